//! A bit-packed binary raster: one bit per pixel, rows of `u64` words, column 0 in bit 0 of
//! word 0 of its row.
//!
//! Rows are padded to whole words (plus optional spare words); the padding bits are set by the
//! owner to whatever "outside the raster" should read as, and [`BitGrid::read_word`] extends the
//! row past its storage with a caller-chosen fill, so a window may slide off either end.

/// A binary raster of `width_px` × `height_px` bits stored row by row in `u64` words.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct BitGrid {
    width_px: usize,
    height_px: usize,
    words_per_row: usize,
    words: Vec<u64>,
}

impl BitGrid {
    /// An all-clear grid with `spare_words` extra words at the end of each row.
    pub(crate) fn new(width_px: usize, height_px: usize, spare_words: usize) -> Self {
        let words_per_row = width_px.div_ceil(64) + spare_words;
        BitGrid {
            width_px,
            height_px,
            words_per_row,
            words: vec![0; words_per_row * height_px],
        }
    }

    /// Width in pixels (without padding).
    pub(crate) fn width_px(&self) -> usize {
        self.width_px
    }

    /// Height in pixels.
    pub(crate) fn height_px(&self) -> usize {
        self.height_px
    }

    /// Words stored per row, padding and spare words included.
    pub(crate) fn words_per_row(&self) -> usize {
        self.words_per_row
    }

    /// Sets the pixel at (`column`, `row`); both must be inside the grid.
    pub(crate) fn set(&mut self, column: usize, row: usize) {
        debug_assert!(column < self.width_px && row < self.height_px);
        self.words[row * self.words_per_row + column / 64] |= 1 << (column % 64);
    }

    /// Whether the pixel at (`column`, `row`) is set; both must be inside the grid.
    #[cfg(test)]
    pub(crate) fn get(&self, column: usize, row: usize) -> bool {
        debug_assert!(column < self.width_px && row < self.height_px);
        self.words[row * self.words_per_row + column / 64] >> (column % 64) & 1 == 1
    }

    /// Sets every padding bit, from column `width_px` to the end of each row's storage.
    pub(crate) fn fill_padding(&mut self) {
        for row in self.words.chunks_exact_mut(self.words_per_row) {
            for (w, word) in row.iter_mut().enumerate() {
                let first_column = w * 64;
                if first_column + 64 <= self.width_px {
                    continue;
                }
                let valid_bits = self.width_px.saturating_sub(first_column);
                *word |= !0 << valid_bits;
            }
        }
    }

    /// The words of `row`.
    pub(crate) fn row(&self, row: usize) -> &[u64] {
        &self.words[row * self.words_per_row..(row + 1) * self.words_per_row]
    }

    /// The words of `row`, mutable.
    pub(crate) fn row_mut(&mut self, row: usize) -> &mut [u64] {
        &mut self.words[row * self.words_per_row..(row + 1) * self.words_per_row]
    }

    /// Number of set bits, padding included.
    pub(crate) fn count_ones(&self) -> u32 {
        self.words.iter().map(|w| w.count_ones()).sum()
    }
}

/// The 64 bits of `row` starting at bit `first_bit`, with `fill` standing in for every bit past
/// the end of the row's storage.
#[inline]
pub(crate) fn read_word(row: &[u64], first_bit: usize, fill: u64) -> u64 {
    let word = first_bit / 64;
    let shift = first_bit % 64;
    let low = row.get(word).copied().unwrap_or(fill);
    if shift == 0 {
        return low;
    }
    let high = row.get(word + 1).copied().unwrap_or(fill);
    (low >> shift) | (high << (64 - shift))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_set_get_count() {
        let mut grid = BitGrid::new(70, 3, 0);
        assert_eq!(grid.words_per_row(), 2);
        grid.set(0, 0);
        grid.set(69, 2);
        grid.set(64, 1);
        assert!(grid.get(0, 0) && grid.get(69, 2) && grid.get(64, 1));
        assert!(!grid.get(1, 0));
        assert_eq!(grid.count_ones(), 3);
    }

    #[test]
    fn test_fill_padding() {
        let mut grid = BitGrid::new(70, 1, 1);
        grid.fill_padding();
        assert_eq!(grid.row(0), &[0, !0 << 6, !0]);
    }

    #[test]
    fn test_read_word_funnels_and_fills() {
        let row = [0xF0u64, 0x1];
        assert_eq!(read_word(&row, 0, 0), 0xF0);
        assert_eq!(read_word(&row, 4, 0), 0xF | 1 << 60);
        assert_eq!(read_word(&row, 64, 0), 1);
        assert_eq!(read_word(&row, 65, !0), !0 << 63);
        assert_eq!(read_word(&row, 200, !0), !0);
    }
}
