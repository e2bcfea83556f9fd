//! A uniform grid over 2-D points for exact nearest-neighbour queries within a radius, the
//! correspondence search of ICP (as the voxel map of Vizzo et al. 2023, "KISS-ICP", in 2-D).
//!
//! Each cell holds the points inside it as a linked list threaded through the point indices,
//! so adding a point is constant time and the grid costs four bytes a cell. A query visits
//! the cells around its point ring by ring and stops as soon as no unvisited cell can hold a
//! point nearer than the best one found, or nearer than the radius: for the short radii of
//! ICP that is the query's cell and its eight neighbours. The answer is the exact nearest
//! point, as a k-d tree's, for about what a k-d tree query cost on the benchmark logs; the
//! grid also gives, in the same pass, how far the second nearest lies, which lets ICP skip
//! most queries ([`super::icp`]), and stops at the first point within reach when only its
//! existence matters.
//!
//! The grid covers the cells its points fell in, with a margin, and grows when a point lands
//! outside; cells outside it hold nothing.

use crate::floor::floor;

/// Marks the end of a cell's list.
const NONE: u32 = u32::MAX;

/// Cells added on each side when the grid grows.
const GROWTH_MARGIN_CELLS: i64 = 32;

/// The grid grows no larger than this many cells (64 MiB); points beyond it are kept in one
/// list that every query reads whole, so that a wild point costs time rather than memory.
const MAX_CELLS: usize = 1 << 24;

/// See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct PointGrid {
    cell_m: f64,
    /// Cell coordinates of the grid's first cell.
    first_cell: [i64; 2],
    /// Cells along x and y.
    size_cells: [usize; 2],
    /// Index of the last point added to each cell, row by row; [`NONE`] when empty.
    head: Vec<u32>,
    /// For each point, the point added to its cell (or to the overflow) before it.
    next: Vec<u32>,
    /// The last point added outside the largest grid allowed ([`MAX_CELLS`]).
    overflow: u32,
    points: Vec<[f64; 2]>,
}

impl PointGrid {
    /// Gives back the room kept for points that will not come: for a grid that is complete.
    pub fn shrink_to_fit(&mut self) {
        self.head.shrink_to_fit();
        self.next.shrink_to_fit();
        self.points.shrink_to_fit();
    }

    /// An empty grid of square cells `cell_m` wide.
    ///
    /// # Panics
    /// If `cell_m` is not positive and finite (a programming error: it is a constant of the
    /// caller).
    pub fn new(cell_m: f64) -> Self {
        assert!(cell_m > 0.0 && cell_m.is_finite(), "cell size {cell_m}");
        PointGrid {
            cell_m,
            first_cell: [0, 0],
            size_cells: [0, 0],
            head: Vec::new(),
            next: Vec::new(),
            overflow: NONE,
            points: Vec::new(),
        }
    }

    /// The points, in the order they were added; [`Self::push`] returns each one's index.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }

    /// Adds `point` (finite) and returns its index.
    pub fn push(&mut self, point: [f64; 2]) -> usize {
        let cell = self.cell_of(point);
        if self.slot(cell).is_none() {
            self.grow_to(cell);
        }
        let index = self.points.len();
        self.points.push(point);
        let list = match self.slot(cell) {
            Some(slot) => &mut self.head[slot],
            None => &mut self.overflow,
        };
        self.next.push(*list);
        *list = index as u32;
        index
    }

    /// The index of the point nearest to `query` and its squared distance, when that point
    /// lies within `max_distance_m`. Of points at exactly the same distance, any one.
    pub fn nearest_within(&self, query: [f64; 2], max_distance_m: f64) -> Option<(usize, f64)> {
        let max_sq = max_distance_m * max_distance_m;
        let mut best: Option<(usize, f64)> = None;
        self.visit_rings(query, max_distance_m, |index, distance_sq| {
            if distance_sq <= max_sq && best.is_none_or(|(_, d)| distance_sq < d) {
                best = Some((index, distance_sq));
            }
            best.map_or(max_sq, |(_, d)| d)
        });
        best
    }

    /// [`Self::nearest_within`], and how far every other point lies from `query` at least: the
    /// squared distance of the second nearest point, or `max_distance_m²` when there is none
    /// within it. With no point within `max_distance_m`, every point lies beyond it.
    ///
    /// A query nearby needs no search when the first answer still holds there; see
    /// [`super::icp`].
    pub fn nearest_two_within(
        &self,
        query: [f64; 2],
        max_distance_m: f64,
    ) -> (Option<(usize, f64)>, f64) {
        let max_sq = max_distance_m * max_distance_m;
        let mut best: Option<(usize, f64)> = None;
        let mut second_sq = max_sq;
        self.visit_rings(query, max_distance_m, |index, distance_sq| {
            if distance_sq <= max_sq {
                match best {
                    Some((_, d)) if distance_sq >= d => second_sq = second_sq.min(distance_sq),
                    _ => {
                        if let Some((_, d)) = best {
                            second_sq = second_sq.min(d);
                        }
                        best = Some((index, distance_sq));
                    }
                }
            }
            second_sq
        });
        (best, second_sq)
    }

    /// Whether some point lies within `max_distance_m` of `query`.
    pub fn any_within(&self, query: [f64; 2], max_distance_m: f64) -> bool {
        let max_sq = max_distance_m * max_distance_m;
        let mut found = false;
        self.visit_rings(query, max_distance_m, |_, distance_sq| {
            found |= distance_sq <= max_sq;
            // Once one is found, nothing farther is needed.
            if found { -1.0 } else { max_sq }
        });
        found
    }

    /// Visits the points of the cells around `query`, ring by ring, handing each index and
    /// squared distance to `visit`, which returns the squared distance that still matters.
    /// Stops after the first ring beyond which every point is farther than that, or farther
    /// than `max_distance_m`.
    fn visit_rings(
        &self,
        query: [f64; 2],
        max_distance_m: f64,
        mut visit: impl FnMut(usize, f64) -> f64,
    ) {
        if self.points.is_empty() || !(query[0].is_finite() && query[1].is_finite()) {
            return;
        }
        let center = self.cell_of(query);
        let width = self.size_cells[0] as i64;
        let height = self.size_cells[1] as i64;
        // The query's cell relative to the grid's first cell.
        let relative = [
            center[0].saturating_sub(self.first_cell[0]),
            center[1].saturating_sub(self.first_cell[1]),
        ];
        let mut still_matters_sq = max_distance_m * max_distance_m;
        let mut visit_list = |mut index: u32, still_matters_sq: &mut f64| {
            while index != NONE {
                let i = index as usize;
                let [px, py] = self.points[i];
                let (dx, dy) = (px - query[0], py - query[1]);
                *still_matters_sq = visit(i, dx * dx + dy * dy);
                index = self.next[i];
            }
        };
        visit_list(self.overflow, &mut still_matters_sq);
        for ring in 0i64.. {
            let [x0, y0] = relative.map(|c| c.saturating_sub(ring));
            let [x1, y1] = relative.map(|c| c.saturating_add(ring));
            // The ring's cells inside the grid: its first and last rows whole, and the two
            // end cells of the rows between.
            for y in y0.max(0)..=y1.min(height - 1) {
                let row = &self.head[(y * width) as usize..((y + 1) * width) as usize];
                if y == y0 || y == y1 {
                    for x in x0.max(0)..=x1.min(width - 1) {
                        visit_list(row[x as usize], &mut still_matters_sq);
                    }
                } else {
                    if (0..width).contains(&x0) {
                        visit_list(row[x0 as usize], &mut still_matters_sq);
                    }
                    if ring > 0 && (0..width).contains(&x1) {
                        visit_list(row[x1 as usize], &mut still_matters_sq);
                    }
                }
                if still_matters_sq < 0.0 {
                    return;
                }
            }
            // Every point outside the rings visited lies at least this far from the query
            // (less a hair for rounding at cell borders).
            let low = [
                center[0].saturating_sub(ring),
                center[1].saturating_sub(ring),
            ];
            let high = [
                center[0].saturating_add(ring),
                center[1].saturating_add(ring),
            ];
            let clear_m = [
                query[0] - low[0] as f64 * self.cell_m,
                high[0].saturating_add(1) as f64 * self.cell_m - query[0],
                query[1] - low[1] as f64 * self.cell_m,
                high[1].saturating_add(1) as f64 * self.cell_m - query[1],
            ]
            .into_iter()
            .fold(f64::INFINITY, f64::min)
                - 1e-9;
            let whole_grid = x0 <= 0 && y0 <= 0 && x1 >= width - 1 && y1 >= height - 1;
            if whole_grid || clear_m > max_distance_m || clear_m * clear_m > still_matters_sq {
                return;
            }
        }
    }

    /// The cell `point` lies in.
    fn cell_of(&self, point: [f64; 2]) -> [i64; 2] {
        // `as` saturates, so a point far outside any grid still names a (distant) cell.
        point.map(|coordinate| floor(coordinate / self.cell_m) as i64)
    }

    /// The position of `cell` in `head`, when the grid covers it.
    fn slot(&self, cell: [i64; 2]) -> Option<usize> {
        let x = usize::try_from(cell[0].checked_sub(self.first_cell[0])?).ok()?;
        let y = usize::try_from(cell[1].checked_sub(self.first_cell[1])?).ok()?;
        (x < self.size_cells[0] && y < self.size_cells[1]).then(|| y * self.size_cells[0] + x)
    }

    /// Enlarges the grid to cover `cell` with a margin, and threads every point anew.
    fn grow_to(&mut self, cell: [i64; 2]) {
        let (mut low, mut high) = if self.head.is_empty() {
            (cell, cell)
        } else {
            (
                self.first_cell,
                [
                    self.first_cell[0] + self.size_cells[0] as i64 - 1,
                    self.first_cell[1] + self.size_cells[1] as i64 - 1,
                ],
            )
        };
        for axis in 0..2 {
            if cell[axis] < low[axis] {
                low[axis] = cell[axis].saturating_sub(GROWTH_MARGIN_CELLS);
            }
            if cell[axis] > high[axis] {
                high[axis] = cell[axis].saturating_add(GROWTH_MARGIN_CELLS);
            }
        }
        let size_cells = [0, 1].map(|axis| high[axis].abs_diff(low[axis]).saturating_add(1));
        let too_large = size_cells
            .iter()
            .try_fold(1usize, |cells, &side| {
                cells.checked_mul(usize::try_from(side).ok()?)
            })
            .is_none_or(|cells| cells > MAX_CELLS);
        if too_large {
            return;
        }
        self.first_cell = low;
        self.size_cells = size_cells.map(|side| side as usize);
        self.head = vec![NONE; self.size_cells[0] * self.size_cells[1]];
        self.overflow = NONE;
        for (index, &point) in self.points.iter().enumerate() {
            let list = match self.slot(self.cell_of(point)) {
                Some(slot) => &mut self.head[slot],
                None => &mut self.overflow,
            };
            self.next[index] = *list;
            *list = index as u32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute_force(points: &[[f64; 2]], query: [f64; 2], max_m: f64) -> Option<f64> {
        points
            .iter()
            .map(|p| (p[0] - query[0]).powi(2) + (p[1] - query[1]).powi(2))
            .filter(|&d| d <= max_m * max_m)
            .min_by(f64::total_cmp)
    }

    proptest! {
        #[test]
        fn prop_nearest_is_the_brute_force_nearest(
            points in prop::collection::vec((-5.0..5.0f64, -5.0..5.0f64), 0..60),
            queries in prop::collection::vec((-7.0..7.0f64, -7.0..7.0f64), 1..20),
            cell_m in 0.05..1.5f64,
            max_m in 0.0..4.0f64,
        ) {
            let points: Vec<[f64; 2]> = points.into_iter().map(|(x, y)| [x, y]).collect();
            let mut grid = PointGrid::new(cell_m);
            for &p in &points {
                grid.push(p);
            }
            for (x, y) in queries {
                let query = [x, y];
                let expected = brute_force(&points, query, max_m);
                let found = grid.nearest_within(query, max_m);
                prop_assert_eq!(found.map(|(_, d)| d), expected);
                if let Some((index, d)) = found {
                    let p = grid.points()[index];
                    prop_assert_eq!((p[0] - x).powi(2) + (p[1] - y).powi(2), d);
                }
                prop_assert_eq!(grid.any_within(query, max_m), expected.is_some());
                let (nearest, second_sq) = grid.nearest_two_within(query, max_m);
                prop_assert_eq!(nearest.map(|(_, d)| d), expected);
                let mut distances: Vec<f64> = points
                    .iter()
                    .map(|p| (p[0] - x).powi(2) + (p[1] - y).powi(2))
                    .collect();
                distances.sort_by(f64::total_cmp);
                let expected_second = match expected {
                    Some(_) => distances.get(1).copied().unwrap_or(f64::INFINITY),
                    None => distances.first().copied().unwrap_or(f64::INFINITY),
                };
                prop_assert_eq!(second_sq, expected_second.min(max_m * max_m));
            }
        }
    }

    #[test]
    fn an_empty_grid_finds_nothing_and_far_points_grow_it() {
        let mut grid = PointGrid::new(0.1);
        assert!(grid.nearest_within([0.0, 0.0], 10.0).is_none());
        assert_eq!(grid.push([0.0, 0.0]), 0);
        assert_eq!(grid.push([250.0, -130.0]), 1);
        assert_eq!(
            grid.nearest_within([249.9, -130.0], 0.2).map(|(i, _)| i),
            Some(1)
        );
        assert_eq!(
            grid.nearest_within([0.05, 0.0], 0.2).map(|(i, _)| i),
            Some(0)
        );
        assert!(grid.nearest_within([125.0, -65.0], 1.0).is_none());
        assert!(grid.nearest_within([f64::NAN, 0.0], 1.0).is_none());
        // Beyond the largest grid allowed, a point is still found.
        assert_eq!(grid.push([1e7, 1e7]), 2);
        assert_eq!(
            grid.nearest_within([1e7, 1e7 + 0.5], 1.0).map(|(i, _)| i),
            Some(2)
        );
        assert_eq!(
            grid.nearest_within([0.05, 0.0], 0.2).map(|(i, _)| i),
            Some(0)
        );
    }
}
