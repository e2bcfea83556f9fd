//! A smooth view of a probability grid, for matching scans with sub-cell precision.
//!
//! A [`ProbabilityGrid`] is piecewise constant: its value does not change within a cell, so it
//! gives an optimiser no slope to follow. This view interpolates the cell probabilities with a
//! bicubic Catmull-Rom spline through the cell centres (Keys 1981, "Cubic convolution
//! interpolation for digital image processing", with `a = -1/2`), which passes through every
//! centre value, has a continuous first derivative, and needs only the 4 × 4 nearest cells. The
//! gradient and the second derivatives (for a Newton step) are computed analytically alongside
//! the value.
//!
//! Unknown cells, and everything outside the grid, read as the grid's `min_probability`: a scan
//! point gains nothing by drifting into unexplored space.
//!
//! Two levels are kept: the grid itself ([`GridLevel::Sharp`]) and the grid blurred by the
//! binomial kernel `[1, 2, 1] / 4` along each axis ([`GridLevel::Smoothed`], a spread of about
//! 0.7 cells). A wall's slope on the smoothed level reaches about a cell farther, which lets a
//! matcher start farther off; its peak sits slightly off the wall where the two sides of the
//! wall differ (free space in front, unknown behind), so the sharp level has the last word.
//!
//! The view is a copy taken when built; build it again after the grid changes (or once, when a
//! submap is finished). It stores two `f32` per cell.

use super::probability_grid::ProbabilityGrid;

/// Cells of low probability added around the grid, so the 4 × 4 stencil of any point within
/// the grid or up to 2.5 cells beyond it stays inside the stored values, and the interpolation
/// (of either level: the blur spreads the grid one cell into the padding) has settled to the
/// constant outside value with a zero slope where the stencil leaves them.
const PADDING_CELLS: usize = 4;

/// Bicubic interpolation of a [`ProbabilityGrid`]'s probabilities, sharp and smoothed, with
/// derivatives.
#[derive(Clone, Debug)]
pub struct InterpolatedGrid {
    /// Probabilities, row-major, the grid's cells surrounded by [`PADDING_CELLS`] of
    /// `outside_probability` on each side.
    probabilities: Vec<f32>,
    /// `probabilities` blurred, same layout.
    smoothed: Vec<f32>,
    width_cells: usize,
    height_cells: usize,
    /// Centre of stored cell `[0, 0]` (a padding cell) in the grid frame, metres.
    first_center_in_grid: [f64; 2],
    cells_per_m: f64,
    outside_probability: f32,
}

impl InterpolatedGrid {
    /// Copies the probabilities of `grid`, unknown cells reading as its `min_probability`, and
    /// blurs a second copy.
    pub fn new(grid: &ProbabilityGrid) -> Self {
        let limits = grid.limits();
        let outside_probability = grid.options().min_probability;
        let width_cells = limits.width_cells() + 2 * PADDING_CELLS;
        let height_cells = limits.height_cells() + 2 * PADDING_CELLS;
        let mut probabilities = vec![outside_probability; width_cells * height_cells];
        for row in 0..limits.height_cells() {
            let start = (row + PADDING_CELLS) * width_cells + PADDING_CELLS;
            let stored = &mut probabilities[start..start + limits.width_cells()];
            for (column, probability) in stored.iter_mut().enumerate() {
                // Both indices are below the grid's size, which fits in i32 as every cell of the
                // grid has an `i32` index.
                let cell = [column as i32, row as i32];
                if let Some(p) = grid.probability(cell) {
                    *probability = p;
                }
            }
        }
        let mut smoothed = probabilities.clone();
        smooth(&mut smoothed, width_cells);
        let resolution_m = limits.resolution_m();
        let lower_corner = limits.lower_corner_in_grid();
        let first_center_offset_m = (0.5 - PADDING_CELLS as f64) * resolution_m;
        InterpolatedGrid {
            probabilities,
            smoothed,
            width_cells,
            height_cells,
            first_center_in_grid: [
                lower_corner[0] + first_center_offset_m,
                lower_corner[1] + first_center_offset_m,
            ],
            cells_per_m: 1.0 / resolution_m,
            outside_probability,
        }
    }

    /// Side of one cell, in metres.
    pub fn resolution_m(&self) -> f64 {
        1.0 / self.cells_per_m
    }

    /// The value read for unknown cells and outside the grid.
    pub fn outside_probability(&self) -> f32 {
        self.outside_probability
    }

    /// The interpolated occupancy probability at `point_in_grid` (metres), sharp level.
    pub fn probability(&self, point_in_grid: [f64; 2]) -> f64 {
        self.evaluate(point_in_grid).probability
    }

    /// The interpolated occupancy probability at `point_in_grid` (metres) with its first and
    /// second derivatives with respect to the point. Far outside the grid, or at a non-finite
    /// point, the probability is the outside value and the derivatives zero.
    #[inline]
    pub fn evaluate(&self, point_in_grid: [f64; 2]) -> InterpolatedProbability {
        self.evaluate_level(GridLevel::Sharp, point_in_grid)
    }

    /// As [`InterpolatedGrid::evaluate`], reading the grid at `level`.
    #[inline]
    pub fn evaluate_level(
        &self,
        level: GridLevel,
        point_in_grid: [f64; 2],
    ) -> InterpolatedProbability {
        self.evaluate_four(level, [point_in_grid; 4])[0]
    }

    /// [`InterpolatedGrid::evaluate_level`] at four points at once, which is faster than four
    /// calls: the points run side by side in SIMD lanes.
    #[inline]
    pub fn evaluate_four(
        &self,
        level: GridLevel,
        points_in_grid: [[f64; 2]; 4],
    ) -> [InterpolatedProbability; 4] {
        let samples = match level {
            GridLevel::Sharp => &self.probabilities,
            GridLevel::Smoothed => &self.smoothed,
        };
        // Offsets within the cell, per lane, in single precision: the samples are `f32`, and
        // four of them fill one SIMD register.
        let mut tx = [0.0f32; 4];
        let mut inside = [false; 4];
        // `along_y[k][c][lane]`: along stencil column `c` of the point of `lane`, the cubic
        // through the four rows at the point's offset (k = 0), its slope (1), its curvature (2).
        // A point whose stencil leaves the stored cells reads the outside value.
        let mut along_y = [[[0.0f32; 4]; 4]; 3];
        along_y[0] = [[self.outside_probability; 4]; 4];
        for (lane, point_in_grid) in points_in_grid.iter().enumerate() {
            // Continuous cell coordinates: stored cell `[i, j]` has its centre at `(i, j)`.
            let u = (point_in_grid[0] - self.first_center_in_grid[0]) * self.cells_per_m;
            let v = (point_in_grid[1] - self.first_center_in_grid[1]) * self.cells_per_m;
            // The stencil spans cells `floor(u) - 1 ..= floor(u) + 2`, likewise along v.
            // Written so that NaN fails the test too.
            let stencil_inside = u >= 1.0
                && u < (self.width_cells - 2) as f64
                && v >= 1.0
                && v < (self.height_cells - 2) as f64;
            if !stencil_inside {
                continue;
            }
            // Truncation is `floor` for these positive coordinates, and cheaper.
            let (u_floor, v_floor) = (u as usize, v as usize);
            tx[lane] = (u - u_floor as f64) as f32;
            let ty = (v - v_floor as f64) as f32;
            // The stencil's four rows, each four cells wide: the columns run in SIMD lanes.
            let mut rows = [[0.0f32; 4]; 4];
            for (r, stencil_row) in rows.iter_mut().enumerate() {
                let start = (v_floor - 1 + r) * self.width_cells + u_floor - 1;
                if let Some(cells) = samples[start..].first_chunk::<4>() {
                    *stencil_row = *cells;
                }
            }
            inside[lane] = true;
            let [value, slope, curvature] = CatmullRom::through(rows).derivatives([ty; 4]);
            for c in 0..4 {
                along_y[0][c][lane] = value[c];
                along_y[1][c][lane] = slope[c];
                along_y[2][c][lane] = curvature[c];
            }
        }
        // Then along x. Derivatives are with respect to the cell coordinates u and v.
        let [value, du, duu] = CatmullRom::through(along_y[0]).derivatives(tx);
        let [dv, duv, _] = CatmullRom::through(along_y[1]).derivatives(tx);
        let [dvv, _, _] = CatmullRom::through(along_y[2]).derivatives(tx);
        let s = self.cells_per_m;
        let s2 = s * s;
        std::array::from_fn(|lane| {
            if !inside[lane] {
                // Exactly the outside value: the cubic through four equal samples is only
                // nearly constant in floating point.
                return InterpolatedProbability {
                    probability: f64::from(self.outside_probability),
                    ..InterpolatedProbability::default()
                };
            }
            let [du, dv] = [du[lane], dv[lane]].map(|d| f64::from(d) * s);
            let [duu, duv, dvv] = [duu[lane], duv[lane], dvv[lane]].map(|d| f64::from(d) * s2);
            InterpolatedProbability {
                probability: f64::from(value[lane]),
                gradient_per_m: [du, dv],
                hessian_per_m2: [[duu, duv], [duv, dvv]],
            }
        })
    }
}

/// Which version of the grid an [`InterpolatedGrid`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridLevel {
    /// The grid's own probabilities.
    Sharp,
    /// The probabilities blurred over about a cell either side: slopes reach farther from the
    /// walls, so a matcher starting farther off still finds its way, at the price of precision.
    Smoothed,
}

/// The interpolated probability at a point, with its derivatives with respect to the point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InterpolatedProbability {
    /// The occupancy probability; can leave `[0, 1]` slightly between very different cells, as
    /// cubic interpolation overshoots.
    pub probability: f64,
    /// `[∂P/∂x, ∂P/∂y]`, per metre.
    pub gradient_per_m: [f64; 2],
    /// `[[∂²P/∂x², ∂²P/∂x∂y], [∂²P/∂y∂x, ∂²P/∂y²]]`, per square metre.
    pub hessian_per_m2: [[f64; 2]; 2],
}

/// Catmull-Rom cubics `a + b t + c t² + d t³` through samples at `t = -1, 0, 1, 2`, four of
/// them side by side (one per SIMD lane), between the samples at 0 and 1.
struct CatmullRom {
    a: [f32; 4],
    b: [f32; 4],
    c: [f32; 4],
    d: [f32; 4],
}

impl CatmullRom {
    /// The cubics through `samples[0..4]`, lane by lane: each passes through `samples[1]` at 0
    /// and `samples[2]` at 1, with slopes `(samples[2] - samples[0]) / 2` and
    /// `(samples[3] - samples[1]) / 2` there.
    #[inline]
    fn through(samples: [[f32; 4]; 4]) -> Self {
        let [p0, p1, p2, p3] = samples;
        let mut cubic = CatmullRom {
            a: p1,
            b: [0.0; 4],
            c: [0.0; 4],
            d: [0.0; 4],
        };
        for lane in 0..4 {
            cubic.b[lane] = 0.5 * (p2[lane] - p0[lane]);
            cubic.c[lane] = p0[lane] - 2.5 * p1[lane] + 2.0 * p2[lane] - 0.5 * p3[lane];
            cubic.d[lane] = 0.5 * (p3[lane] - p0[lane]) + 1.5 * (p1[lane] - p2[lane]);
        }
        cubic
    }

    /// Value, first and second derivative of each lane's cubic at that lane's `t`.
    #[inline]
    fn derivatives(&self, t: [f32; 4]) -> [[f32; 4]; 3] {
        let mut out = [[0.0f32; 4]; 3];
        for lane in 0..4 {
            let (a, b, c, d, t) = (
                self.a[lane],
                self.b[lane],
                self.c[lane],
                self.d[lane],
                t[lane],
            );
            out[0][lane] = a + t * (b + t * (c + t * d));
            out[1][lane] = b + t * (2.0 * c + 3.0 * t * d);
            out[2][lane] = 2.0 * c + 6.0 * t * d;
        }
        out
    }
}

/// Blurs `samples` (rows of `width` values) in place by the binomial kernel `[1, 2, 1] / 4`
/// along rows, then along columns, leaving the outermost rows and columns as they are.
fn smooth(samples: &mut [f32], width: usize) {
    let height = samples.len() / width;
    let source = samples.to_vec();
    for row in 0..height {
        for column in 1..width.saturating_sub(1) {
            let i = row * width + column;
            samples[i] = 0.25 * source[i - 1] + 0.5 * source[i] + 0.25 * source[i + 1];
        }
    }
    let source = samples.to_vec();
    for row in 1..height.saturating_sub(1) {
        for column in 0..width {
            let i = row * width + column;
            samples[i] = 0.25 * source[i - width] + 0.5 * source[i] + 0.25 * source[i + width];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::map_limits::MapLimits;
    use crate::grid::probability_grid::{ProbabilityGridOptions, log_odds_from_probability};

    /// A 6 × 5 grid of 0.1 m cells at (-0.3, 0.2) with a few known cells.
    fn grid() -> ProbabilityGrid {
        let mut grid = ProbabilityGrid::with_limits(
            MapLimits::new(0.1, [-0.3, 0.2], 6, 5),
            ProbabilityGridOptions::default(),
        );
        for (cell, p) in [
            ([2, 2], 0.9f32),
            ([3, 2], 0.7),
            ([2, 3], 0.3),
            ([1, 1], 0.5),
            ([4, 1], 0.95),
        ] {
            grid.update_log_odds(cell, log_odds_from_probability(p));
        }
        grid
    }

    #[test]
    fn test_cubic_through_samples() {
        // Lane 0 a general cubic, lane 1 a straight line, lanes 2 and 3 constants.
        let cubic = CatmullRom::through([
            [0.3, 1.0, 0.0, 0.5],
            [0.9, 2.0, 0.0, 0.5],
            [0.2, 3.0, 0.0, 0.5],
            [0.6, 4.0, 0.0, 0.5],
        ]);
        let [at_0, slope_0, _] = cubic.derivatives([0.0; 4]);
        let [at_1, slope_1, _] = cubic.derivatives([1.0; 4]);
        assert!((at_0[0] - 0.9).abs() < 1e-6 && (at_1[0] - 0.2).abs() < 1e-6);
        assert!((slope_0[0] - (0.2 - 0.3) / 2.0).abs() < 1e-6);
        assert!((slope_1[0] - (0.6 - 0.9) / 2.0).abs() < 1e-6);
        let [value, slope, curvature] = cubic.derivatives([0.3; 4]);
        assert!((value[1] - 2.3).abs() < 1e-6 && (slope[1] - 1.0).abs() < 1e-6);
        assert!(curvature[1].abs() < 1e-6);
        assert_eq!([value[3], slope[3], curvature[3]], [0.5, 0.0, 0.0]);
    }

    #[test]
    fn test_four_at_once_matches_one_at_a_time() {
        let interpolated = InterpolatedGrid::new(&grid());
        let points = [[-0.07, 0.43], [5.0, 0.0], [0.14, 0.31], [-0.2, 0.6]];
        let four = interpolated.evaluate_four(GridLevel::Sharp, points);
        for (point, at_point) in points.iter().zip(four) {
            assert_eq!(interpolated.evaluate(*point), at_point);
        }
    }

    #[test]
    fn test_passes_through_cell_centres() {
        let grid = grid();
        let interpolated = InterpolatedGrid::new(&grid);
        for column in 0..6 {
            for row in 0..5 {
                let center = grid.limits().cell_center_in_grid([column, row]);
                let expected = grid.probability([column, row]).unwrap_or(0.12);
                let value = interpolated.probability(center);
                assert!((value - f64::from(expected)).abs() < 1e-6, "{column} {row}");
            }
        }
    }

    #[test]
    fn test_outside_reads_low() {
        let interpolated = InterpolatedGrid::new(&grid());
        for point in [[-5.0, 0.0], [0.0, 50.0], [f64::NAN, 0.5], [-0.6, 0.25]] {
            let at_point = interpolated.evaluate(point);
            let smoothed = interpolated.evaluate_level(GridLevel::Smoothed, point);
            assert_eq!(at_point, smoothed);
            assert!((at_point.probability - 0.12).abs() < 1e-6, "{point:?}");
            assert_eq!(at_point.gradient_per_m, [0.0, 0.0]);
            assert_eq!(at_point.hessian_per_m2, [[0.0, 0.0], [0.0, 0.0]]);
        }
    }

    #[test]
    fn test_derivatives_match_finite_differences() {
        let interpolated = InterpolatedGrid::new(&grid());
        // Single-precision arithmetic inside: a step of a thousandth of a cell.
        let h = 1e-4;
        for point in [[-0.07, 0.43], [0.011, 0.52], [0.14, 0.31], [-0.2, 0.6]] {
            let at_point = interpolated.evaluate(point);
            for axis in 0..2 {
                let mut ahead = point;
                let mut behind = point;
                ahead[axis] += h;
                behind[axis] -= h;
                let (ahead, behind) = (interpolated.evaluate(ahead), interpolated.evaluate(behind));
                let slope = (ahead.probability - behind.probability) / (2.0 * h);
                let gradient = at_point.gradient_per_m[axis];
                assert!(
                    (gradient - slope).abs() < 1e-3 * (1.0 + slope.abs()),
                    "{point:?} {axis}: {gradient} vs {slope}"
                );
                for other in 0..2 {
                    let curvature =
                        (ahead.gradient_per_m[other] - behind.gradient_per_m[other]) / (2.0 * h);
                    let hessian = at_point.hessian_per_m2[axis][other];
                    assert!(
                        (hessian - curvature).abs() < 1e-2 * (1.0 + curvature.abs()),
                        "{point:?} {axis} {other}: {hessian} vs {curvature}"
                    );
                }
            }
        }
    }

    #[test]
    fn test_smoothed_level_spreads_a_wall() {
        // A wall one cell thick along y at column 10 of a 21 × 9 grid, free space elsewhere.
        let mut grid = ProbabilityGrid::with_limits(
            MapLimits::new(0.1, [0.0, 0.0], 21, 9),
            ProbabilityGridOptions::default(),
        );
        for column in 0..21 {
            for row in 0..9 {
                let p = if column == 10 { 0.9f32 } else { 0.2 };
                grid.update_log_odds([column, row], log_odds_from_probability(p));
            }
        }
        let interpolated = InterpolatedGrid::new(&grid);
        let wall = [1.05, 0.45];
        let two_cells_off = [0.85, 0.45];
        let sharp = interpolated.evaluate_level(GridLevel::Sharp, two_cells_off);
        let smoothed = interpolated.evaluate_level(GridLevel::Smoothed, two_cells_off);
        assert!(sharp.gradient_per_m[0].abs() < 1e-6, "{sharp:?}");
        assert!(smoothed.gradient_per_m[0] > 0.1, "{smoothed:?}");
        // Both peak on the wall, the smoothed level lower.
        let sharp_peak = interpolated.evaluate_level(GridLevel::Sharp, wall);
        let smoothed_peak = interpolated.evaluate_level(GridLevel::Smoothed, wall);
        assert!((sharp_peak.probability - 0.9).abs() < 1e-6);
        assert!((smoothed_peak.probability - (0.5 * 0.9 + 0.5 * 0.2)).abs() < 1e-6);
        assert!(sharp_peak.gradient_per_m[0].abs() < 1e-4);
        assert!(smoothed_peak.gradient_per_m[0].abs() < 1e-4);
    }

    #[test]
    fn test_continuous_across_cell_borders() {
        let interpolated = InterpolatedGrid::new(&grid());
        // Cell centres are at -0.25 + 0.1 k along x: the border between spline pieces is there.
        for x in [-0.25, -0.15, -0.05, 0.05] {
            let below = interpolated.evaluate([x - 1e-9, 0.47]);
            let above = interpolated.evaluate([x + 1e-9, 0.47]);
            assert!((below.probability - above.probability).abs() < 1e-6);
            assert!((below.gradient_per_m[0] - above.gradient_per_m[0]).abs() < 1e-4);
        }
    }
}
