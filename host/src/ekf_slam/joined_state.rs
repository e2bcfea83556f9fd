//! The state a map join forms, read before it is formed.
//!
//! Joining a local map replaces the global map's pose by the local map's robot and appends
//! the local map's landmarks: `[pose, landmarks]` becomes
//! `[new pose, landmarks, new landmarks]`. Data association then pairs new landmarks with old
//! ones, and the paired new ones are fused away at once. Formed in full first, the covariance
//! would grow by every new landmark only to shrink again, and the map's memory would peak at
//! that transient on every join. [`JoinedState`] reads the joined state's entries in place,
//! from the map's state and the blocks of the new entries, so the pairing runs on it and the
//! state grows only by what stays (`EkfState::replace_pose_append_and_fuse`).

use nalgebra::{DMatrix, DVector};

use super::covariance_store::CovarianceStore;
use super::ekf_state::EkfState;
use super::jcbb::CovarianceEntries;

/// The covariance of a join's new entries with the map's state. The new entries depend on
/// the map only through its pose, so it is `left · right`: their `k × 3` regression on the
/// pose times the pose's `3 × n` covariance with the state. It is kept as the two factors;
/// formed, the `k × n` block would be a join's largest working memory after the map itself.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossCovariance {
    left: DMatrix<f64>,
    right: DMatrix<f64>,
}

impl CrossCovariance {
    /// `left` (`k × 3`) times `right` (`3 × n`).
    ///
    /// # Panics
    /// If the factors are not `k × 3` and `3 × n` (a programming error).
    pub fn new(left: DMatrix<f64>, right: DMatrix<f64>) -> CrossCovariance {
        assert_eq!(left.ncols(), 3, "the left factor has three columns");
        assert_eq!(right.nrows(), 3, "the right factor has three rows");
        CrossCovariance { left, right }
    }

    /// Rows: the new entries.
    pub fn nrows(&self) -> usize {
        self.left.nrows()
    }

    /// Columns: the state's entries.
    pub fn ncols(&self) -> usize {
        self.right.ncols()
    }

    /// Entry `(row, column)` of the product, summed in the order nalgebra's product of the
    /// factors sums it, so it is the formed product's entry to the bit.
    pub fn entry(&self, row: usize, column: usize) -> f64 {
        let mut sum = self.left[(row, 0)] * self.right[(0, column)];
        for t in 1..3 {
            sum += self.left[(row, t)] * self.right[(t, column)];
        }
        sum
    }

    /// The rows `rows` of the product.
    pub fn select_rows(&self, rows: &[usize]) -> CrossCovariance {
        CrossCovariance {
            left: self.left.select_rows(rows),
            right: self.right.clone(),
        }
    }
}

/// `[new pose, landmarks, new landmarks]` over a state `[pose, landmarks]` (a robot of three
/// entries) and the new entries `new` (a pose, then landmarks) with their covariance with
/// the state (`cross`, rows: new entries; its first three columns, the old pose's, are
/// never read) and among themselves (`own`), as `EkfState::replace_pose_and_append` takes
/// them.
#[derive(Debug)]
pub struct JoinedState<'a, C = DMatrix<f64>> {
    state: &'a EkfState<C>,
    new: &'a DVector<f64>,
    cross: &'a CrossCovariance,
    own: &'a DMatrix<f64>,
}

/// Where an entry of the joined state is held.
#[derive(Debug, Clone, Copy)]
enum Source {
    /// Entry of the map's state.
    Map(usize),
    /// Entry of the new entries.
    New(usize),
}

impl<'a, C: CovarianceStore> JoinedState<'a, C> {
    /// The view; see the type's documentation for the arguments.
    pub fn new(
        state: &'a EkfState<C>,
        new: &'a DVector<f64>,
        cross: &'a CrossCovariance,
        own: &'a DMatrix<f64>,
    ) -> JoinedState<'a, C> {
        debug_assert_eq!(state.robot_dim(), 3);
        debug_assert!(new.len() >= 3 && (new.len() - 3).is_multiple_of(2));
        debug_assert_eq!((cross.nrows(), cross.ncols()), (new.len(), state.dim()));
        debug_assert_eq!(own.shape(), (new.len(), new.len()));
        JoinedState {
            state,
            new,
            cross,
            own,
        }
    }

    /// Entries of the joined state.
    pub fn dim(&self) -> usize {
        self.state.dim() + self.new.len() - 3
    }

    /// Landmarks of the joined state: the map's, then the new ones.
    pub fn landmark_count(&self) -> usize {
        (self.dim() - 3) / 2
    }

    /// Entry `index` of the joined state's mean.
    pub fn mean_entry(&self, index: usize) -> f64 {
        match self.source(index) {
            Source::Map(i) => self.state.mean()[i],
            Source::New(i) => self.new[i],
        }
    }

    /// Index in the joined state of landmark `i`'s `x_m`.
    pub fn landmark_offset(&self, i: usize) -> usize {
        self.state.landmark_offset(i)
    }

    /// Landmark `i` of the joined state.
    pub fn landmark(&self, i: usize) -> [f64; 2] {
        let offset = self.state.landmark_offset(i);
        [self.mean_entry(offset), self.mean_entry(offset + 1)]
    }

    fn source(&self, index: usize) -> Source {
        let n = self.state.dim();
        if index < 3 {
            Source::New(index)
        } else if index < n {
            Source::Map(index)
        } else {
            Source::New(index - n + 3)
        }
    }
}

impl<C: CovarianceStore> CovarianceEntries for JoinedState<'_, C> {
    fn entry(&self, row: usize, column: usize) -> f64 {
        match (self.source(row), self.source(column)) {
            (Source::Map(r), Source::Map(c)) => self.state.covariance().entry(r, c),
            // The lower triangle, as the join stores it.
            (Source::New(r), Source::New(c)) => self.own[(r.max(c), r.min(c))],
            (Source::New(r), Source::Map(c)) => self.cross.entry(r, c),
            (Source::Map(r), Source::New(c)) => self.cross.entry(c, r),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factored_cross_covariance_is_the_product_to_the_bit() {
        let left = DMatrix::from_fn(7, 3, |r, c| ((r * 5 + c * 3) % 11) as f64 / 3.0 - 1.7);
        let right = DMatrix::from_fn(3, 40, |r, c| ((r * 13 + c * 7) % 17) as f64 / 9.0 - 0.8);
        let product = &left * &right;
        let cross = CrossCovariance::new(left, right);
        for r in 0..7 {
            for c in 0..40 {
                assert_eq!(cross.entry(r, c), product[(r, c)], "({r}, {c})");
            }
        }
        let rows = cross.select_rows(&[1, 4]);
        assert_eq!(rows.entry(1, 9), product[(4, 9)]);
    }

    #[test]
    fn reads_what_the_append_forms() {
        // A pose and two landmarks, joined with a new pose and one new landmark.
        let n = 7;
        let k = 5;
        let covariance = DMatrix::from_fn(n, n, |r, c| 1.0 / (1.0 + r as f64 + c as f64));
        let mean = DVector::from_fn(n, |i, _| i as f64);
        let state = EkfState::from_parts(mean, covariance, 3);
        let new = DVector::from_fn(k, |i, _| 100.0 + i as f64);
        let cross = CrossCovariance::new(
            DMatrix::from_fn(k, 3, |r, c| 0.5 + (r * 3 + c) as f64),
            DMatrix::from_fn(3, n, |r, c| 1.0 / (2.0 + (r * n + c) as f64)),
        );
        let own = DMatrix::from_fn(k, k, |r, c| 50.0 + (r + c) as f64);
        let view = JoinedState::new(&state, &new, &cross, &own);
        let mut formed = state.clone();
        formed.replace_pose_and_append(&new, &cross, &own);
        assert_eq!(view.dim(), formed.dim());
        assert_eq!(view.landmark_count(), 3);
        for r in 0..formed.dim() {
            assert_eq!(view.mean_entry(r), formed.mean()[r]);
            for c in 0..formed.dim() {
                assert_eq!(view.entry(r, c), formed.covariance()[(r, c)], "({r}, {c})");
            }
        }
    }
}
