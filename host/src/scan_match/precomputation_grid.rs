//! Max-pooled "blocked" grids for the branch-and-bound search of [`super::FastMatcher`]
//! (Hess et al. 2016, "Real-Time Loop Closure in 2D LIDAR SLAM", section V.C; Olson 2009,
//! "Real-Time Correlative Scan Matching", multi-resolution search).
//!
//! A pixel is *blocked* when a new-scan pixel landing there adds nothing to the score: it is
//! already set by the reference scan, or it lies outside the raster (clipped). Level 0 is that
//! set. Level `k` is blocked at `p` when any of `p + (i, j) * step` is blocked at level 0, for
//! `i, j` in `0..2^k` and `step` the table's translation step in pixels: the OR over every offset
//! a block of `2^k` × `2^k` table translations adds to its lowest corner. Outside the raster every
//! level reads as blocked (padding bits and reads past the row are ones).

use super::bit_grid::{BitGrid, read_word};

/// Blocked grids for levels `0..=depth`, all of raster size.
#[derive(Clone, Debug)]
pub(crate) struct PrecomputationGrids {
    levels: Vec<BitGrid>,
}

impl PrecomputationGrids {
    /// Builds the levels from `reference` (the reference drawing, raster size, clear padding).
    pub(crate) fn new(reference: &BitGrid, translation_step_px: usize, depth: u32) -> Self {
        let mut level = reference.clone();
        level.fill_padding();
        let mut levels = Vec::with_capacity(depth as usize + 1);
        for k in 0..depth {
            let next = dilate(&level, translation_step_px << k);
            levels.push(level);
            level = next;
        }
        levels.push(level);
        PrecomputationGrids { levels }
    }

    /// The grid of `level`, `0..=depth`.
    pub(crate) fn level(&self, level: u32) -> &BitGrid {
        &self.levels[level as usize]
    }
}

/// `grid` OR-ed with itself shifted by `offset_px` along x, then the result with itself shifted
/// by `offset_px` along y, reading ones outside the raster.
fn dilate(grid: &BitGrid, offset_px: usize) -> BitGrid {
    let mut along_x = grid.clone();
    for row in 0..grid.height_px() {
        let source = grid.row(row);
        for (w, word) in along_x.row_mut(row).iter_mut().enumerate() {
            *word |= read_word(source, w * 64 + offset_px, !0);
        }
    }
    let mut both = along_x.clone();
    for row in 0..grid.height_px() {
        let below = row + offset_px;
        for (w, word) in both.row_mut(row).iter_mut().enumerate() {
            *word |= if below < grid.height_px() {
                along_x.row(below)[w]
            } else {
                !0
            };
        }
    }
    both
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Level `k` by its definition, one pixel at a time.
    fn blocked_naive(reference: &BitGrid, step: usize, k: u32, column: usize, row: usize) -> bool {
        (0..1usize << k).any(|i| {
            (0..1usize << k).any(|j| {
                let (c, r) = (column + i * step, row + j * step);
                c >= reference.width_px() || r >= reference.height_px() || reference.get(c, r)
            })
        })
    }

    #[test]
    fn test_levels_match_definition() {
        let mut reference = BitGrid::new(70, 20, 0);
        for &(c, r) in &[(3, 4), (10, 10), (63, 0), (64, 19), (40, 7)] {
            reference.set(c, r);
        }
        for step in [1, 2, 3] {
            let grids = PrecomputationGrids::new(&reference, step, 3);
            for k in 0..=3 {
                for row in 0..20 {
                    for column in 0..70 {
                        assert_eq!(
                            grids.level(k).get(column, row),
                            blocked_naive(&reference, step, k, column, row),
                            "step {step} level {k} at ({column}, {row})"
                        );
                    }
                }
            }
        }
    }
}
