//! The new scan drawn once for one rotation, ready to slide by whole-pixel table offsets.
//!
//! Because candidate translations are whole-pixel offsets of the same vertex pixels, and
//! Bresenham lines shift exactly with their end points, the drawing of candidate
//! (rotation, x, y) is this drawing shifted by the candidate's offset and clipped to the raster.
//! The drawing is kept on a raster enlarged by the table's largest offset on every side: pixels
//! beyond that can never land in the raster for any candidate, so dropping them changes nothing.

use super::bit_grid::BitGrid;
use super::search::{Polyline, RasterOptions};
use super::simd::SimdLevel;

/// One rotation's drawing of the new scan on the enlarged raster.
#[derive(Clone, Debug)]
pub(crate) struct RotatedScan {
    /// Enlarged raster: column `c` here is raster column `c - margin_px[0]`, likewise rows.
    grid: BitGrid,
    margin_px: [usize; 2],
    /// Rows of `grid` with at least one set pixel, ascending.
    occupied_rows: Vec<usize>,
}

impl RotatedScan {
    /// Draws `polyline` with vertices `vertices_px` (raster pixels, no table offset) on the
    /// raster of `raster` enlarged by `margin_px` (the table's largest offset) on each side.
    pub(crate) fn new(
        polyline: &Polyline,
        vertices_px: &[Option<[i32; 2]>],
        raster: &RasterOptions,
        margin_px: [usize; 2],
    ) -> Self {
        let width = raster.width_px as usize + 2 * margin_px[0];
        let height = raster.height_px as usize + 2 * margin_px[1];
        // One spare word so that a window of `words_per_row + 1` words starting at any allowed
        // offset stays inside the row: `ceil((W + 2m) / 64) >= ceil(W / 64) + floor(2m / 64)`.
        let mut grid = spare_grids::take(width, height, 1);
        let mut row_occupied = vec![false; height];
        let margin = margin_px.map(|m| m as i64);
        polyline.draw(vertices_px, [0, 0], |[column, row]| {
            let column = i64::from(column) + margin[0];
            let row = i64::from(row) + margin[1];
            if (0..width as i64).contains(&column) && (0..height as i64).contains(&row) {
                grid.set(column as usize, row as usize);
                row_occupied[row as usize] = true;
            }
        });
        let occupied_rows = (0..height).filter(|&row| row_occupied[row]).collect();
        RotatedScan {
            grid,
            margin_px,
            occupied_rows,
        }
    }

    /// Number of pixels of this drawing, shifted by `offset_px`, that land inside the raster on
    /// a pixel that is not set in `blocked` (a raster-size grid whose padding bits are set).
    ///
    /// With `blocked` the reference drawing, this is what the candidate adds to the union; with
    /// a max-pooled level it is a lower bound over a block of candidates.
    ///
    /// `offset_px` must lie within the margins given to [`RotatedScan::new`].
    pub(crate) fn uncovered_px(&self, blocked: &BitGrid, offset_px: [i32; 2]) -> u32 {
        self.uncovered_px_at(SimdLevel::detected(), blocked, offset_px)
    }

    /// [`Self::uncovered_px`] by the build for `level`, which must not exceed
    /// [`SimdLevel::detected`].
    #[inline]
    fn uncovered_px_at(&self, level: SimdLevel, blocked: &BitGrid, offset_px: [i32; 2]) -> u32 {
        debug_assert!(level <= SimdLevel::detected());
        #[cfg(target_arch = "x86_64")]
        match level {
            // SAFETY: the CPU has every feature these builds are compiled for.
            SimdLevel::Avx512 => return unsafe { self.uncovered_px_avx512(blocked, offset_px) },
            SimdLevel::Avx2 => return unsafe { self.uncovered_px_avx2(blocked, offset_px) },
            SimdLevel::Baseline => {}
        }
        self.count_uncovered_px(blocked, offset_px)
    }

    /// [`Self::uncovered_px`] compiled for AVX2 and POPCNT.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,popcnt,bmi2")]
    unsafe fn uncovered_px_avx2(&self, blocked: &BitGrid, offset_px: [i32; 2]) -> u32 {
        self.count_uncovered_px(blocked, offset_px)
    }

    /// [`Self::uncovered_px`] compiled for AVX-512's vector popcount.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,popcnt,bmi2,avx512f,avx512vl,avx512bw,avx512vpopcntdq")]
    unsafe fn uncovered_px_avx512(&self, blocked: &BitGrid, offset_px: [i32; 2]) -> u32 {
        self.count_uncovered_px(blocked, offset_px)
    }

    /// The body of [`Self::uncovered_px`], inlined into each build of it.
    #[inline(always)]
    fn count_uncovered_px(&self, blocked: &BitGrid, offset_px: [i32; 2]) -> u32 {
        let first_column = self.margin_px[0] as i64 - i64::from(offset_px[0]);
        let first_row = self.margin_px[1] as i64 - i64::from(offset_px[1]);
        debug_assert!(first_column >= 0 && first_column <= 2 * self.margin_px[0] as i64);
        debug_assert!(first_row >= 0 && first_row <= 2 * self.margin_px[1] as i64);
        let first_column = first_column as usize;
        let first_row = first_row as usize;
        let end_row = first_row + blocked.height_px();

        let start = self.occupied_rows.partition_point(|&r| r < first_row);
        let end = self.occupied_rows.partition_point(|&r| r < end_row);
        // Each output word funnels two neighbouring source words; the split is the same for
        // the whole call. `(high << 1) << (63 - shift)` is `high << (64 - shift)` and vanishes
        // for a zero shift without a branch.
        let first_word = first_column / 64;
        let shift = (first_column % 64) as u32;
        let rows = &self.occupied_rows[start..end];
        match blocked.words_per_row() {
            // The 256-pixel rasters of the SLAM and the benchmark: a row is one vector.
            4 => self.count_rows::<4>(blocked, rows, first_row, first_word, shift),
            // The 512-pixel rasters of the wide loop-closure search.
            8 => self.count_rows::<8>(blocked, rows, first_row, first_word, shift),
            words => {
                let mut uncovered = 0;
                for &row in rows {
                    // The spare word of `grid` keeps this window inside the row (see `new`).
                    let source = &self.grid.row(row)[first_word..first_word + words + 1];
                    let blocked_row = blocked.row(row - first_row);
                    for (pair, &blocked_word) in source.windows(2).zip(blocked_row) {
                        let word = (pair[0] >> shift) | ((pair[1] << 1) << (63 - shift));
                        uncovered += (word & !blocked_word).count_ones();
                    }
                }
                uncovered
            }
        }
    }

    /// The count of [`Self::count_uncovered_px`] over `rows` for rasters of `WORDS` words a
    /// row, with fixed-size arrays the compiler can keep in registers.
    #[inline(always)]
    fn count_rows<const WORDS: usize>(
        &self,
        blocked: &BitGrid,
        rows: &[usize],
        first_row: usize,
        first_word: usize,
        shift: u32,
    ) -> u32 {
        let mut counts = [0u32; WORDS];
        for &row in rows {
            let source = self.grid.row(row);
            let (Some(low), Some(high), Ok(blocked_row)) = (
                source.get(first_word..first_word + WORDS),
                source.get(first_word + 1..first_word + 1 + WORDS),
                <&[u64; WORDS]>::try_from(blocked.row(row - first_row)),
            ) else {
                // Cannot happen: the spare word and the caller's `WORDS` keep both in range.
                debug_assert!(
                    false,
                    "row {row} out of the drawing's or the raster's words"
                );
                continue;
            };
            for i in 0..WORDS {
                let word = (low[i] >> shift) | ((high[i] << 1) << (63 - shift));
                counts[i] += (word & !blocked_row[i]).count_ones();
            }
        }
        counts.iter().sum()
    }
}

impl Drop for RotatedScan {
    /// Hands the grid, cleared, to the next drawing of the same shape.
    fn drop(&mut self) {
        let mut grid = std::mem::replace(&mut self.grid, BitGrid::new(0, 0, 0));
        for &row in &self.occupied_rows {
            grid.row_mut(row).fill(0);
        }
        spare_grids::give_back(grid);
    }
}

/// Cleared grids of dropped drawings, per thread, for the next drawings of the same shape.
///
/// A match draws every rotation of the table (361 for a search over every heading) on a
/// fresh grid and drops them all at its end. Allocating and zeroing them anew each time cost
/// more than the drawing; a drawing sets few rows, so clearing those is cheap.
mod spare_grids {
    use super::BitGrid;
    use std::cell::RefCell;

    /// Grids kept per shape, enough for the largest table of rotations in use.
    const MAX_PER_SHAPE: usize = 512;
    /// Words kept per shape (32 MiB), so that large rasters are not held on to in hundreds.
    const MAX_WORDS_PER_SHAPE: usize = 1 << 22;
    /// Shapes kept; the least recently used one goes first.
    const MAX_SHAPES: usize = 8;

    type Shape = (usize, usize, usize);

    thread_local! {
        static SPARE: RefCell<Vec<(Shape, Vec<BitGrid>)>> = const { RefCell::new(Vec::new()) };
    }

    fn shape_of(grid: &BitGrid) -> Shape {
        (grid.width_px(), grid.height_px(), grid.words_per_row())
    }

    /// An all-clear grid as [`BitGrid::new`] makes it, from the spares when one fits.
    pub(super) fn take(width_px: usize, height_px: usize, spare_words: usize) -> BitGrid {
        let shape = (width_px, height_px, width_px.div_ceil(64) + spare_words);
        let kept = SPARE.with_borrow_mut(|spare| {
            let index = spare.iter().position(|(s, _)| *s == shape)?;
            // Most recently used last.
            let entry = spare.remove(index);
            spare.push(entry);
            spare.last_mut()?.1.pop()
        });
        kept.unwrap_or_else(|| BitGrid::new(width_px, height_px, spare_words))
    }

    /// Keeps `grid`, which must be all clear, for a later [`take`].
    pub(super) fn give_back(grid: BitGrid) {
        if grid.height_px() == 0 {
            return;
        }
        let shape = shape_of(&grid);
        let words = shape.1 * shape.2;
        let room = |kept: usize| kept < MAX_PER_SHAPE && (kept + 1) * words <= MAX_WORDS_PER_SHAPE;
        SPARE.with_borrow_mut(|spare| match spare.iter_mut().find(|(s, _)| *s == shape) {
            Some((_, grids)) if room(grids.len()) => grids.push(grid),
            Some(_) => {}
            None if room(0) => {
                if spare.len() == MAX_SHAPES {
                    spare.remove(0);
                }
                spare.push((shape, vec![grid]));
            }
            None => {}
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;
    use crate::scan_match::scan::Scan;

    /// Checks `uncovered_px` against drawing each shifted candidate directly, on a raster of
    /// `size_px` whose reference blocks a stretch of one row, for every offset within `margin_px`.
    fn check_against_direct_drawing(size_px: [u32; 2], margin_px: [usize; 2]) {
        let [width, height] = size_px;
        let raster = RasterOptions {
            resolution_m: 0.1,
            width_px: width,
            height_px: height,
            max_gap_m: 1.0,
        };
        let scan = Scan::from_points_in_robot(vec![
            Some([-3.3, -1.9]),
            Some([-2.5, -1.0]),
            Some([3.4, 1.9]),
            None,
            Some([0.05, 0.05]),
            Some([0.5, 0.0]),
        ]);
        let polyline = Polyline::new(&scan, raster.max_gap_m);
        let vertices = polyline.vertices_px(Pose2::IDENTITY, &raster);
        let rotated = RotatedScan::new(&polyline, &vertices, &raster, margin_px);

        let (width, height) = (width as usize, height as usize);
        let mut blocked = BitGrid::new(width, height, 0);
        for column in width / 2 - 5..width / 2 + 5 {
            blocked.set(column, height / 2);
        }
        blocked.fill_padding();
        let [mx, my] = margin_px.map(|m| m as i32);
        for dx in -mx..=mx {
            for dy in -my..=my {
                let mut expected = std::collections::HashSet::new();
                polyline.draw(&vertices, [dx, dy], |[c, r]| {
                    let inside = (0..width as i32).contains(&c) && (0..height as i32).contains(&r);
                    if inside && !blocked.get(c as usize, r as usize) {
                        expected.insert([c, r]);
                    }
                });
                assert_eq!(
                    rotated.uncovered_px(&blocked, [dx, dy]) as usize,
                    expected.len(),
                    "offset ({dx}, {dy})"
                );
                // Every build this CPU runs, whichever one `uncovered_px` picks.
                for level in [SimdLevel::Baseline, SimdLevel::Avx2, SimdLevel::Avx512] {
                    if level <= SimdLevel::detected() {
                        assert_eq!(
                            rotated.uncovered_px_at(level, &blocked, [dx, dy]) as usize,
                            expected.len(),
                            "offset ({dx}, {dy}), {level:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn test_uncovered_matches_direct_drawing() {
        check_against_direct_drawing([70, 40], [5, 3]);
    }

    #[test]
    fn test_uncovered_matches_direct_drawing_across_words() {
        // Offsets of more than a word, so that the drawing's words slide past the raster's.
        check_against_direct_drawing([200, 40], [70, 3]);
    }

    #[test]
    fn test_uncovered_matches_direct_drawing_on_the_slam_rasters() {
        // The 256- and 512-pixel rasters, whose rows are counted as fixed-size arrays.
        check_against_direct_drawing([256, 24], [70, 2]);
        check_against_direct_drawing([512, 24], [70, 2]);
    }

    #[test]
    fn a_drawing_on_a_recycled_grid_is_the_drawing_on_a_fresh_one() {
        let raster = RasterOptions {
            resolution_m: 0.1,
            width_px: 120,
            height_px: 50,
            max_gap_m: 1.0,
        };
        let margin_px = [4, 2];
        let draw = |points: Vec<Option<[f64; 2]>>| {
            let polyline = Polyline::new(&Scan::from_points_in_robot(points), raster.max_gap_m);
            let vertices = polyline.vertices_px(Pose2::IDENTITY, &raster);
            RotatedScan::new(&polyline, &vertices, &raster, margin_px)
        };
        // Pixels on different rows, so that a row left uncleared would show.
        let first = || vec![Some([-5.0, -2.0]), Some([-4.5, -1.7]), Some([0.0, 2.4])];
        let second = || vec![Some([1.0, 1.0]), Some([1.5, -1.0])];
        // Drawn on fresh grids: no drawing of that shape has been dropped yet.
        let (fresh_first, fresh_second) = (draw(first()), draw(second()));
        let fresh = (fresh_first.grid.clone(), fresh_second.grid.clone());
        // Spares are taken last given first: the second scan gets the first one's grid.
        drop(fresh_second);
        drop(fresh_first);
        let recycled_second = draw(second());
        let recycled_first = draw(first());
        assert_eq!(recycled_first.grid, fresh.0);
        assert_eq!(recycled_second.grid, fresh.1);
        assert_ne!(fresh.0, fresh.1);
    }
}
