//! An occupancy grid: for every cell, the probability that it is occupied, or "unknown".
//!
//! Each cell stores the log-odds `ln(p / (1 - p))` of being occupied as an `f32`, so independent
//! observations combine by addition. A cell nobody has observed is *unknown*, which is kept apart
//! from "observed, probability one half". Log-odds are clamped to the probabilities
//! `[min_probability, max_probability]` of [`ProbabilityGridOptions`], so a cell seen free a
//! thousand times still turns occupied after a few dozen hits when the world changes.
//!
//! The grid grows when asked to cover a point outside it (see
//! [`ProbabilityGrid::grow_to_include_bounds`]). Growth adds at least half the current size on
//! the side that needs it, so building a map scan by scan copies each cell only a bounded number
//! of times on average. Growing keeps every cell at the same place in the grid frame; only the
//! indices shift, and [`ProbabilityGrid::limits`] tells the new ones.

use serde::{Deserialize, Serialize};

use super::map_limits::{CellIndex, MapLimits};
use super::range_inserter::{RangeInserter, RangeInserterOptions};
use crate::geometry::Pose2;
use crate::scan_match::{BresenhamLine, Scan};

/// Marks a cell nobody has observed.
const UNKNOWN_LOG_ODDS: f32 = f32::NAN;

/// Least number of cells added on a side when the grid grows.
const MIN_GROWTH_CELLS: usize = 64;

/// The most cells a grid grows by beyond what is needed, per side.
const MAX_GROWTH_CELLS: usize = 256;

/// The most cells a grid has along either axis (409.6 m at 10 cm, 204.8 m at 5 cm).
pub const MAX_SIDE_CELLS: usize = 4096;

/// Limits on the occupancy probability a cell can reach.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ProbabilityGridOptions {
    /// Lowest probability a cell can hold (a cell seen free very often); 0.12.
    pub min_probability: f32,
    /// Highest probability a cell can hold (a cell seen occupied very often); 0.97.
    pub max_probability: f32,
}

impl Default for ProbabilityGridOptions {
    /// Clamps probabilities to `[0.12, 0.97]`.
    fn default() -> Self {
        ProbabilityGridOptions {
            min_probability: 0.12,
            max_probability: 0.97,
        }
    }
}

/// The log-odds a grid's cells are kept within.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LogOddsBounds {
    min: f32,
    max: f32,
}

impl LogOddsBounds {
    /// A cell's log-odds after adding `delta_log_odds` to `previous` ([`UNKNOWN_LOG_ODDS`]
    /// counting as even odds), kept within the bounds.
    #[inline]
    pub(crate) fn updated(self, previous: f32, delta_log_odds: f32) -> f32 {
        let previous = if previous.is_nan() { 0.0 } else { previous };
        (previous + delta_log_odds).clamp(self.min, self.max)
    }
}

/// Occupancy log-odds per cell over [`MapLimits`], growable, with unknown cells kept apart.
#[derive(Clone, Debug)]
pub struct ProbabilityGrid {
    limits: MapLimits,
    /// Row-major, `limits.num_cells()` entries; [`UNKNOWN_LOG_ODDS`] for unknown cells.
    log_odds: Vec<f32>,
    options: ProbabilityGridOptions,
    min_log_odds: f32,
    max_log_odds: f32,
}

impl ProbabilityGrid {
    /// Gives back the room kept for growth: for a grid that will not grow again.
    pub fn shrink_to_fit(&mut self) {
        self.log_odds.shrink_to_fit();
    }

    /// An empty grid (no cells yet) of `resolution_m` metres per cell. Cell corners sit at whole
    /// multiples of `resolution_m` from the grid-frame origin, whatever the grid grows to.
    ///
    /// # Panics
    ///
    /// If `resolution_m` is not finite and positive, or the probabilities of `options` are not
    /// ordered `0 < min_probability <= max_probability < 1`.
    pub fn new(resolution_m: f64, options: ProbabilityGridOptions) -> Self {
        ProbabilityGrid::with_limits(MapLimits::new(resolution_m, [0.0, 0.0], 0, 0), options)
    }

    /// A grid covering `limits`, every cell unknown.
    ///
    /// # Panics
    ///
    /// If the probabilities of `options` are not ordered
    /// `0 < min_probability <= max_probability < 1`.
    pub fn with_limits(limits: MapLimits, options: ProbabilityGridOptions) -> Self {
        let ProbabilityGridOptions {
            min_probability,
            max_probability,
        } = options;
        assert!(
            0.0 < min_probability && min_probability <= max_probability && max_probability < 1.0,
            "grid probabilities must satisfy 0 < min <= max < 1, got [{min_probability}, \
             {max_probability}]"
        );
        ProbabilityGrid {
            limits,
            log_odds: vec![UNKNOWN_LOG_ODDS; limits.num_cells()],
            options,
            min_log_odds: log_odds_from_probability(min_probability),
            max_log_odds: log_odds_from_probability(max_probability),
        }
    }

    /// Builds one grid in the map frame by inserting every `(robot_pose_in_map, scan)` in turn
    /// with a [`RangeInserter`] of `inserter_options`; this is how the global map is drawn from
    /// the optimised trajectory.
    ///
    /// # Panics
    ///
    /// As [`ProbabilityGrid::new`] and [`RangeInserter::new`], on invalid options.
    pub fn from_scans<'a>(
        scans_in_map: impl IntoIterator<Item = (Pose2, &'a Scan)>,
        resolution_m: f64,
        grid_options: ProbabilityGridOptions,
        inserter_options: RangeInserterOptions,
    ) -> Self {
        let mut grid = ProbabilityGrid::new(resolution_m, grid_options);
        let mut inserter = RangeInserter::new(inserter_options);
        for (robot_pose_in_map, scan) in scans_in_map {
            inserter.insert(scan, robot_pose_in_map, &mut grid);
        }
        grid
    }

    /// Placement, resolution and size of the grid.
    pub fn limits(&self) -> &MapLimits {
        &self.limits
    }

    /// The options the grid was built with.
    pub fn options(&self) -> &ProbabilityGridOptions {
        &self.options
    }

    /// Log-odds of `cell` being occupied, or `None` if it is unknown or outside the grid.
    pub fn log_odds(&self, cell: CellIndex) -> Option<f32> {
        let index = self.limits.linear_index(cell)?;
        let log_odds = self.log_odds[index];
        (!log_odds.is_nan()).then_some(log_odds)
    }

    /// Probability that `cell` is occupied, or `None` if it is unknown or outside the grid.
    pub fn probability(&self, cell: CellIndex) -> Option<f32> {
        self.log_odds(cell).map(probability_from_log_odds)
    }

    /// Probability that the cell containing `point_in_grid` (metres) is occupied, or `None` if
    /// the cell is unknown or outside the grid.
    pub fn probability_at(&self, point_in_grid: [f64; 2]) -> Option<f32> {
        if !point_in_grid.iter().all(|c| c.is_finite()) {
            return None;
        }
        self.probability(self.limits.cell_index(point_in_grid))
    }

    /// Whether a cell of the Bresenham line from `from` to `to` (both included) is known with
    /// a probability of at least `min_probability`: whether a beam along it passes a surface.
    /// Cells outside the grid count as unknown.
    pub fn line_reaches_probability(
        &self,
        from: CellIndex,
        to: CellIndex,
        min_probability: f32,
    ) -> bool {
        // Compared in log-odds (NaN, unknown, compares false), so no cell is converted.
        let min_log_odds = log_odds_from_probability(min_probability);
        match self.limits.line_indices(from, to) {
            Some(mut indices) => indices.any(|i| self.log_odds[i] >= min_log_odds),
            None => BresenhamLine::new(from, to)
                .any(|cell| self.log_odds(cell).is_some_and(|l| l >= min_log_odds)),
        }
    }

    /// True if `cell` lies inside the grid and has been observed.
    pub fn is_known(&self, cell: CellIndex) -> bool {
        self.log_odds(cell).is_some()
    }

    /// Number of observed cells.
    pub fn num_known_cells(&self) -> usize {
        self.log_odds.iter().filter(|l| !l.is_nan()).count()
    }

    /// Adds `delta_log_odds` to the log-odds of `cell` (an unknown cell starts from zero, even
    /// odds), clamping the result to the grid's probability range. Returns false, changing
    /// nothing, if `cell` lies outside the grid.
    pub fn update_log_odds(&mut self, cell: CellIndex, delta_log_odds: f32) -> bool {
        match self.limits.linear_index(cell) {
            Some(index) => {
                self.update_log_odds_at(index, delta_log_odds);
                true
            }
            None => false,
        }
    }

    /// [`ProbabilityGrid::update_log_odds`] by row-major storage index.
    pub(crate) fn update_log_odds_at(&mut self, index: usize, delta_log_odds: f32) {
        debug_assert!(index < self.log_odds.len(), "cell index out of bounds");
        let (log_odds, bounds) = self.log_odds_mut();
        log_odds[index] = bounds.updated(log_odds[index], delta_log_odds);
    }

    /// Every cell's log-odds (row-major, as [`MapLimits::linear_index`]), for callers that
    /// update many cells, with the bounds an update keeps them in.
    pub(crate) fn log_odds_mut(&mut self) -> (&mut [f32], LogOddsBounds) {
        let bounds = self.log_odds_bounds();
        (&mut self.log_odds, bounds)
    }

    /// The bounds an update keeps a cell's log-odds in.
    pub(crate) fn log_odds_bounds(&self) -> LogOddsBounds {
        LogOddsBounds {
            min: self.min_log_odds,
            max: self.max_log_odds,
        }
    }

    /// Grows the grid, if needed, so that it contains the cell of `point_in_grid` (metres).
    /// Non-finite points are ignored.
    pub fn grow_to_include(&mut self, point_in_grid: [f64; 2]) {
        self.grow_to_include_bounds(point_in_grid, point_in_grid);
    }

    /// Grows the grid at once to contain every cell of the box from `lower_in_grid` to
    /// `upper_in_grid` (metres), when it can do so without nearing [`MAX_SIDE_CELLS`]; returns
    /// whether it did. Growing one box at a time ([`Self::grow_to_include_bounds`]) to the
    /// same cells then changes nothing but the cost: each growth copies every cell.
    ///
    /// The box, with the grid's current cells and the widest growth margin on every side,
    /// must stay within [`MAX_SIDE_CELLS`]: then neither this growth nor any growth step by
    /// step towards the same box is cut short by that limit, and both leave every cell with
    /// the same value.
    pub fn reserve_bounds(&mut self, lower_in_grid: [f64; 2], upper_in_grid: [f64; 2]) -> bool {
        let fits = self.can_reserve(lower_in_grid, upper_in_grid);
        if fits {
            self.grow_to_include_bounds(lower_in_grid, upper_in_grid);
        }
        fits
    }

    /// The limits [`Self::reserve_bounds`] gives this grid while it is still empty (no cells),
    /// without making its cells; `None` when the grid has cells or would not reserve the box.
    pub(crate) fn limits_reserved_when_empty(
        &self,
        lower_in_grid: [f64; 2],
        upper_in_grid: [f64; 2],
    ) -> Option<MapLimits> {
        (self.log_odds.is_empty() && self.can_reserve(lower_in_grid, upper_in_grid)).then(|| {
            let lower = self.limits.cell_index(lower_in_grid).map(i64::from);
            let upper = self.limits.cell_index(upper_in_grid).map(i64::from);
            self.first_limits(lower, upper)
        })
    }

    /// Whether [`Self::reserve_bounds`] reserves the box at once.
    fn can_reserve(&self, lower_in_grid: [f64; 2], upper_in_grid: [f64; 2]) -> bool {
        if !lower_in_grid
            .iter()
            .chain(&upper_in_grid)
            .all(|c| c.is_finite())
        {
            return false;
        }
        let lower = self.limits.cell_index(lower_in_grid).map(i64::from);
        let upper = self.limits.cell_index(upper_in_grid).map(i64::from);
        let size = [self.limits.width_cells(), self.limits.height_cells()];
        (0..2).all(|axis| {
            let (mut low, mut high) = (lower[axis].min(upper[axis]), lower[axis].max(upper[axis]));
            if size[axis] > 0 {
                low = low.min(0);
                high = high.max(size[axis] as i64 - 1);
            }
            high - low + 1 + 2 * MAX_GROWTH_CELLS as i64 <= MAX_SIDE_CELLS as i64
        })
    }

    /// Grows the grid, if needed, so that it contains every cell of the axis-aligned box from
    /// `lower_in_grid` to `upper_in_grid` (metres). Known cells keep their values and their
    /// place in the grid frame; their indices shift if the grid grows down or left. Non-finite
    /// corners are ignored.
    ///
    /// Each side that must grow gains the missing cells plus a margin of at least half the
    /// current size (and at least 64 cells), so repeated growth stays cheap on average.
    pub fn grow_to_include_bounds(&mut self, lower_in_grid: [f64; 2], upper_in_grid: [f64; 2]) {
        if !lower_in_grid
            .iter()
            .chain(&upper_in_grid)
            .all(|c| c.is_finite())
        {
            return;
        }
        let lower = self.limits.cell_index(lower_in_grid).map(i64::from);
        let upper = self.limits.cell_index(upper_in_grid).map(i64::from);
        if self.log_odds.is_empty() {
            self.limits = self.first_limits(lower, upper);
            self.log_odds = vec![UNKNOWN_LOG_ODDS; self.limits.num_cells()];
            return;
        }
        let size = [self.limits.width_cells(), self.limits.height_cells()];
        let mut grow_low = [0usize; 2];
        let mut grow_high = [0usize; 2];
        for axis in 0..2 {
            let (low, high) = (lower[axis].min(upper[axis]), lower[axis].max(upper[axis]));
            // A quarter of the size, at most MAX_GROWTH_CELLS: amortised like a vector's
            // growth, without a large grid growing by tens of metres of unknown cells.
            let margin = MIN_GROWTH_CELLS.max(size[axis] / 4).min(MAX_GROWTH_CELLS) as i64;
            if low < 0 {
                grow_low[axis] = (margin - low) as usize;
            }
            if high >= size[axis] as i64 {
                grow_high[axis] = (high + 1 - size[axis] as i64 + margin) as usize;
            }
        }
        if grow_low == [0, 0] && grow_high == [0, 0] {
            return;
        }
        // A grid never outgrows MAX_SIDE_CELLS a side: beyond it, points are left out (a pose
        // gone astray must not take all the memory there is).
        for axis in 0..2 {
            let room = MAX_SIDE_CELLS.saturating_sub(size[axis]);
            let wanted = grow_low[axis] + grow_high[axis];
            if wanted > room {
                let keep = room as f64 / wanted as f64;
                grow_low[axis] = (grow_low[axis] as f64 * keep) as usize;
                grow_high[axis] = (grow_high[axis] as f64 * keep) as usize;
            }
        }
        if grow_low == [0, 0] && grow_high == [0, 0] {
            return;
        }
        self.grow(grow_low, grow_high);
    }

    /// The first cells of an empty grid asked to hold the cells `lower` to `upper` (indices
    /// of the current limits): that box with a margin all round, aligned with the origin.
    fn first_limits(&self, lower: [i64; 2], upper: [i64; 2]) -> MapLimits {
        let margin = MIN_GROWTH_CELLS as i64;
        let first = [
            lower[0].min(upper[0]) - margin,
            lower[1].min(upper[1]) - margin,
        ];
        let width = (lower[0].max(upper[0]) + 1 + margin - first[0]) as usize;
        let height = (lower[1].max(upper[1]) + 1 + margin - first[1]) as usize;
        let lower_corner = self.limits.lower_corner_in_grid();
        let resolution_m = self.limits.resolution_m();
        MapLimits::new(
            resolution_m,
            [
                lower_corner[0] + first[0] as f64 * resolution_m,
                lower_corner[1] + first[1] as f64 * resolution_m,
            ],
            width,
            height,
        )
    }

    /// Adds `grow_low` cells before and `grow_high` after the current ones, per axis.
    fn grow(&mut self, grow_low: [usize; 2], grow_high: [usize; 2]) {
        let old = self.limits;
        let resolution_m = old.resolution_m();
        let width = old.width_cells() + grow_low[0] + grow_high[0];
        let height = old.height_cells() + grow_low[1] + grow_high[1];
        let old_corner = old.lower_corner_in_grid();
        let new_limits = MapLimits::new(
            resolution_m,
            [
                old_corner[0] - grow_low[0] as f64 * resolution_m,
                old_corner[1] - grow_low[1] as f64 * resolution_m,
            ],
            width,
            height,
        );
        // Written once, row by row: unknown rows below, the old rows between unknown margins,
        // unknown rows above.
        let mut log_odds = Vec::with_capacity(width * height);
        log_odds.resize(grow_low[1] * width, UNKNOWN_LOG_ODDS);
        for old_row in self.log_odds.chunks_exact(old.width_cells()) {
            log_odds.resize(log_odds.len() + grow_low[0], UNKNOWN_LOG_ODDS);
            log_odds.extend_from_slice(old_row);
            log_odds.resize(log_odds.len() + grow_high[0], UNKNOWN_LOG_ODDS);
        }
        log_odds.resize(width * height, UNKNOWN_LOG_ODDS);
        self.limits = new_limits;
        self.log_odds = log_odds;
    }
}

#[cfg(test)]
impl ProbabilityGrid {
    /// Whether both grids hold the same value, to the bit, at the centre of every cell of
    /// either: the same map, whatever cells each happens to cover.
    pub(crate) fn same_values(&self, other: &ProbabilityGrid) -> bool {
        [self, other].iter().all(|grid| {
            let limits = grid.limits();
            (0..limits.height_cells() as i32).all(|row| {
                (0..limits.width_cells() as i32).all(|column| {
                    let centre = limits.cell_center_in_grid([column, row]);
                    let value = |g: &ProbabilityGrid| g.probability_at(centre).map(f32::to_bits);
                    value(self) == value(other)
                })
            })
        })
    }
}

/// `ln(p / (1 - p))`.
pub(crate) fn log_odds_from_probability(probability: f32) -> f32 {
    (probability / (1.0 - probability)).ln()
}

/// `1 / (1 + exp(-log_odds))`.
pub(crate) fn probability_from_log_odds(log_odds: f32) -> f32 {
    1.0 / (1.0 + (-log_odds).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> ProbabilityGrid {
        ProbabilityGrid::with_limits(
            MapLimits::new(0.1, [0.0, 0.0], 4, 3),
            ProbabilityGridOptions::default(),
        )
    }

    #[test]
    fn a_line_reaches_a_probability_where_a_cell_by_cell_walk_does() {
        let mut grid = ProbabilityGrid::with_limits(
            MapLimits::new(0.1, [0.0, 0.0], 20, 15),
            ProbabilityGridOptions::default(),
        );
        // A fixed scatter of known cells, some of them surfaces.
        let mut state = 12345u32;
        let mut next = move |n: u32| {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            (state >> 16) % n
        };
        for _ in 0..60 {
            let cell = [next(20) as i32, next(15) as i32];
            let delta = if next(3) == 0 { 3.0 } else { -1.0 };
            grid.update_log_odds(cell, delta);
        }
        let mut reached = 0;
        for _ in 0..2000 {
            // Ends inside and outside the grid.
            let from = [next(28) as i32 - 4, next(23) as i32 - 4];
            let to = [next(28) as i32 - 4, next(23) as i32 - 4];
            let walked = BresenhamLine::new(from, to)
                .any(|cell| grid.probability(cell).is_some_and(|p| p >= 0.9));
            assert_eq!(
                grid.line_reaches_probability(from, to, 0.9),
                walked,
                "{from:?} → {to:?}"
            );
            reached += usize::from(walked);
        }
        // Both answers occur.
        assert!(reached > 100 && reached < 1900, "{reached}");
    }

    #[test]
    fn test_log_odds_round_trip() {
        for p in [0.12f32, 0.3, 0.5, 0.55, 0.97] {
            assert!((probability_from_log_odds(log_odds_from_probability(p)) - p).abs() < 1e-6);
        }
    }

    #[test]
    fn test_unknown_until_updated() {
        let mut grid = grid();
        assert_eq!(grid.probability([1, 1]), None);
        assert_eq!(grid.num_known_cells(), 0);
        assert!(grid.update_log_odds([1, 1], log_odds_from_probability(0.55)));
        let p = grid.probability([1, 1]).unwrap();
        assert!((p - 0.55).abs() < 1e-6);
        assert_eq!(grid.probability_at([0.15, 0.15]), Some(p));
        assert!(grid.is_known([1, 1]) && !grid.is_known([0, 1]));
        assert!(!grid.update_log_odds([4, 0], 1.0));
        assert_eq!(grid.probability([4, 0]), None);
        assert_eq!(grid.probability_at([f64::NAN, 0.0]), None);
    }

    #[test]
    fn test_updates_are_clamped() {
        let mut grid = grid();
        for _ in 0..100 {
            grid.update_log_odds([0, 0], 1.0);
            grid.update_log_odds([1, 0], -1.0);
        }
        assert!((grid.probability([0, 0]).unwrap() - 0.97).abs() < 1e-6);
        assert!((grid.probability([1, 0]).unwrap() - 0.12).abs() < 1e-6);
        // One step back from the clamp moves the cell at once.
        grid.update_log_odds([0, 0], -1.0);
        assert!(grid.probability([0, 0]).unwrap() < 0.95);
    }

    #[test]
    fn test_growth_keeps_contents() {
        let mut grid = grid();
        let cells = [[0, 0], [3, 0], [2, 2], [1, 1]];
        let values = [0.5f32, -0.25, 1.5, -1.0];
        for (cell, value) in cells.iter().zip(values) {
            grid.update_log_odds(*cell, value);
        }
        let centers: Vec<[f64; 2]> = cells
            .iter()
            .map(|&c| grid.limits().cell_center_in_grid(c))
            .collect();
        grid.grow_to_include([-3.0, -0.01]);
        grid.grow_to_include([0.2, 9.0]);
        grid.grow_to_include([20.0, 0.0]);
        let limits = *grid.limits();
        assert!(limits.contains_point([-3.0, -0.01]));
        assert!(limits.contains_point([0.2, 9.0]));
        assert!(limits.contains_point([20.0, 0.0]));
        assert!(limits.width_cells() >= 231 && limits.height_cells() >= 91);
        for (center, value) in centers.iter().zip(values) {
            let cell = limits.cell_index(*center);
            assert_eq!(grid.log_odds(cell), Some(value));
        }
        assert_eq!(grid.num_known_cells(), 4);
        // Cells stay aligned with the original ones.
        let corner = limits.lower_corner_in_grid();
        for c in corner {
            assert!((c / 0.1 - (c / 0.1).round()).abs() < 1e-9);
        }
    }

    #[test]
    fn test_growth_is_amortised() {
        let mut grid = ProbabilityGrid::new(0.05, ProbabilityGridOptions::default());
        let mut reallocations = 0;
        let mut previous = (0, 0);
        for step in 0..2000 {
            let x_m = step as f64 * 0.05;
            grid.grow_to_include([x_m, -x_m]);
            let size = (grid.limits().width_cells(), grid.limits().height_cells());
            if size != previous {
                reallocations += 1;
                previous = size;
            }
        }
        // 2000 cells in each direction, growing by a quarter of the size (at most 256 cells)
        // beyond the need each time.
        assert!(reallocations <= 2 * 12, "{reallocations} reallocations");
    }

    #[test]
    fn test_growth_stops_at_the_largest_side() {
        let mut grid = ProbabilityGrid::new(0.05, ProbabilityGridOptions::default());
        grid.grow_to_include([0.0, 0.0]);
        grid.grow_to_include([1e6, -1e6]);
        assert!(grid.limits().width_cells() <= MAX_SIDE_CELLS);
        assert!(grid.limits().height_cells() <= MAX_SIDE_CELLS);
        // A point beyond it is not stored, and nothing panics.
        assert!(!grid.update_log_odds(grid.limits().cell_index([1e6, -1e6]), 1.0));
    }

    #[test]
    fn test_empty_grid_grows_around_first_point() {
        let mut grid = ProbabilityGrid::new(0.05, ProbabilityGridOptions::default());
        assert_eq!(grid.limits().num_cells(), 0);
        assert_eq!(grid.probability_at([0.0, 0.0]), None);
        grid.grow_to_include_bounds([10.0, -5.0], [12.0, -4.0]);
        let limits = *grid.limits();
        assert!(limits.contains_point([10.0, -5.0]) && limits.contains_point([12.0, -4.0]));
        assert!(limits.width_cells() < 200 && limits.height_cells() < 200);
        grid.grow_to_include([f64::NAN, 0.0]);
        assert_eq!(*grid.limits(), limits);
    }
}
