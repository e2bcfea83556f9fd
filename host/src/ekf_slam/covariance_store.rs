//! How an [`EkfState`](super::EkfState) keeps its covariance.
//!
//! A covariance is symmetric, so it can be kept whole ([`DMatrix`], what the local maps use:
//! their updates are dense matrix products) or as one triangle
//! ([`PackedCovariance`](super::packed_covariance::PackedCovariance), what the global map
//! uses: the largest structure of the method, it grows with the area mapped, and half of it
//! is the other half's mirror). [`CovarianceStore`] is what the operations both share need
//! of either.

use nalgebra::DMatrix;

use super::jcbb::CovarianceEntries;

/// A symmetric matrix kept so that the filter's shared operations can read and change it.
pub trait CovarianceStore: CovarianceEntries + Clone + std::fmt::Debug + PartialEq {
    /// The store holding the square, symmetric `matrix`.
    fn from_square(matrix: DMatrix<f64>) -> Self;

    /// Rows (and columns).
    fn dim(&self) -> usize;

    /// Sets entry `(row, column)` and its mirror `(column, row)`.
    fn set(&mut self, row: usize, column: usize, value: f64);

    /// Grows to `dim` rows and columns; the entries already held keep their place and
    /// value, the new ones are zero. Room for a quarter more is reserved when the buffer
    /// must grow, so the joins that follow grow it without reallocating it each time.
    fn grow(&mut self, dim: usize);

    /// Keeps only the rows and columns `keep` (increasing), compacted in place.
    fn gather(&mut self, keep: &[usize]);

    /// `P −= W Wᵀ` for a `W` of as many rows as `P`.
    fn subtract_outer_product(&mut self, w: &DMatrix<f64>);

    /// The rows `first .. first + count` as a dense `count × n` matrix.
    fn rows(&self, first: usize, count: usize) -> DMatrix<f64> {
        DMatrix::from_fn(count, self.dim(), |r, c| self.entry(first + r, c))
    }

    /// The square block at `first` of `size` rows, dense.
    fn block(&self, first: usize, size: usize) -> DMatrix<f64> {
        DMatrix::from_fn(size, size, |r, c| self.entry(first + r, first + c))
    }
}

impl CovarianceStore for DMatrix<f64> {
    fn from_square(matrix: DMatrix<f64>) -> Self {
        debug_assert!(matrix.is_square());
        matrix
    }

    fn dim(&self) -> usize {
        self.nrows()
    }

    fn set(&mut self, row: usize, column: usize, value: f64) {
        self[(row, column)] = value;
        self[(column, row)] = value;
    }

    fn grow(&mut self, dim: usize) {
        let n = self.nrows();
        debug_assert!(dim >= n);
        // Grown by value in its own buffer (reallocated, not copied into fresh zeroed
        // memory): `resize_mut` would clone the matrix first.
        let mut data: Vec<f64> = std::mem::replace(self, DMatrix::zeros(0, 0)).data.into();
        if data.capacity() < dim * dim {
            let planned = dim + dim / 4;
            data.reserve_exact(planned * planned - data.len());
        }
        *self = DMatrix::from_vec(n, n, data).resize(dim, dim, 0.0);
    }

    fn gather(&mut self, keep: &[usize]) {
        let n = self.nrows();
        let k = keep.len();
        debug_assert!(keep.windows(2).all(|w| w[0] < w[1]) && keep.last().is_none_or(|&l| l < n));
        let mut data: Vec<f64> = std::mem::replace(self, DMatrix::zeros(0, 0)).data.into();
        // Entry (to_row, to_col) goes to to_col·k + to_row ≤ from_col·n + from_row, where it
        // comes from: walking forward never overwrites an entry still to be read.
        for (to_col, &from_col) in keep.iter().enumerate() {
            for (to_row, &from_row) in keep.iter().enumerate() {
                data[to_col * k + to_row] = data[from_col * n + from_row];
            }
        }
        data.truncate(k * k);
        *self = DMatrix::from_vec(k, k, data);
    }

    /// A band of columns at a time, so that only a band of `Wᵀ` is formed at once (the whole
    /// of it is as large as `W`, and a join's memory peaks while it is held). `gemm` with an
    /// explicit transpose uses its blocked kernel (`gemm_tr` would take dot products column
    /// by column); every entry sums its products in the same order whatever the bands, so
    /// entries (i, j) and (j, i) stay equal to the bit. The bands are near-equal and at least
    /// `MIN_BAND` wide, so none is narrow enough for nalgebra to leave the blocked kernel.
    fn subtract_outer_product(&mut self, w: &DMatrix<f64>) {
        const MAX_BAND: usize = 128;
        const MIN_BAND: usize = 64;
        let n = self.ncols();
        debug_assert_eq!(w.nrows(), n);
        let bands = n.div_ceil(MAX_BAND).min((n / MIN_BAND).max(1));
        let mut first = 0;
        for band in 0..bands {
            let width = (n - first) / (bands - band);
            let band_of_w_t = w.rows(first, width).transpose();
            self.columns_mut(first, width)
                .gemm(-1.0, w, &band_of_w_t, 1.0);
            first += width;
        }
        debug_assert_eq!(first, n);
    }

    fn rows(&self, first: usize, count: usize) -> DMatrix<f64> {
        self.view((first, 0), (count, self.ncols())).into_owned()
    }

    fn block(&self, first: usize, size: usize) -> DMatrix<f64> {
        self.view((first, first), (size, size)).into_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_outer_product_by_bands_is_the_whole_product_to_the_bit() {
        for (n, m) in [(5, 4), (70, 6), (130, 20), (301, 34)] {
            let w = DMatrix::from_fn(n, m, |r, c| ((r * 31 + c * 17) % 23) as f64 / 7.0 - 1.3);
            let p = DMatrix::from_fn(n, n, |r, c| ((r + c) % 13) as f64 * 0.1);
            let mut whole = p.clone();
            whole.gemm(-1.0, &w, &w.transpose(), 1.0);
            let mut banded = p;
            banded.subtract_outer_product(&w);
            assert_eq!(banded, whole, "{n} × {m}");
        }
    }
}
