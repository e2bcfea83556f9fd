//! The geometry of a regular grid of square cells: where it sits, how fine it is, how big it is.
//!
//! A grid lives in some frame, called the *grid frame* here (the submap frame for a submap, the
//! map frame for a global map). Cell `[column, row]` covers the square whose lower corner is
//! `lower_corner_in_grid + resolution_m * [column, row]`: columns grow along x, rows along y, so
//! row 0 is the *bottom* row (images flip this when exported). A point on a cell's lower or left
//! edge belongs to that cell; one on its upper or right edge belongs to the next.
//!
//! Cell indices are signed: a point outside the grid still has an index, which
//! [`MapLimits::contains`] then rejects. This lets callers decide how far a grid must grow.

use crate::floor::floor;

/// Index of a cell: `[column, row]`, column along x, row along y (row 0 at the bottom).
pub type CellIndex = [i32; 2];

/// Resolution, placement and size of a grid of square cells in the grid frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapLimits {
    resolution_m: f64,
    lower_corner_in_grid: [f64; 2],
    width_cells: usize,
    height_cells: usize,
}

impl MapLimits {
    /// A grid of `width_cells` × `height_cells` cells of side `resolution_m` metres, whose cell
    /// `[0, 0]` has its lower-left corner at `lower_corner_in_grid` (metres).
    ///
    /// # Panics
    ///
    /// If `resolution_m` is not finite and positive, or `lower_corner_in_grid` is not finite:
    /// a grid without a scale or a place is a programming error, not an input to recover from.
    pub fn new(
        resolution_m: f64,
        lower_corner_in_grid: [f64; 2],
        width_cells: usize,
        height_cells: usize,
    ) -> Self {
        assert!(
            resolution_m.is_finite() && resolution_m > 0.0,
            "resolution_m must be finite and positive, got {resolution_m}"
        );
        assert!(
            lower_corner_in_grid.iter().all(|c| c.is_finite()),
            "lower_corner_in_grid must be finite, got {lower_corner_in_grid:?}"
        );
        MapLimits {
            resolution_m,
            lower_corner_in_grid,
            width_cells,
            height_cells,
        }
    }

    /// Side of one cell, in metres.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// Lower-left corner of cell `[0, 0]` in the grid frame, in metres.
    pub fn lower_corner_in_grid(&self) -> [f64; 2] {
        self.lower_corner_in_grid
    }

    /// Upper-right corner of the last cell in the grid frame, in metres.
    pub fn upper_corner_in_grid(&self) -> [f64; 2] {
        [
            self.lower_corner_in_grid[0] + self.width_cells as f64 * self.resolution_m,
            self.lower_corner_in_grid[1] + self.height_cells as f64 * self.resolution_m,
        ]
    }

    /// Number of columns (cells along x).
    pub fn width_cells(&self) -> usize {
        self.width_cells
    }

    /// Number of rows (cells along y).
    pub fn height_cells(&self) -> usize {
        self.height_cells
    }

    /// Number of cells, `width_cells * height_cells`.
    pub fn num_cells(&self) -> usize {
        self.width_cells * self.height_cells
    }

    /// The cell containing `point_in_grid` (metres), whether or not it lies inside the grid.
    ///
    /// Coordinates beyond the range of `i32` saturate; a NaN coordinate gives index 0, so
    /// callers that may see non-finite points must filter them first.
    pub fn cell_index(&self, point_in_grid: [f64; 2]) -> CellIndex {
        let scale = 1.0 / self.resolution_m;
        [
            floor((point_in_grid[0] - self.lower_corner_in_grid[0]) * scale) as i32,
            floor((point_in_grid[1] - self.lower_corner_in_grid[1]) * scale) as i32,
        ]
    }

    /// The centre of `cell` in the grid frame, in metres (defined for cells outside the grid too).
    pub fn cell_center_in_grid(&self, cell: CellIndex) -> [f64; 2] {
        [
            self.lower_corner_in_grid[0] + (f64::from(cell[0]) + 0.5) * self.resolution_m,
            self.lower_corner_in_grid[1] + (f64::from(cell[1]) + 0.5) * self.resolution_m,
        ]
    }

    /// True if `cell` lies inside the grid.
    pub fn contains(&self, cell: CellIndex) -> bool {
        usize::try_from(cell[0]).is_ok_and(|column| column < self.width_cells)
            && usize::try_from(cell[1]).is_ok_and(|row| row < self.height_cells)
    }

    /// True if `point_in_grid` (metres) lies in a cell of the grid.
    pub fn contains_point(&self, point_in_grid: [f64; 2]) -> bool {
        point_in_grid.iter().all(|c| c.is_finite()) && self.contains(self.cell_index(point_in_grid))
    }

    /// Position of `cell` in row-major storage (`row * width_cells + column`), or `None` if the
    /// cell lies outside the grid.
    pub fn linear_index(&self, cell: CellIndex) -> Option<usize> {
        self.contains(cell)
            .then(|| cell[1] as usize * self.width_cells + cell[0] as usize)
    }

    /// The storage positions ([`Self::linear_index`]) of the cells of the Bresenham line from
    /// `from` to `to`, both included, in the order of [`BresenhamLine`]'s cells; `None` unless
    /// both ends lie in the grid (then so does every cell between them, and one check of the
    /// ends serves the whole line).
    ///
    /// [`BresenhamLine`]: crate::scan_match::BresenhamLine
    pub fn line_indices(&self, from: CellIndex, to: CellIndex) -> Option<LineIndices> {
        let (Some(from_index), Some(_)) = (self.linear_index(from), self.linear_index(to)) else {
            return None;
        };
        let delta_x = (i64::from(to[0]) - i64::from(from[0])).abs();
        let delta_y = -(i64::from(to[1]) - i64::from(from[1])).abs();
        // Grid dimensions fit in memory, so a row's stride fits an `isize`.
        Some(LineIndices {
            index: from_index as isize,
            step_x: (to[0] - from[0]).signum() as isize,
            step_y: (to[1] - from[1]).signum() as isize * self.width_cells as isize,
            delta_x,
            delta_y,
            error: delta_x + delta_y,
            remaining: delta_x.max(-delta_y) as usize + 1,
        })
    }
}

/// The storage positions of a line's cells ([`MapLimits::line_indices`]): Bresenham's
/// all-octant integer form, stepping through row-major storage.
#[derive(Clone, Debug)]
pub struct LineIndices {
    index: isize,
    step_x: isize,
    step_y: isize,
    delta_x: i64,
    /// Minus the absolute row extent, as in the textbook form of the algorithm.
    delta_y: i64,
    error: i64,
    remaining: usize,
}

impl Iterator for LineIndices {
    type Item = usize;

    fn next(&mut self) -> Option<usize> {
        if self.remaining == 0 {
            return None;
        }
        self.remaining -= 1;
        let index = self.index as usize;
        let twice_error = 2 * self.error;
        if twice_error >= self.delta_y {
            self.error += self.delta_y;
            self.index += self.step_x;
        }
        if twice_error <= self.delta_x {
            self.error += self.delta_x;
            self.index += self.step_y;
        }
        Some(index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> MapLimits {
        MapLimits::new(0.05, [-1.0, 2.0], 40, 30)
    }

    #[test]
    fn test_cell_center_round_trip() {
        let limits = limits();
        for column in -3..43 {
            for row in -3..33 {
                let center = limits.cell_center_in_grid([column, row]);
                assert_eq!(limits.cell_index(center), [column, row]);
            }
        }
    }

    #[test]
    fn test_point_to_cell() {
        let limits = limits();
        assert_eq!(limits.cell_index([-1.0, 2.0]), [0, 0]);
        assert_eq!(limits.cell_index([-0.951, 2.049]), [0, 0]);
        assert_eq!(limits.cell_index([-0.949, 2.051]), [1, 1]);
        assert_eq!(limits.cell_index([-1.001, 1.999]), [-1, -1]);
        assert_eq!(limits.cell_index([0.99, 3.49]), [39, 29]);
    }

    #[test]
    fn test_contains_and_linear_index() {
        let limits = limits();
        assert!(limits.contains([0, 0]));
        assert!(limits.contains([39, 29]));
        assert!(!limits.contains([40, 0]));
        assert!(!limits.contains([0, 30]));
        assert!(!limits.contains([-1, 5]));
        assert_eq!(limits.linear_index([3, 2]), Some(2 * 40 + 3));
        assert_eq!(limits.linear_index([39, 29]), Some(limits.num_cells() - 1));
        assert_eq!(limits.linear_index([0, -1]), None);
        assert!(limits.contains_point([0.99, 3.49]));
        assert!(!limits.contains_point([1.0, 3.0]));
        assert!(!limits.contains_point([f64::NAN, 3.0]));
    }

    #[test]
    fn test_upper_corner() {
        let [x, y] = limits().upper_corner_in_grid();
        assert!((x - 1.0).abs() < 1e-12 && (y - 3.5).abs() < 1e-12);
    }

    #[test]
    fn test_far_points_saturate() {
        assert_eq!(limits().cell_index([1e30, -1e30]), [i32::MAX, i32::MIN]);
    }
}
