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

use super::ekf_state::EkfState;
use super::jcbb::CovarianceEntries;

/// `[new pose, landmarks, new landmarks]` over a state `[pose, landmarks]` (a robot of three
/// entries) and the new entries `new` (a pose, then landmarks) with their covariance with
/// the state (`cross`, rows: new entries; its first three columns, the old pose's, are
/// never read) and among themselves (`own`), as `EkfState::replace_pose_and_append` takes
/// them.
#[derive(Debug, Clone, Copy)]
pub struct JoinedState<'a> {
    state: &'a EkfState,
    new: &'a DVector<f64>,
    cross: &'a DMatrix<f64>,
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

impl<'a> JoinedState<'a> {
    /// The view; see the type's documentation for the arguments.
    pub fn new(
        state: &'a EkfState,
        new: &'a DVector<f64>,
        cross: &'a DMatrix<f64>,
        own: &'a DMatrix<f64>,
    ) -> JoinedState<'a> {
        debug_assert_eq!(state.robot_dim(), 3);
        debug_assert!(new.len() >= 3 && (new.len() - 3).is_multiple_of(2));
        debug_assert_eq!(cross.shape(), (new.len(), state.dim()));
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

impl CovarianceEntries for JoinedState<'_> {
    fn entry(&self, row: usize, column: usize) -> f64 {
        match (self.source(row), self.source(column)) {
            (Source::Map(r), Source::Map(c)) => self.state.covariance()[(r, c)],
            (Source::New(r), Source::New(c)) => self.own[(r, c)],
            (Source::New(r), Source::Map(c)) => self.cross[(r, c)],
            (Source::Map(r), Source::New(c)) => self.cross[(c, r)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_what_the_append_forms() {
        // A pose and two landmarks, joined with a new pose and one new landmark.
        let n = 7;
        let k = 5;
        let covariance = DMatrix::from_fn(n, n, |r, c| 1.0 / (1.0 + r as f64 + c as f64));
        let mean = DVector::from_fn(n, |i, _| i as f64);
        let state = EkfState::from_parts(mean, covariance, 3);
        let new = DVector::from_fn(k, |i, _| 100.0 + i as f64);
        let cross = DMatrix::from_fn(k, n, |r, c| 10.0 + (r * n + c) as f64);
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
