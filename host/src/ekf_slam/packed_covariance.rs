//! A symmetric matrix kept as its lower triangle, row by row.
//!
//! Entry `(i, j)` with `j ≤ i` is element `i (i + 1) / 2 + j` of one buffer: row `i` holds
//! `(i, 0) … (i, i)`, contiguous. Half the memory of the whole matrix, and a state that grows
//! by appending entries (a map join appends its new landmarks) appends rows at the end of
//! the buffer, where everything held stays in place.

use nalgebra::DMatrix;

use super::covariance_store::CovarianceStore;
use super::jcbb::CovarianceEntries;

/// A symmetric `dim × dim` matrix, its lower triangle row by row.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PackedCovariance {
    dim: usize,
    lower: Vec<f64>,
}

/// Elements of the lower triangle of a `dim × dim` matrix.
fn triangle(dim: usize) -> usize {
    dim * (dim + 1) / 2
}

impl PackedCovariance {
    /// Row `i` of the triangle: entries `(i, 0) … (i, i)`.
    fn row(&self, i: usize) -> &[f64] {
        &self.lower[triangle(i)..triangle(i + 1)]
    }

    /// The whole matrix, dense.
    pub fn to_dense(&self) -> DMatrix<f64> {
        DMatrix::from_fn(self.dim, self.dim, |r, c| self.entry(r, c))
    }
}

impl CovarianceEntries for PackedCovariance {
    fn entry(&self, row: usize, column: usize) -> f64 {
        let (i, j) = if column <= row {
            (row, column)
        } else {
            (column, row)
        };
        self.lower[triangle(i) + j]
    }
}

impl CovarianceStore for PackedCovariance {
    fn from_square(matrix: DMatrix<f64>) -> Self {
        debug_assert!(matrix.is_square());
        let dim = matrix.nrows();
        let mut lower = Vec::with_capacity(triangle(dim));
        for i in 0..dim {
            lower.extend((0..=i).map(|j| matrix[(i, j)]));
        }
        PackedCovariance { dim, lower }
    }

    fn dim(&self) -> usize {
        self.dim
    }

    fn set(&mut self, row: usize, column: usize, value: f64) {
        let (i, j) = if column <= row {
            (row, column)
        } else {
            (column, row)
        };
        self.lower[triangle(i) + j] = value;
    }

    fn grow(&mut self, dim: usize) {
        debug_assert!(dim >= self.dim);
        let needed = triangle(dim);
        if self.lower.capacity() < needed {
            let planned = triangle(dim + dim / 4);
            self.lower.reserve_exact(planned - self.lower.len());
        }
        self.lower.resize(needed, 0.0);
        self.dim = dim;
    }

    fn gather(&mut self, keep: &[usize]) {
        debug_assert!(
            keep.windows(2).all(|w| w[0] < w[1]) && keep.last().is_none_or(|&l| l < self.dim)
        );
        // Entry (a, b), b ≤ a, goes to triangle(a) + b ≤ triangle(keep[a]) + keep[b], where it
        // comes from: walking forward never overwrites an entry still to be read.
        for (a, &from_row) in keep.iter().enumerate() {
            let from = triangle(from_row);
            for (b, &from_column) in keep[..=a].iter().enumerate() {
                self.lower[triangle(a) + b] = self.lower[from + from_column];
            }
        }
        self.dim = keep.len();
        self.lower.truncate(triangle(self.dim));
    }

    /// One column of `W` at a time: row `i` of the triangle takes `−w_ik · w_{0..=i, k}`, an
    /// `axpy` over contiguous memory on both sides, and nothing beyond `W` is formed.
    fn subtract_outer_product(&mut self, w: &DMatrix<f64>) {
        debug_assert_eq!(w.nrows(), self.dim);
        for k in 0..w.ncols() {
            let column = w.column(k);
            let column = column.as_slice();
            for (i, &w_ik) in column.iter().enumerate() {
                if w_ik == 0.0 {
                    continue;
                }
                let row = &mut self.lower[triangle(i)..triangle(i + 1)];
                for (p, &w_jk) in row.iter_mut().zip(&column[..=i]) {
                    *p -= w_ik * w_jk;
                }
            }
        }
    }

    fn rows(&self, first: usize, count: usize) -> DMatrix<f64> {
        let mut rows = DMatrix::zeros(count, self.dim);
        for r in 0..count {
            let i = first + r;
            // Left of the diagonal from row i itself, right of it down column i.
            for (c, &value) in self.row(i).iter().enumerate() {
                rows[(r, c)] = value;
            }
            for c in i + 1..self.dim {
                rows[(r, c)] = self.lower[triangle(c) + i];
            }
        }
        rows
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn symmetric(n: usize) -> DMatrix<f64> {
        let a = DMatrix::from_fn(n, n, |r, c| ((r * 7 + c * 3) % 11) as f64 * 0.05 - 0.2);
        &a * a.transpose() + DMatrix::identity(n, n) * 0.3
    }

    #[test]
    fn holds_every_entry_of_the_matrix() {
        let dense = symmetric(9);
        let packed = PackedCovariance::from_square(dense.clone());
        assert_eq!(packed.to_dense(), dense);
        assert_eq!(packed.lower.len(), 45);
        assert_eq!(CovarianceStore::rows(&packed, 3, 3), dense.rows(3, 3));
        assert_eq!(packed.block(5, 2), dense.view((5, 5), (2, 2)));
    }

    #[test]
    fn grows_gathers_and_sets_as_the_whole_matrix() {
        let dense = symmetric(9);
        let mut packed = PackedCovariance::from_square(dense.clone());
        let mut whole = dense.clone();
        packed.grow(12);
        CovarianceStore::grow(&mut whole, 12);
        packed.set(10, 4, 2.5);
        whole.set(10, 4, 2.5);
        packed.set(1, 11, -1.5);
        whole.set(1, 11, -1.5);
        assert_eq!(packed.to_dense(), whole);
        let keep = [0, 1, 2, 4, 7, 10, 11];
        packed.gather(&keep);
        whole.gather(&keep);
        assert_eq!(packed.dim(), 7);
        assert_eq!(packed.to_dense(), whole);
    }

    #[test]
    fn subtracts_the_outer_product_as_the_whole_matrix() {
        let dense = symmetric(150);
        let w = DMatrix::from_fn(150, 6, |r, c| ((r * 5 + c * 13) % 17) as f64 * 0.01 - 0.08);
        let mut packed = PackedCovariance::from_square(dense.clone());
        let mut whole = dense;
        packed.subtract_outer_product(&w);
        whole.subtract_outer_product(&w);
        assert!((packed.to_dense() - whole).amax() < 1e-12);
    }
}
