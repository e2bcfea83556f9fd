//! Inserting one laser scan into a [`ProbabilityGrid`] by log-odds ray casting.
//!
//! For every beam with a return, the cell of its end point gets a *hit* (evidence of an
//! obstacle) and every cell the beam crossed on its way there, from the sensor cell up to but
//! excluding the end cell along a Bresenham line, gets a *miss* (evidence of free space). An
//! observation of probability `p` adds `ln(p / (1 - p))` to a cell's log-odds, so the defaults
//! (hit 0.55, miss 0.49) make a cell occupied after a few consistent hits and free after many
//! consistent misses, as in Cartographer's 2D probability-grid inserter.
//!
//! Within one scan each cell is updated at most once, and a hit wins over a miss: neighbouring
//! beams cross the same cells near the sensor, and a grazing beam may pass through the cell
//! another beam ends in. Counting those repeats would make the map depend on the beam density.
//!
//! Optionally, a beam without a return marks the cells along it free up to `miss_range_m`. A
//! [`Scan`] stores no direction for such a beam, so it is taken from the valid beams, assuming
//! the constant angular step laser scanners have.

use serde::{Deserialize, Serialize};

use super::map_limits::CellIndex;
#[cfg(doc)]
use super::probability_grid::MAX_SIDE_CELLS;
use super::probability_grid::{ProbabilityGrid, log_odds_from_probability};
use crate::geometry::Pose2;
use crate::scan_match::{BresenhamLine, Scan};

/// Evidence per observation and treatment of unusual beams.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RangeInserterOptions {
    /// Occupancy probability of one hit, in `(0.5, 1)`; 0.55.
    pub hit_probability: f32,
    /// Occupancy probability of one miss, in `(0, 0.5)`; 0.49.
    pub miss_probability: f32,
    /// If set, beams without a return mark cells free from the sensor out to this range, in
    /// metres; `None` (the default) leaves them out.
    pub miss_range_m: Option<f64>,
    /// End points farther from the sensor than this, in metres, are left out entirely; 100 m,
    /// beyond any range the LMS2xx reports. It also bounds how far one bad point grows a grid.
    pub max_range_m: f64,
}

impl Default for RangeInserterOptions {
    /// Hit 0.55, miss 0.49, no free space from beams without a return, points up to 100 m.
    fn default() -> Self {
        RangeInserterOptions {
            hit_probability: 0.55,
            miss_probability: 0.49,
            miss_range_m: None,
            max_range_m: 100.0,
        }
    }
}

/// Inserts scans into probability grids; keeps scratch space between scans.
#[derive(Clone, Debug)]
pub struct RangeInserter {
    options: RangeInserterOptions,
    hit_log_odds: f32,
    miss_log_odds: f32,
    /// Which cells the scan being inserted has updated.
    marks: UpdateMarks,
    /// End points of beams with a return, in the grid frame.
    hits_in_grid: Vec<[f64; 2]>,
    /// Far ends of the free rays of beams without a return, in the grid frame.
    free_ends_in_grid: Vec<[f64; 2]>,
}

impl RangeInserter {
    /// An inserter applying `options`.
    ///
    /// # Panics
    ///
    /// If `hit_probability` is not in `(0.5, 1)`, `miss_probability` not in `(0, 0.5)`,
    /// `max_range_m` not positive, or `miss_range_m` set but not finite and positive.
    pub fn new(options: RangeInserterOptions) -> Self {
        let RangeInserterOptions {
            hit_probability,
            miss_probability,
            miss_range_m,
            max_range_m,
        } = options;
        assert!(
            hit_probability > 0.5 && hit_probability < 1.0,
            "hit_probability must be in (0.5, 1), got {hit_probability}"
        );
        assert!(
            miss_probability > 0.0 && miss_probability < 0.5,
            "miss_probability must be in (0, 0.5), got {miss_probability}"
        );
        assert!(
            max_range_m > 0.0,
            "max_range_m must be positive, got {max_range_m}"
        );
        if let Some(miss_range_m) = miss_range_m {
            assert!(
                miss_range_m.is_finite() && miss_range_m > 0.0,
                "miss_range_m must be finite and positive, got {miss_range_m}"
            );
        }
        RangeInserter {
            options,
            hit_log_odds: log_odds_from_probability(hit_probability),
            miss_log_odds: log_odds_from_probability(miss_probability),
            marks: UpdateMarks::default(),
            hits_in_grid: Vec::new(),
            free_ends_in_grid: Vec::new(),
        }
    }

    /// The options the inserter applies.
    pub fn options(&self) -> &RangeInserterOptions {
        &self.options
    }

    /// Inserts `scan`, taken with the robot at `grid_from_robot`, into `grid`: a hit at each end
    /// point's cell, a miss in each cell crossed on the way, each cell updated at most once,
    /// hits first. The grid grows to hold every cell touched. A non-finite pose inserts nothing.
    pub fn insert(&mut self, scan: &Scan, grid_from_robot: Pose2, grid: &mut ProbabilityGrid) {
        let sensor_in_grid = [grid_from_robot.x_m, grid_from_robot.y_m];
        let Some((lower, upper)) = self.bounds_in_grid(scan, grid_from_robot) else {
            return;
        };
        // Grow once for the whole scan: the Bresenham cells of a ray stay within the box of its
        // two end cells, so a grid containing every end contains every ray.
        grid.grow_to_include_bounds(lower, upper);
        self.marks.start_scan(grid.limits().num_cells());

        let limits = *grid.limits();
        let sensor_cell = limits.cell_index(sensor_in_grid);
        for &hit_in_grid in &self.hits_in_grid {
            self.marks
                .update_once(grid, limits.cell_index(hit_in_grid), self.hit_log_odds);
        }
        for &hit_in_grid in &self.hits_in_grid {
            let end_cell = limits.cell_index(hit_in_grid);
            let num_free = chebyshev_length(sensor_cell, end_cell);
            self.marks
                .update_ray_once(grid, sensor_cell, end_cell, num_free, self.miss_log_odds);
        }
        for &free_end_in_grid in &self.free_ends_in_grid {
            let end_cell = limits.cell_index(free_end_in_grid);
            let num_cells = chebyshev_length(sensor_cell, end_cell) + 1;
            self.marks
                .update_ray_once(grid, sensor_cell, end_cell, num_cells, self.miss_log_odds);
        }
    }

    /// The box (lower and upper corner, metres in the grid frame) holding every cell that
    /// inserting `scan` at `grid_from_robot` would touch: the sensor and every ray's far end.
    /// `None` for a non-finite pose, which inserts nothing.
    pub fn bounds_in_grid(
        &mut self,
        scan: &Scan,
        grid_from_robot: Pose2,
    ) -> Option<([f64; 2], [f64; 2])> {
        let sensor_in_grid = [grid_from_robot.x_m, grid_from_robot.y_m];
        if !(sensor_in_grid[0].is_finite()
            && sensor_in_grid[1].is_finite()
            && grid_from_robot.theta_rad.is_finite())
        {
            return None;
        }
        self.collect_end_points(scan, grid_from_robot);
        let mut lower = sensor_in_grid;
        let mut upper = sensor_in_grid;
        for point in self.hits_in_grid.iter().chain(&self.free_ends_in_grid) {
            for axis in 0..2 {
                lower[axis] = lower[axis].min(point[axis]);
                upper[axis] = upper[axis].max(point[axis]);
            }
        }
        Some((lower, upper))
    }

    /// The box (as [`Self::bounds_in_grid`]) holding every cell that inserting each of
    /// `scans`, taken at its `robot_pose_in_map`, into a grid placed at `grid_from_map` would
    /// touch; `None` when no scan has a finite pose.
    pub fn bounds_of_scans<'a>(
        &mut self,
        scans: impl IntoIterator<Item = (&'a Scan, Pose2)>,
        grid_from_map: Pose2,
    ) -> Option<([f64; 2], [f64; 2])> {
        let mut bounds: Option<([f64; 2], [f64; 2])> = None;
        for (scan, robot_pose_in_map) in scans {
            let Some((lower, upper)) = self.bounds_in_grid(scan, grid_from_map * robot_pose_in_map)
            else {
                continue;
            };
            bounds = Some(match bounds {
                None => (lower, upper),
                Some((l, u)) => (
                    [l[0].min(lower[0]), l[1].min(lower[1])],
                    [u[0].max(upper[0]), u[1].max(upper[1])],
                ),
            });
        }
        bounds
    }

    /// The end points of beams with a return that the last [`Self::bounds_in_grid`] placed, in
    /// the grid frame: the cells [`Self::insert`] would mark hit, in that order.
    pub(crate) fn hits_in_grid(&self) -> &[[f64; 2]] {
        &self.hits_in_grid
    }

    /// The log-odds a hit and a miss add.
    pub(crate) fn hit_and_miss_log_odds(&self) -> (f32, f32) {
        (self.hit_log_odds, self.miss_log_odds)
    }

    /// Fills `hits_in_grid` and `free_ends_in_grid` for `scan` at `grid_from_robot`.
    fn collect_end_points(&mut self, scan: &Scan, grid_from_robot: Pose2) {
        self.hits_in_grid.clear();
        self.free_ends_in_grid.clear();
        let max_range_m = self.options.max_range_m;
        self.hits_in_grid.extend(
            scan.points_in_robot()
                .iter()
                .flatten()
                .filter(|p| p[0].hypot(p[1]) <= max_range_m)
                .map(|&p| grid_from_robot.transform_point(p)),
        );
        let Some(miss_range_m) = self.options.miss_range_m else {
            return;
        };
        let Some(beam_angles_rad) = beam_angles_rad(scan.points_in_robot()) else {
            return;
        };
        for (point, angle_rad) in scan.points_in_robot().iter().zip(beam_angles_rad) {
            if point.is_none() {
                let (sin, cos) = angle_rad.sin_cos();
                let free_end_in_robot = [miss_range_m * cos, miss_range_m * sin];
                self.free_ends_in_grid
                    .push(grid_from_robot.transform_point(free_end_in_robot));
            }
        }
    }
}

/// For each grid cell, the number of the scan that last updated it, so that a scan updates each
/// cell at most once without clearing a grid-sized buffer per scan.
#[derive(Clone, Debug, Default)]
struct UpdateMarks {
    /// Per grid cell (row-major), the number of the scan that last updated it.
    updated_in_scan: Vec<u32>,
    /// Number of the scan being inserted; never 0 once started, 0 marking cells never updated.
    scan_number: u32,
}

impl UpdateMarks {
    /// Starts a new scan over a grid of `num_cells` cells: no cell updated yet.
    ///
    /// When the grid grew, its cells moved to other indices and the marks left there are
    /// meaningless, but they are all numbers of earlier scans, never the new scan's: the buffer
    /// is kept and only lengthened. Only when the scan numbers wrap does it start afresh.
    fn start_scan(&mut self, num_cells: usize) {
        if self.updated_in_scan.len() < num_cells || self.scan_number == u32::MAX {
            // A new buffer (growing the old one would copy marks that no longer count), with
            // room for the grid to grow by half before the next.
            self.updated_in_scan = vec![0; num_cells + num_cells / 2];
            self.scan_number = 0;
        }
        self.scan_number += 1;
    }

    /// Adds `delta_log_odds` once to each of the first `num_cells` cells of the Bresenham
    /// line from `from` to `to` ([`BresenhamLine`]'s cells, in its order) that this scan has
    /// not updated yet.
    ///
    /// The line is walked by storage index
    /// ([`MapLimits::line_indices`](super::MapLimits::line_indices)) when both ends lie in the
    /// grid. A ray reaching beyond a grid that could not grow to hold it ([`MAX_SIDE_CELLS`])
    /// is walked cell by cell.
    fn update_ray_once(
        &mut self,
        grid: &mut ProbabilityGrid,
        from: CellIndex,
        to: CellIndex,
        num_cells: usize,
        delta_log_odds: f32,
    ) {
        let Some(indices) = grid.limits().line_indices(from, to) else {
            for cell in BresenhamLine::new(from, to).take(num_cells) {
                self.update_once(grid, cell, delta_log_odds);
            }
            return;
        };
        let scan_number = self.scan_number;
        let (log_odds, bounds) = grid.log_odds_mut();
        let marks = &mut self.updated_in_scan;
        for cell in indices.take(num_cells) {
            if marks[cell] != scan_number {
                marks[cell] = scan_number;
                log_odds[cell] = bounds.updated(log_odds[cell], delta_log_odds);
            }
        }
    }

    /// Adds `delta_log_odds` to `cell` unless it was already updated in this scan.
    fn update_once(&mut self, grid: &mut ProbabilityGrid, cell: CellIndex, delta_log_odds: f32) {
        // Only a grid that could not grow to hold the scan leaves cells outside.
        let Some(index) = grid.limits().linear_index(cell) else {
            return;
        };
        if self.updated_in_scan[index] != self.scan_number {
            self.updated_in_scan[index] = self.scan_number;
            grid.update_log_odds_at(index, delta_log_odds);
        }
    }
}

/// Number of cells on the Bresenham line from `from` to `to` before `to`.
pub(super) fn chebyshev_length(from: CellIndex, to: CellIndex) -> usize {
    let dx = (i64::from(to[0]) - i64::from(from[0])).unsigned_abs();
    let dy = (i64::from(to[1]) - i64::from(from[1])).unsigned_abs();
    dx.max(dy) as usize
}

/// The direction of every beam in the robot frame, in radians: measured for beams with a return,
/// inferred for the others from the nearest beam with a return and the median angular step
/// between consecutive beams with a return. `None` with fewer than two beams with a return.
fn beam_angles_rad(points_in_robot: &[Option<[f64; 2]>]) -> Option<Vec<f64>> {
    let measured: Vec<(usize, f64)> = points_in_robot
        .iter()
        .enumerate()
        .filter_map(|(beam, point)| point.map(|p| (beam, p[1].atan2(p[0]))))
        .collect();
    let mut steps_rad: Vec<f64> = measured
        .windows(2)
        .map(|pair| {
            let turn_rad = Pose2::new(0.0, 0.0, pair[1].1 - pair[0].1).theta_rad;
            turn_rad / (pair[1].0 - pair[0].0) as f64
        })
        .collect();
    if steps_rad.is_empty() {
        return None;
    }
    steps_rad.sort_by(f64::total_cmp);
    let step_rad = steps_rad[steps_rad.len() / 2];
    let mut nearest = 0;
    let angles_rad = (0..points_in_robot.len())
        .map(|beam| {
            while nearest + 1 < measured.len()
                && measured[nearest + 1].0.abs_diff(beam) <= measured[nearest].0.abs_diff(beam)
            {
                nearest += 1;
            }
            let (measured_beam, measured_angle_rad) = measured[nearest];
            measured_angle_rad + (beam as f64 - measured_beam as f64) * step_rad
        })
        .collect();
    Some(angles_rad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::probability_grid::ProbabilityGridOptions;
    use std::f64::consts::FRAC_PI_2;

    fn grid() -> ProbabilityGrid {
        ProbabilityGrid::new(0.1, ProbabilityGridOptions::default())
    }

    #[test]
    fn test_single_beam_marks_free_then_occupied() {
        let mut grid = grid();
        let mut inserter = RangeInserter::new(RangeInserterOptions::default());
        let scan = Scan::from_points_in_robot(vec![Some([1.0, 0.0])]);
        // Robot at (0.05, 0.05) facing +y: the beam runs from cell [0, 0] up to cell [0, 10].
        inserter.insert(&scan, Pose2::new(0.05, 0.05, FRAC_PI_2), &mut grid);
        let limits = *grid.limits();
        for row in 0..10 {
            let p = grid.probability(limits.cell_index([0.05, 0.05 + row as f64 * 0.1]));
            assert!((p.unwrap() - 0.49).abs() < 1e-6, "row {row}: {p:?}");
        }
        let end = grid.probability_at([0.05, 1.05]).unwrap();
        assert!((end - 0.55).abs() < 1e-6);
        assert_eq!(grid.num_known_cells(), 11);
        assert_eq!(grid.probability_at([0.15, 0.55]), None);
        assert_eq!(grid.probability_at([0.05, 1.15]), None);
    }

    #[test]
    fn test_each_cell_once_per_scan_and_hits_win() {
        let mut grid = grid();
        let mut inserter = RangeInserter::new(RangeInserterOptions::default());
        // Three beams along x: two end in the same cell, the third passes through it.
        let scan = Scan::from_points_in_robot(vec![
            Some([0.52, 0.0]),
            Some([0.54, 0.01]),
            Some([0.9, 0.0]),
        ]);
        inserter.insert(&scan, Pose2::new(0.05, 0.05, 0.0), &mut grid);
        let p_shared_end = grid.probability_at([0.55, 0.05]).unwrap();
        assert!((p_shared_end - 0.55).abs() < 1e-6, "{p_shared_end}");
        let p_near = grid.probability_at([0.25, 0.05]).unwrap();
        assert!((p_near - 0.49).abs() < 1e-6, "{p_near}");
        let p_far = grid.probability_at([0.95, 0.05]).unwrap();
        assert!((p_far - 0.55).abs() < 1e-6, "{p_far}");

        // A second scan adds once more.
        inserter.insert(&scan, Pose2::new(0.05, 0.05, 0.0), &mut grid);
        let expected = probability_after(&[0.55, 0.55]);
        let p = grid.probability_at([0.55, 0.05]).unwrap();
        assert!((p - expected).abs() < 1e-6, "{p} != {expected}");
    }

    #[test]
    fn test_square_room_is_free_inside_and_occupied_on_walls() {
        let walls = crate::scan_match::synthetic::polygon_walls(&[
            [-1.0, -1.0],
            [2.0, -1.0],
            [2.0, 1.5],
            [-1.0, 1.5],
        ]);
        let pose_in_map = Pose2::new(0.3, 0.2, 0.4);
        let scan = crate::scan_match::synthetic::cast_scan(
            &walls,
            pose_in_map,
            -std::f64::consts::PI,
            std::f64::consts::PI / 180.0,
            360,
            20.0,
        );
        let mut grid = ProbabilityGrid::new(0.05, ProbabilityGridOptions::default());
        let mut inserter = RangeInserter::new(RangeInserterOptions::default());
        for _ in 0..20 {
            inserter.insert(&scan, pose_in_map, &mut grid);
        }
        // The room's interior, away from the walls, is free.
        for point in [[0.0, 0.0], [1.5, 1.0], [-0.7, -0.7], [1.7, -0.6]] {
            let p = grid.probability_at(point).unwrap();
            assert!(p < 0.4, "{point:?}: {p}");
        }
        // Beam ends are occupied.
        for point in scan.points_in_robot().iter().flatten() {
            let p = grid
                .probability_at(pose_in_map.transform_point(*point))
                .unwrap();
            assert!(p > 0.6, "{point:?}: {p}");
        }
        // Beyond the walls nothing is known.
        for point in [[2.3, 0.0], [0.0, 1.8], [-1.3, -1.3]] {
            assert_eq!(grid.probability_at(point), None);
        }
    }

    #[test]
    fn test_rays_without_return_are_free_when_asked() {
        let points = vec![Some([1.0, 0.0]), None, Some([0.0, 1.0])];
        let scan = Scan::from_points_in_robot(points);
        let mut plain = grid();
        RangeInserter::new(RangeInserterOptions::default()).insert(
            &scan,
            Pose2::IDENTITY,
            &mut plain,
        );
        assert_eq!(plain.probability_at([0.5, 0.5]), None);

        let mut with_free = grid();
        let options = RangeInserterOptions {
            miss_range_m: Some(1.0),
            ..RangeInserterOptions::default()
        };
        RangeInserter::new(options).insert(&scan, Pose2::IDENTITY, &mut with_free);
        // The missing beam points at 45 degrees, free out to 1 m.
        let p = with_free.probability_at([0.5, 0.5]).unwrap();
        assert!((p - 0.49).abs() < 1e-6);
        assert!(with_free.probability_at([0.65, 0.65]).is_some());
        assert_eq!(with_free.probability_at([0.8, 0.8]), None);
    }

    #[test]
    fn test_beam_angles_are_inferred() {
        let step = 0.1f64;
        let points: Vec<Option<[f64; 2]>> = (0..8)
            .map(|beam| {
                let angle = -0.3 + beam as f64 * step;
                (beam % 3 != 0).then(|| [2.0 * angle.cos(), 2.0 * angle.sin()])
            })
            .collect();
        let angles = beam_angles_rad(&points).unwrap();
        for (beam, angle) in angles.iter().enumerate() {
            assert!(
                (angle - (-0.3 + beam as f64 * step)).abs() < 1e-9,
                "{beam}: {angle}"
            );
        }
        assert_eq!(beam_angles_rad(&[None, Some([1.0, 0.0]), None]), None);
    }

    #[test]
    fn test_far_points_and_bad_poses_are_ignored() {
        let mut grid = grid();
        let mut inserter = RangeInserter::new(RangeInserterOptions::default());
        let scan = Scan::from_points_in_robot(vec![Some([1e9, 0.0])]);
        inserter.insert(&scan, Pose2::IDENTITY, &mut grid);
        assert_eq!(grid.num_known_cells(), 0);
        assert!(grid.limits().width_cells() < 1000);
        let scan = Scan::from_points_in_robot(vec![Some([1.0, 0.0])]);
        inserter.insert(&scan, Pose2::new(f64::NAN, 0.0, 0.0), &mut grid);
        assert_eq!(grid.num_known_cells(), 0);
    }

    /// The inserter's rule spelt out cell by cell: the grid grown to the scan's box, a hit in
    /// every end cell, then a miss in every cell of every ray's Bresenham line short of its
    /// end, each cell updated once.
    fn insert_cell_by_cell(
        scan: &Scan,
        grid_from_robot: Pose2,
        grid: &mut ProbabilityGrid,
        options: RangeInserterOptions,
    ) {
        let mut inserter = RangeInserter::new(options);
        let Some((lower, upper)) = inserter.bounds_in_grid(scan, grid_from_robot) else {
            return;
        };
        grid.grow_to_include_bounds(lower, upper);
        let limits = *grid.limits();
        let sensor = limits.cell_index([grid_from_robot.x_m, grid_from_robot.y_m]);
        let mut updated = std::collections::HashSet::new();
        let mut update = |grid: &mut ProbabilityGrid, cell: CellIndex, delta: f32| {
            if updated.insert(cell) {
                grid.update_log_odds(cell, delta);
            }
        };
        for hit in &inserter.hits_in_grid {
            update(grid, limits.cell_index(*hit), inserter.hit_log_odds);
        }
        for hit in &inserter.hits_in_grid {
            let end = limits.cell_index(*hit);
            let line: Vec<CellIndex> = BresenhamLine::new(sensor, end).collect();
            for &cell in &line[..line.len() - 1] {
                update(grid, cell, inserter.miss_log_odds);
            }
        }
        for free_end in &inserter.free_ends_in_grid {
            for cell in BresenhamLine::new(sensor, limits.cell_index(*free_end)) {
                update(grid, cell, inserter.miss_log_odds);
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

        /// Rays walked by storage index update the cells the rule names, to the bit, over
        /// several scans that grow the grid in every direction.
        #[test]
        fn rays_walked_by_index_update_the_cells_the_rule_names(
            scans in proptest::collection::vec(
                (
                    (-3.0f64..3.0, -3.0f64..3.0, -3.2f64..3.2),
                    proptest::collection::vec(
                        proptest::option::weighted(0.8, (0.05f64..6.0, -1.6f64..1.6)),
                        2..40,
                    ),
                ),
                1..5,
            ),
            miss_range in proptest::option::of(1.0f64..4.0),
        ) {
            let options = RangeInserterOptions {
                miss_range_m: miss_range,
                ..RangeInserterOptions::default()
            };
            let mut fast = grid();
            let mut expected = grid();
            let mut inserter = RangeInserter::new(options);
            for ((x, y, theta), beams) in &scans {
                let pose = Pose2::new(*x, *y, *theta);
                let points = beams
                    .iter()
                    .map(|beam| beam.map(|(r, a): (f64, f64)| [r * a.cos(), r * a.sin()]))
                    .collect();
                let scan = Scan::from_points_in_robot(points);
                inserter.insert(&scan, pose, &mut fast);
                insert_cell_by_cell(&scan, pose, &mut expected, options);
            }
            proptest::prop_assert!(fast.same_values(&expected));
        }
    }

    #[test]
    fn rays_beyond_a_grid_that_cannot_grow_keep_their_cells_inside() {
        use crate::grid::probability_grid::MAX_SIDE_CELLS;
        // A grid already at the largest side, and a beam far beyond it.
        let mut fast = grid();
        let side_m = MAX_SIDE_CELLS as f64 * 0.1;
        fast.grow_to_include_bounds([0.0, 0.0], [side_m - 20.0, 1.0]);
        let mut expected = fast.clone();
        // 90 m ahead from 30 m short of the grid's end.
        let scan = Scan::from_points_in_robot(vec![Some([90.0, 0.3]), Some([2.0, 0.0])]);
        let pose = Pose2::new(side_m - 30.0, 0.5, 0.0);
        RangeInserter::new(RangeInserterOptions::default()).insert(&scan, pose, &mut fast);
        insert_cell_by_cell(&scan, pose, &mut expected, RangeInserterOptions::default());
        // The grid stopped at its largest side, short of the far end point.
        assert!(fast.limits().width_cells() <= MAX_SIDE_CELLS);
        assert!(
            !fast
                .limits()
                .contains_point(pose.transform_point([90.0, 0.3]))
        );
        assert!(fast.num_known_cells() > 100);
        assert!(fast.same_values(&expected));
    }

    /// The probability after independent observations of `probabilities`, from even odds.
    fn probability_after(probabilities: &[f32]) -> f32 {
        let log_odds: f32 = probabilities
            .iter()
            .map(|&p| log_odds_from_probability(p))
            .sum();
        1.0 / (1.0 + (-log_odds).exp())
    }
}
