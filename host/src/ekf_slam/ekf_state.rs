//! The EKF's state and covariance: a robot block followed by 2D point landmarks.
//!
//! Layout of the state vector: the robot's `robot_dim` entries first, of which the first three
//! are always its pose `[x_m, y_m, theta_rad]` in the filter's frame (the rest are motion-model
//! states such as odometry calibration or velocities), then two entries `[x_m, y_m]` per
//! landmark. The covariance is kept full and symmetric: as the whole matrix (the local maps,
//! whose updates are dense products; symmetry checked by `debug_assert!`) or as its lower
//! triangle (the global map, [`CovarianceStore`]).
//!
//! Prediction touches only the robot rows and columns (O(n)); an update of `m` measurement
//! rows costs O(n² m) and uses the Joseph form
//! `P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ`, which keeps `P` positive semi-definite when the
//! gain is not exactly optimal (clipped angles, constraints with tiny noise).

use nalgebra::{DMatrix, DVector, Matrix2, Matrix2x3, Matrix3};

use super::covariance_store::CovarianceStore;
use super::jcbb::CovarianceEntries;
use super::joined_state::{CrossCovariance, JoinedState};
use crate::geometry::{Pose2, wrap_angle_rad};

/// Index of the heading in the state vector.
const THETA: usize = 2;

/// What can go wrong inside the filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EkfError {
    /// An innovation covariance was not positive definite, so the update was not applied.
    #[error("innovation covariance is not positive definite")]
    CovarianceNotPositiveDefinite,
    /// Matrix sizes do not fit the state.
    #[error("measurement of {rows} rows does not fit a state of {state_dim}")]
    DimensionMismatch {
        /// Rows of the measurement.
        rows: usize,
        /// Entries of the state.
        state_dim: usize,
    },
    /// A measurement in the map frame reached a local map that does not estimate its base.
    #[error("the local map holds no estimate of its base frame")]
    MissingBase,
}

/// Mean and full covariance of the robot-and-landmarks state, the covariance kept whole
/// (`DMatrix`, the default: the local maps) or as one triangle
/// ([`PackedCovariance`](super::PackedCovariance): the global map).
#[derive(Debug, Clone, PartialEq)]
pub struct EkfState<C = DMatrix<f64>> {
    mean: DVector<f64>,
    covariance: C,
    robot_dim: usize,
}

/// Debug-checks that `matrix` is symmetric to rounding.
macro_rules! debug_assert_symmetric {
    ($matrix:expr) => {
        debug_assert!(
            {
                let m = &$matrix;
                let scale = m.amax().max(1.0);
                (m - m.transpose()).amax() <= 1e-9 * scale
            },
            "covariance lost its symmetry"
        )
    };
}

impl<C: CovarianceStore> EkfState<C> {
    /// A state with the robot only, its covariance kept in `C`.
    ///
    /// # Panics
    /// If the robot has fewer than three entries or the covariance is not square of the same
    /// size (a programming error, not an input error).
    pub fn with_covariance_store(
        robot_mean: DVector<f64>,
        robot_covariance: DMatrix<f64>,
    ) -> EkfState<C> {
        let robot_dim = robot_mean.len();
        assert!(robot_dim >= 3, "the robot state starts with a pose");
        assert_eq!(robot_covariance.shape(), (robot_dim, robot_dim));
        EkfState {
            mean: robot_mean,
            covariance: C::from_square(robot_covariance),
            robot_dim,
        }
    }

    /// A state with `robot_dim` robot entries followed by landmarks, for tests that build
    /// one directly.
    #[cfg(test)]
    pub(crate) fn from_parts_with_store(
        mean: DVector<f64>,
        covariance: DMatrix<f64>,
        robot_dim: usize,
    ) -> EkfState<C> {
        debug_assert!(robot_dim >= 3 && (mean.len() - robot_dim).is_multiple_of(2));
        debug_assert_eq!(covariance.shape(), (mean.len(), mean.len()));
        EkfState {
            mean,
            covariance: C::from_square(covariance),
            robot_dim,
        }
    }

    /// Entries of the robot block.
    pub fn robot_dim(&self) -> usize {
        self.robot_dim
    }

    /// Entries of the whole state.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Number of landmarks.
    pub fn landmark_count(&self) -> usize {
        (self.dim() - self.robot_dim) / 2
    }

    /// Index in the state vector of landmark `i`'s `x_m`.
    pub fn landmark_offset(&self, i: usize) -> usize {
        self.robot_dim + 2 * i
    }

    /// The state vector.
    pub fn mean(&self) -> &DVector<f64> {
        &self.mean
    }

    /// The covariance.
    pub fn covariance(&self) -> &C {
        &self.covariance
    }

    /// The robot pose (state entries 0..3) in the filter's frame.
    pub fn pose(&self) -> Pose2 {
        Pose2 {
            x_m: self.mean[0],
            y_m: self.mean[1],
            theta_rad: self.mean[2],
        }
    }

    /// The robot's motion-model entries (the whole robot block).
    pub fn robot(&self) -> DVector<f64> {
        self.mean.rows(0, self.robot_dim).into_owned()
    }

    /// Covariance of the robot pose.
    pub fn pose_covariance(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|r, c| self.covariance.entry(r, c))
    }

    /// Covariance of the whole robot block.
    pub fn robot_covariance(&self) -> DMatrix<f64> {
        self.covariance.block(0, self.robot_dim)
    }

    /// Position of landmark `i`, metres.
    pub fn landmark(&self, i: usize) -> [f64; 2] {
        let o = self.landmark_offset(i);
        [self.mean[o], self.mean[o + 1]]
    }

    /// Covariance of landmark `i`'s position.
    pub fn landmark_covariance(&self, i: usize) -> Matrix2<f64> {
        let o = self.landmark_offset(i);
        Matrix2::from_fn(|r, c| self.covariance.entry(o + r, o + c))
    }

    /// Replaces the pose (entries 0..3) by the first three of `new` and appends the rest as
    /// landmarks, in one pass over the covariance: the state `[pose, landmarks]` becomes
    /// `[new pose, landmarks, new landmarks]`. `cross` is the covariance of `new` with the
    /// current state (rows: new entries; its first three columns, the old pose's, are used
    /// only through `own`), `own` the covariance of `new`. Used by map joining, where the new
    /// entries are the local map composed with the old pose.
    pub(crate) fn replace_pose_and_append(
        &mut self,
        new: &DVector<f64>,
        cross: &CrossCovariance,
        own: &DMatrix<f64>,
    ) {
        debug_assert_eq!(self.robot_dim, 3);
        let n = self.dim();
        let k = new.len();
        debug_assert!(k >= 3 && (k - 3).is_multiple_of(2));
        debug_assert_eq!((cross.nrows(), cross.ncols()), (k, n));
        debug_assert_eq!(own.shape(), (k, k));
        let (landmarks, appended) = (n - 3, k - 3);
        let dim = n + appended;
        // Grown in place (the old landmarks keep their place and their entries): every entry
        // of the old pose's rows and columns and of the new rows and columns is written below.
        self.covariance.grow(dim);
        // The new pose and the new landmarks with the old landmarks.
        let new_rows = |index: usize| if index < 3 { index } else { n + index - 3 };
        for c in 3..n {
            for r in 0..k {
                self.covariance.set(new_rows(r), c, cross.entry(r, c));
            }
        }
        // The new entries among themselves (the lower triangle: `own` is symmetric).
        for c in 0..k {
            for r in c..k {
                self.covariance.set(new_rows(r), new_rows(c), own[(r, c)]);
            }
        }
        let mut mean = DVector::zeros(dim);
        mean.rows_mut(0, 3).copy_from(&new.rows(0, 3));
        mean.rows_mut(3, landmarks)
            .copy_from(&self.mean.rows(3, landmarks));
        mean.rows_mut(n, appended).copy_from(&new.rows(3, appended));
        self.mean = mean;
    }

    /// Re-expresses the whole state in another frame (`new_from_old`, rigid): the pose
    /// (entries 0..3, the only robot entries) is composed and every landmark transformed.
    /// The Jacobian is block-diagonal, a rotation of each `(x, y)` pair and one for the
    /// heading, so `J P Jᵀ` is applied in place, block by block of the lower triangle
    /// (`R_a P_ab R_bᵀ`): O(n²) time and no memory beyond the state's, where the product of
    /// dense `n × n` matrices costs O(n³) and three of them.
    pub(crate) fn transform_rigid(&mut self, new_from_old: Pose2) {
        debug_assert_eq!(self.robot_dim, 3);
        let (pose, _, _) = super::frames::compose_pose(new_from_old, self.pose());
        self.mean
            .rows_mut(0, 3)
            .copy_from_slice(&[pose.x_m, pose.y_m, pose.theta_rad]);
        for i in 0..self.landmark_count() {
            let (point, _, _) = super::frames::transform_point(new_from_old, self.landmark(i));
            let o = self.landmark_offset(i);
            self.mean.rows_mut(o, 2).copy_from_slice(&point);
        }
        let (sin, cos) = new_from_old.theta_rad.sin_cos();
        // The blocks (first entry, rotated): the pose's position, its heading, each landmark.
        let blocks: Vec<(usize, bool)> = [(0, true), (2, false)]
            .into_iter()
            .chain((0..self.landmark_count()).map(|i| (3 + 2 * i, true)))
            .collect();
        let rotation = Matrix2::new(cos, -sin, sin, cos);
        for (a, &(row, row_rotated)) in blocks.iter().enumerate() {
            for &(column, column_rotated) in &blocks[..=a] {
                let rows = if row_rotated { 2 } else { 1 };
                let columns = if column_rotated { 2 } else { 1 };
                let mut block = Matrix2::from_fn(|r, c| {
                    if r < rows && c < columns {
                        self.covariance.entry(row + r, column + c)
                    } else {
                        0.0
                    }
                });
                if row_rotated {
                    block = rotation * block;
                }
                if column_rotated {
                    block *= rotation.transpose();
                }
                for r in 0..rows {
                    // A diagonal block's upper entries are its lower ones' mirror.
                    let last_column = if row == column { r + 1 } else { columns };
                    for c in 0..last_column {
                        self.covariance.set(row + r, column + c, block[(r, c)]);
                    }
                }
            }
        }
    }

    /// Replaces the marginal of the pose (entries 0..3) by `pose` / `pose_covariance` and
    /// moves every other entry by its linear regression on the pose: the rest of the state is
    /// taken as unchanged given the pose. This is how information gathered about the pose
    /// elsewhere (a local map that measured its base) flows into the state:
    /// `x⁺ = x + G Δ`, `P⁺ = P + G (P_b⁺ − P_b) Gᵀ` with `G = P_{·b} P_b⁻¹`.
    ///
    /// # Errors
    /// [`EkfError::CovarianceNotPositiveDefinite`] when the pose's current covariance is not
    /// positive definite (nothing to regress on); the state is then unchanged.
    pub(crate) fn set_pose_marginal(
        &mut self,
        pose: Pose2,
        pose_covariance: &Matrix3<f64>,
    ) -> Result<(), EkfError> {
        let n = self.dim();
        let cholesky = self
            .pose_covariance()
            .cholesky()
            .ok_or(EkfError::CovarianceNotPositiveDefinite)?;
        // Gᵀ = P_b⁻¹ P_{b·} (3 × n).
        let g_t = cholesky.solve(&self.covariance.rows(0, 3));
        let mut delta = nalgebra::Vector3::new(
            pose.x_m - self.mean[0],
            pose.y_m - self.mean[1],
            pose.theta_rad - self.mean[2],
        );
        delta[2] = wrap_angle_rad(delta[2]);
        self.mean.gemv_tr(1.0, &g_t, &delta, 1.0);
        self.mean[THETA] = wrap_angle_rad(self.mean[THETA]);
        let change = pose_covariance - self.pose_covariance();
        let a = g_t.transpose() * change; // n × 3
        // P += A Gᵀ, symmetric: each entry of the lower triangle once.
        for i in 0..n {
            for j in 0..=i {
                let mut sum = a[(i, 0)] * g_t[(0, j)];
                for t in 1..3 {
                    sum += a[(i, t)] * g_t[(t, j)];
                }
                let value = self.covariance.entry(i, j) + sum;
                self.covariance.set(i, j, value);
            }
        }
        // The pose block is set exactly (rounding aside).
        for i in 0..3 {
            for j in 0..=i {
                self.covariance.set(i, j, pose_covariance[(i, j)]);
            }
        }
        Ok(())
    }

    /// Imposes that each pair `(duplicate, kept)` of landmarks is one point (the measurement
    /// `duplicate − kept = 0` with noise `sigma_m` per axis), then removes the duplicates.
    ///
    /// The update is computed only for the entries that stay, in the symmetric form
    /// `P⁺ = P − W Wᵀ` with `W = P Hᵀ L⁻ᵀ` (`L Lᵀ = S`): the directions a near-exact constraint
    /// makes nearly singular are those of the duplicates, which are removed, so the form
    /// needs no Joseph safeguard, and it costs one rank-`2p` product over the kept block
    /// instead of two over the whole covariance.
    ///
    /// # Errors
    /// [`EkfError::CovarianceNotPositiveDefinite`] when the pairs' joint innovation covariance
    /// is not positive definite; the state is then unchanged.
    pub fn merge_landmarks(
        &mut self,
        pairs: &[(usize, usize)],
        sigma_m: f64,
    ) -> Result<(), EkfError> {
        if pairs.is_empty() {
            return Ok(());
        }
        // Row or column `i` of H is `e_duplicate − e_kept` on coordinate `i % 2` of pair `i / 2`.
        let h_entries = |i: usize| {
            let (duplicate, kept) = pairs[i / 2];
            (
                self.landmark_offset(duplicate) + i % 2,
                self.landmark_offset(kept) + i % 2,
            )
        };
        let duplicates: Vec<usize> = pairs.iter().map(|&(duplicate, _)| duplicate).collect();
        let keep = self.entries_without(&duplicates);
        let (w, whitened_innovation) = fusion_factors(
            &self.covariance,
            |i| self.mean[i],
            h_entries,
            2 * pairs.len(),
            &keep,
            sigma_m,
        )?;
        let mut mean = self.mean.select_rows(keep.iter());
        mean.gemv(1.0, &w, &whitened_innovation, 1.0);
        mean[THETA] = wrap_angle_rad(mean[THETA]);
        self.covariance.gather(&keep);
        self.covariance.subtract_outer_product(&w);
        self.mean = mean;
        Ok(())
    }

    /// What [`EkfState::replace_pose_and_append`] followed by
    /// [`EkfState::merge_landmarks`] of the pairs `(new landmark, landmark)` would give (the
    /// first an index among the landmarks of `new`, the second one of this state's), without
    /// ever holding the new landmarks that are fused away: the pairs are read from the
    /// joined state in place ([`JoinedState`]), and the covariance grows only by the entries
    /// that stay. A map join's memory then peaks at the map it keeps, not at the map plus
    /// every landmark of the local map.
    ///
    /// # Errors
    /// [`EkfError::CovarianceNotPositiveDefinite`] when the pairs' joint innovation covariance
    /// is not positive definite; the state is then unchanged (nothing appended).
    pub(crate) fn replace_pose_append_and_fuse(
        &mut self,
        new: &DVector<f64>,
        cross: &CrossCovariance,
        own: &DMatrix<f64>,
        pairs: &[(usize, usize)],
        sigma_m: f64,
    ) -> Result<(), EkfError> {
        if pairs.is_empty() {
            self.replace_pose_and_append(new, cross, own);
            return Ok(());
        }
        let n = self.dim();
        let new_landmarks = (new.len() - 3) / 2;
        let mut fused = vec![false; new_landmarks];
        for &(duplicate, _) in pairs {
            fused[duplicate] = true;
        }
        // The new entries that stay: the pose, then the landmarks not fused away.
        let new_kept: Vec<usize> = (0..3)
            .chain(
                (0..new_landmarks)
                    .filter(|&j| !fused[j])
                    .flat_map(|j| [3 + 2 * j, 4 + 2 * j]),
            )
            .collect();
        let (mean, w) = {
            let joined = JoinedState::new(self, new, cross, own);
            // New landmark `j` is entry `n + 2 j` of the joined state.
            let h_entries = |i: usize| {
                let (duplicate, kept) = pairs[i / 2];
                (
                    n + 2 * duplicate + i % 2,
                    self.landmark_offset(kept) + i % 2,
                )
            };
            let keep: Vec<usize> = (0..n)
                .chain(new_kept[3..].iter().map(|&i| n + i - 3))
                .collect();
            let (w, whitened_innovation) = fusion_factors(
                &joined,
                |i| joined.mean_entry(i),
                h_entries,
                2 * pairs.len(),
                &keep,
                sigma_m,
            )?;
            let mut mean =
                DVector::from_iterator(keep.len(), keep.iter().map(|&i| joined.mean_entry(i)));
            mean.gemv(1.0, &w, &whitened_innovation, 1.0);
            mean[THETA] = wrap_angle_rad(mean[THETA]);
            (mean, w)
        };
        self.replace_pose_and_append(
            &new.select_rows(new_kept.iter()),
            &cross.select_rows(&new_kept),
            &own.select_rows(new_kept.iter())
                .select_columns(new_kept.iter()),
        );
        debug_assert_eq!(self.dim(), mean.len());
        self.mean = mean;
        self.covariance.subtract_outer_product(&w);
        Ok(())
    }

    /// The state entries (robot block, then landmark pairs, increasing) that remain once the
    /// listed landmarks are removed; indices out of range are ignored.
    fn entries_without(&self, landmarks: &[usize]) -> Vec<usize> {
        let count = self.landmark_count();
        let mut removed = vec![false; count];
        for &i in landmarks {
            if i < count {
                removed[i] = true;
            }
        }
        (0..self.robot_dim)
            .chain((0..count).filter(|&i| !removed[i]).flat_map(|i| {
                let o = self.robot_dim + 2 * i;
                [o, o + 1]
            }))
            .collect()
    }

    /// Removes the landmarks whose indices are listed (marginalising them out); the rest keep
    /// their order.
    pub fn remove_landmarks(&mut self, indices: &[usize]) {
        if indices.is_empty() {
            return;
        }
        let keep = self.entries_without(indices);
        self.mean = self.mean.select_rows(keep.iter());
        self.covariance.gather(&keep);
    }
}

/// What only the whole-matrix covariance does: the local maps' prediction and updates,
/// dense products of their small state.
impl EkfState {
    /// A state with the robot only, its covariance kept whole.
    ///
    /// # Panics
    /// If the robot has fewer than three entries or the covariance is not square of the same
    /// size (a programming error, not an input error).
    pub fn new(robot_mean: DVector<f64>, robot_covariance: DMatrix<f64>) -> EkfState {
        EkfState::with_covariance_store(robot_mean, robot_covariance)
    }

    /// [`EkfState::from_parts_with_store`], the covariance kept whole.
    #[cfg(test)]
    pub(crate) fn from_parts(
        mean: DVector<f64>,
        covariance: DMatrix<f64>,
        robot_dim: usize,
    ) -> EkfState {
        EkfState::from_parts_with_store(mean, covariance, robot_dim)
    }

    /// Replaces the robot block after a motion step: `robot_mean` is the predicted robot
    /// state, `f` the motion Jacobian with respect to the robot block and `q` the process
    /// noise already mapped into robot coordinates. Costs O(n).
    pub fn predict_robot(&mut self, robot_mean: &DVector<f64>, f: &DMatrix<f64>, q: &DMatrix<f64>) {
        let r = self.robot_dim;
        let n = self.dim();
        debug_assert_eq!(robot_mean.len(), r);
        self.mean.rows_mut(0, r).copy_from(robot_mean);
        self.mean[THETA] = wrap_angle_rad(self.mean[THETA]);
        let p_rr = self.covariance.view((0, 0), (r, r)).into_owned();
        let new_rr = f * p_rr * f.transpose() + q;
        self.covariance.view_mut((0, 0), (r, r)).copy_from(&new_rr);
        // The robot-landmark block becomes F P_rl, column by column; rows of F that are unit
        // rows (robot entries the motion leaves alone, such as a calibration) keep theirs.
        let moved_rows: Vec<usize> = (0..r)
            .filter(|&i| (0..r).any(|k| f[(i, k)] != if i == k { 1.0 } else { 0.0 }))
            .collect();
        let mut column = vec![0.0; moved_rows.len()];
        for j in r..n {
            for (value, &i) in column.iter_mut().zip(&moved_rows) {
                *value = (0..r).map(|k| f[(i, k)] * self.covariance[(k, j)]).sum();
            }
            for (&value, &i) in column.iter().zip(&moved_rows) {
                self.covariance[(i, j)] = value;
                self.covariance[(j, i)] = value;
            }
        }
        debug_assert_symmetric!(self.covariance);
    }

    /// Appends a landmark at `position_m`, initialised from the robot pose: `d_pose` is the
    /// Jacobian of the position with respect to the pose (the first three state entries),
    /// and `noise` the covariance the measurement adds (already mapped into the plane).
    /// Returns the new landmark's index.
    pub fn add_landmark(
        &mut self,
        position_m: [f64; 2],
        d_pose: &Matrix2x3<f64>,
        noise: &Matrix2<f64>,
    ) -> usize {
        let n = self.dim();
        let p_pose_all = self.covariance.rows(0, 3).into_owned();
        let cross = d_pose * &p_pose_all; // 2 × n
        let p_pp = self.pose_covariance();
        let own = d_pose * p_pp * d_pose.transpose() + noise;

        let mut covariance = DMatrix::zeros(n + 2, n + 2);
        covariance
            .view_mut((0, 0), (n, n))
            .copy_from(&self.covariance);
        covariance.view_mut((n, 0), (2, n)).copy_from(&cross);
        covariance
            .view_mut((0, n), (n, 2))
            .copy_from(&cross.transpose());
        covariance.view_mut((n, n), (2, 2)).copy_from(&own);
        self.covariance = covariance;
        self.mean = self.mean.clone().insert_rows(n, 2, 0.0);
        self.mean[n] = position_m[0];
        self.mean[n + 1] = position_m[1];
        debug_assert_symmetric!(self.covariance);
        self.landmark_count() - 1
    }

    /// Appends `mean.len()` entries to the robot block (before the landmarks), independent of
    /// everything else, with covariance `covariance`. Returns the offset of the first one.
    pub(crate) fn extend_robot(&mut self, mean: &DVector<f64>, covariance: &DMatrix<f64>) -> usize {
        let (n, r, e) = (self.dim(), self.robot_dim, mean.len());
        let landmarks = n - r;
        let mut full_mean = DVector::zeros(n + e);
        full_mean.rows_mut(0, r).copy_from(&self.mean.rows(0, r));
        full_mean.rows_mut(r, e).copy_from(mean);
        full_mean
            .rows_mut(r + e, landmarks)
            .copy_from(&self.mean.rows(r, landmarks));
        let mut full = DMatrix::zeros(n + e, n + e);
        let moved = |index: usize| if index < r { index } else { index + e };
        for c in 0..n {
            for row in 0..n {
                full[(moved(row), moved(c))] = self.covariance[(row, c)];
            }
        }
        full.view_mut((r, r), (e, e)).copy_from(covariance);
        self.mean = full_mean;
        self.covariance = full;
        self.robot_dim = r + e;
        r
    }

    /// Re-expresses three entries holding a pose (`offset..offset + 3`) through
    /// `new_from_old`: the mean is composed, the covariance rotated.
    pub(crate) fn transform_pose_entries(&mut self, offset: usize, new_from_old: Pose2) {
        let old = Pose2 {
            x_m: self.mean[offset],
            y_m: self.mean[offset + 1],
            theta_rad: self.mean[offset + 2],
        };
        let (new, _, rotation) = super::frames::compose_pose(new_from_old, old);
        self.mean
            .rows_mut(offset, 3)
            .copy_from_slice(&[new.x_m, new.y_m, new.theta_rad]);
        let n = self.dim();
        let rows = rotation * self.covariance.view((offset, 0), (3, n));
        self.covariance
            .view_mut((offset, 0), (3, n))
            .copy_from(&rows);
        let columns = self.covariance.view((0, offset), (n, 3)) * rotation.transpose();
        self.covariance
            .view_mut((0, offset), (n, 3))
            .copy_from(&columns);
        symmetrise(&mut self.covariance);
    }

    /// The innovation covariance `H P Hᵀ + R`.
    pub fn innovation_covariance(&self, h: &DMatrix<f64>, r: &DMatrix<f64>) -> DMatrix<f64> {
        h * &self.covariance * h.transpose() + r
    }

    /// Applies a linearised measurement: `innovation = z − h(x̂)` (angles already wrapped),
    /// `h` its Jacobian (m × n) and `r` its noise (m × m), with the Joseph form.
    ///
    /// # Errors
    /// [`EkfError::CovarianceNotPositiveDefinite`] when `H P Hᵀ + R` has no Cholesky
    /// factor (the state is left unchanged), [`EkfError::DimensionMismatch`] on sizes.
    pub fn update(
        &mut self,
        innovation: &DVector<f64>,
        h: &DMatrix<f64>,
        r: &DMatrix<f64>,
    ) -> Result<(), EkfError> {
        let m = innovation.len();
        let n = self.dim();
        if h.shape() != (m, n) || r.shape() != (m, m) {
            return Err(EkfError::DimensionMismatch {
                rows: m,
                state_dim: n,
            });
        }
        let nonzeros: Vec<(usize, usize, f64)> = (0..m)
            .flat_map(|row| (0..n).map(move |col| (row, col)))
            .filter_map(|(row, col)| {
                let value = h[(row, col)];
                (value != 0.0).then_some((row, col, value))
            })
            .collect();
        self.update_sparse(innovation, &nonzeros, r)
    }

    /// [`Self::update`] with the Jacobian given by its non-zero entries `(row, column,
    /// value)`, so no dense `m × n` Jacobian is formed. Entries may come in any order and
    /// repeated ones add up; in row-major order, columns ascending, the result is
    /// [`Self::update`]'s to the bit.
    ///
    /// # Errors
    /// As [`Self::update`]; an entry outside `m × n` is a dimension mismatch.
    pub fn update_sparse(
        &mut self,
        innovation: &DVector<f64>,
        nonzeros: &[(usize, usize, f64)],
        r: &DMatrix<f64>,
    ) -> Result<(), EkfError> {
        let m = innovation.len();
        let n = self.dim();
        if r.shape() != (m, m) || nonzeros.iter().any(|&(row, col, _)| row >= m || col >= n) {
            return Err(EkfError::DimensionMismatch {
                rows: m,
                state_dim: n,
            });
        }
        if m == 0 {
            return Ok(());
        }
        // Textbook names: p_ht = P Hᵀ, s = H P Hᵀ + R, k_gain = P Hᵀ S⁻¹. H is sparse (a
        // measurement touches a few state entries), so P Hᵀ and H P Hᵀ are summed over its
        // non-zeros: O(n · nnz) instead of O(n² m).
        let mut p_ht = DMatrix::zeros(n, m);
        for &(row, col, value) in nonzeros {
            p_ht.column_mut(row)
                .axpy(value, &self.covariance.column(col), 1.0);
        }
        let mut s = r.clone();
        for &(row, col, value) in nonzeros {
            for other in 0..m {
                s[(row, other)] += value * p_ht[(col, other)];
            }
        }
        s = (&s + s.transpose()) * 0.5;
        let cholesky = s
            .clone()
            .cholesky()
            .ok_or(EkfError::CovarianceNotPositiveDefinite)?;
        let k_gain = cholesky.solve(&p_ht.transpose()).transpose();
        self.mean += &k_gain * innovation;
        self.mean[THETA] = wrap_angle_rad(self.mean[THETA]);
        // Joseph form, P⁺ = P − K (P Hᵀ)ᵀ − (P Hᵀ) Kᵀ + K S Kᵀ, rewritten as
        // P − K (P Hᵀ)ᵀ + (K S − P Hᵀ) Kᵀ so it takes two in-place products.
        let gain_residual = &k_gain * &s - &p_ht;
        self.covariance.gemm(-1.0, &k_gain, &p_ht.transpose(), 1.0);
        self.covariance
            .gemm(1.0, &gain_residual, &k_gain.transpose(), 1.0);
        symmetrise(&mut self.covariance);
        debug_assert_symmetric!(self.covariance);
        Ok(())
    }
}

/// The factors of fusing `m` measurements `x_a − x_b = 0` (noise `sigma_m` per row, row `i`
/// of `H` being `e_a − e_b` for `(a, b) = h_entries(i)`) into a state with covariance `p`
/// and mean `mean`: `W = P Hᵀ L⁻ᵀ` over the rows `keep` and the whitened innovation
/// `L⁻¹ ν`, where `L Lᵀ = S = H P Hᵀ + R`. The update is then `x⁺ = x + W L⁻¹ ν` and
/// `P⁺ = P − W Wᵀ` over the kept entries.
///
/// `W` is formed in one buffer, `P Hᵀ` first and then the triangular solve `W Lᵀ = P Hᵀ`
/// column by column, and only for the kept rows, so an update's working memory is `W` (kept ×
/// `m`) and one band of `Wᵀ` ([`CovarianceStore::subtract_outer_product`]).
fn fusion_factors(
    p: &(impl CovarianceEntries + ?Sized),
    mean: impl Fn(usize) -> f64,
    h_entries: impl Fn(usize) -> (usize, usize),
    m: usize,
    keep: &[usize],
    sigma_m: f64,
) -> Result<(DMatrix<f64>, DVector<f64>), EkfError> {
    // S = H P Hᵀ + R and the innovation, from the covariance's entries.
    let mut s = DMatrix::identity(m, m) * sigma_m.powi(2);
    let mut innovation = DVector::zeros(m);
    for row in 0..m {
        let (ra, rb) = h_entries(row);
        innovation[row] = mean(rb) - mean(ra);
        for col in 0..m {
            let (ca, cb) = h_entries(col);
            s[(row, col)] +=
                (p.entry(ra, ca) - p.entry(ra, cb)) - (p.entry(rb, ca) - p.entry(rb, cb));
        }
    }
    s = (&s + s.transpose()) * 0.5;
    let cholesky = s
        .cholesky()
        .ok_or(EkfError::CovarianceNotPositiveDefinite)?;
    let l = cholesky.l();
    let rows = keep.len();
    let mut w = DMatrix::zeros(rows, m);
    for col in 0..m {
        let (a, b) = h_entries(col);
        for (to, &from) in keep.iter().enumerate() {
            w[(to, col)] = p.entry(from, a) - p.entry(from, b);
        }
    }
    let data = w.as_mut_slice();
    for col in 0..m {
        let (solved, rest) = data.split_at_mut(col * rows);
        let target = &mut rest[..rows];
        for k in 0..col {
            let factor = l[(col, k)];
            for (t, &x) in target.iter_mut().zip(&solved[k * rows..(k + 1) * rows]) {
                *t -= factor * x;
            }
        }
        let diagonal = l[(col, col)];
        target.iter_mut().for_each(|t| *t /= diagonal);
    }
    let whitened_innovation = l
        .solve_lower_triangular(&innovation)
        .ok_or(EkfError::CovarianceNotPositiveDefinite)?;
    Ok((w, whitened_innovation))
}

/// Replaces a square matrix by the mean of itself and its transpose, tile by tile so both
/// halves are read from cache.
fn symmetrise(matrix: &mut DMatrix<f64>) {
    const TILE: usize = 32;
    let n = matrix.nrows();
    debug_assert_eq!(n, matrix.ncols());
    for tile_col in (0..n).step_by(TILE) {
        for tile_row in (tile_col..n).step_by(TILE) {
            for col in tile_col..(tile_col + TILE).min(n) {
                for row in tile_row.max(col + 1)..(tile_row + TILE).min(n) {
                    let mean = 0.5 * (matrix[(row, col)] + matrix[(col, row)]);
                    matrix[(row, col)] = mean;
                    matrix[(col, row)] = mean;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::packed_covariance::PackedCovariance;
    use super::*;

    fn robot_only() -> EkfState {
        EkfState::new(
            DVector::from_vec(vec![1.0, 2.0, 0.5]),
            DMatrix::from_diagonal(&DVector::from_vec(vec![0.1, 0.2, 0.01])),
        )
    }

    #[test]
    fn landmark_added_and_removed() {
        let mut state = robot_only();
        let d_pose = Matrix2x3::new(1.0, 0.0, -1.0, 0.0, 1.0, 2.0);
        let a = state.add_landmark([3.0, 4.0], &d_pose, &Matrix2::identity());
        let b = state.add_landmark([5.0, 6.0], &d_pose, &Matrix2::identity());
        assert_eq!((a, b, state.landmark_count()), (0, 1, 2));
        assert_eq!(state.landmark(1), [5.0, 6.0]);
        // Fully correlated with the pose through d_pose.
        let expected =
            d_pose * robot_only().pose_covariance() * d_pose.transpose() + Matrix2::identity();
        assert!((state.landmark_covariance(0) - expected).amax() < 1e-12);
        state.remove_landmarks(&[0]);
        assert_eq!(state.landmark_count(), 1);
        assert_eq!(state.landmark(0), [5.0, 6.0]);
        assert_eq!(state.covariance().shape(), (5, 5));
    }

    #[test]
    fn update_shrinks_covariance_and_moves_mean() {
        let mut state = robot_only();
        // Observe x directly: z = 1.5 with variance 0.1.
        let h = DMatrix::from_row_slice(1, 3, &[1.0, 0.0, 0.0]);
        let r = DMatrix::from_element(1, 1, 0.1);
        state
            .update(&DVector::from_element(1, 0.5), &h, &r)
            .unwrap();
        assert!((state.pose().x_m - 1.25).abs() < 1e-12);
        assert!((state.covariance()[(0, 0)] - 0.05).abs() < 1e-12);
    }

    #[test]
    fn singular_innovation_is_an_error() {
        let mut state = EkfState::new(DVector::zeros(3), DMatrix::zeros(3, 3));
        let h = DMatrix::from_row_slice(1, 3, &[1.0, 0.0, 0.0]);
        let r = DMatrix::zeros(1, 1);
        let before = state.clone();
        let result = state.update(&DVector::from_element(1, 1.0), &h, &r);
        assert_eq!(result, Err(EkfError::CovarianceNotPositiveDefinite));
        assert_eq!(state, before);
    }

    #[test]
    fn prediction_propagates_cross_covariance() {
        let mut state = robot_only();
        let d_pose = Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        state.add_landmark([3.0, 4.0], &d_pose, &Matrix2::identity());
        let f = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, -1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0]);
        let q = DMatrix::identity(3, 3) * 0.01;
        let before = state.covariance().clone();
        state.predict_robot(&DVector::from_vec(vec![1.5, 2.5, 0.6]), &f, &q);
        let cross = state.covariance().view((0, 3), (3, 2)).into_owned();
        let expected = &f * before.view((0, 3), (3, 2));
        assert!((cross - expected).amax() < 1e-12);
        assert_eq!(state.landmark(0), [3.0, 4.0]);
    }

    #[test]
    fn prediction_equals_the_dense_product_when_some_robot_entries_stay() {
        // Pose plus two calibration entries the motion leaves alone, and three landmarks.
        let n = 11;
        let a = DMatrix::from_fn(n, n, |r, c| ((r * 5 + c * 3) % 7) as f64 * 0.1 - 0.3);
        let covariance = &a * a.transpose() + DMatrix::identity(n, n) * 0.2;
        let mut state = EkfState::from_parts(DVector::zeros(n), covariance.clone(), 5);
        let mut f = DMatrix::identity(5, 5);
        for (row, values) in [[0.9, 0.1, -0.7, 0.3, 0.2], [0.0, 1.0, 0.4, -0.1, 0.5]]
            .iter()
            .enumerate()
        {
            for (col, &value) in values.iter().enumerate() {
                f[(row, col)] = value;
            }
        }
        let q = DMatrix::from_diagonal(&DVector::from_vec(vec![0.01, 0.02, 0.003, 1e-4, 1e-5]));
        state.predict_robot(&DVector::from_vec(vec![1.0, 2.0, 0.3, 1.01, 0.02]), &f, &q);

        let mut f_whole = DMatrix::identity(n, n);
        f_whole.view_mut((0, 0), (5, 5)).copy_from(&f);
        let mut q_whole = DMatrix::zeros(n, n);
        q_whole.view_mut((0, 0), (5, 5)).copy_from(&q);
        let expected = &f_whole * covariance * f_whole.transpose() + q_whole;
        assert!((state.covariance() - &expected).amax() < 1e-12);
        // The robot-landmark blocks mirror each other exactly.
        let covariance = state.covariance();
        let upper = covariance.view((0, 5), (5, n - 5)).into_owned();
        let lower = covariance.view((5, 0), (n - 5, 5)).transpose();
        assert_eq!(upper, lower);
    }

    /// A robot and four landmarks with a dense, well-conditioned covariance.
    fn correlated_state() -> EkfState {
        let n = 11;
        let a = DMatrix::from_fn(n, n, |r, c| ((r * 7 + c * 3) % 11) as f64 * 0.05 - 0.2);
        let covariance = &a * a.transpose() + DMatrix::identity(n, n) * 0.3;
        let mean = DVector::from_fn(n, |r, _| r as f64 * 0.7 - 2.0);
        EkfState::from_parts(mean, covariance, 3)
    }

    #[test]
    fn sparse_update_is_the_textbook_update() {
        let before = correlated_state();
        let n = before.dim();
        let nonzeros = [
            (0, 0, -0.8),
            (0, 2, 0.3),
            (0, 5, 0.8),
            (1, 1, -1.1),
            (1, 6, 1.1),
        ];
        let innovation = DVector::from_column_slice(&[0.2, -0.1]);
        let r = DMatrix::identity(2, 2) * 0.04;
        let mut sparse = before.clone();
        sparse.update_sparse(&innovation, &nonzeros, &r).unwrap();

        // K = P Hᵀ S⁻¹, x⁺ = x + K ν, P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ, all dense.
        let mut h = DMatrix::zeros(2, n);
        for &(row, col, value) in &nonzeros {
            h[(row, col)] = value;
        }
        let p = before.covariance();
        let s = &h * p * h.transpose() + &r;
        let k = p * h.transpose() * s.try_inverse().unwrap();
        let mut mean = before.mean() + &k * &innovation;
        mean[THETA] = wrap_angle_rad(mean[THETA]);
        let i_kh = DMatrix::identity(n, n) - &k * &h;
        let covariance = &i_kh * p * i_kh.transpose() + &k * &r * k.transpose();
        assert!((sparse.mean() - mean).amax() < 1e-12);
        assert!((sparse.covariance() - covariance).amax() < 1e-12);

        // The same entries in another order, one of them split in two, give the same update.
        let shuffled = [
            (1, 6, 1.1),
            (0, 5, 0.8),
            (0, 0, -0.5),
            (1, 1, -1.1),
            (0, 2, 0.3),
            (0, 0, -0.3),
        ];
        let mut reordered = before.clone();
        reordered.update_sparse(&innovation, &shuffled, &r).unwrap();
        assert!((reordered.covariance() - sparse.covariance()).amax() < 1e-12);

        let outside = [(0, n, 1.0)];
        assert!(matches!(
            sparse.update_sparse(&innovation, &outside, &r),
            Err(EkfError::DimensionMismatch { .. })
        ));
    }

    #[test]
    fn merged_landmarks_match_the_constraint_update_then_removal() {
        let pairs = [(3, 0), (2, 1)];
        let sigma_m = 1e-3;
        let mut merged = correlated_state();
        merged.merge_landmarks(&pairs, sigma_m).unwrap();

        // Reference: the same constraint through the general update, then removal.
        let mut reference = correlated_state();
        let n = reference.dim();
        let mut h = DMatrix::zeros(4, n);
        let mut innovation = DVector::zeros(4);
        for (row, &(duplicate, kept)) in pairs.iter().enumerate() {
            let (a, b) = (reference.landmark(duplicate), reference.landmark(kept));
            for d in 0..2 {
                h[(2 * row + d, reference.landmark_offset(duplicate) + d)] = 1.0;
                h[(2 * row + d, reference.landmark_offset(kept) + d)] = -1.0;
                innovation[2 * row + d] = b[d] - a[d];
            }
        }
        let r = DMatrix::identity(4, 4) * sigma_m.powi(2);
        reference.update(&innovation, &h, &r).unwrap();
        reference.remove_landmarks(&[2, 3]);

        assert_eq!(merged.landmark_count(), 2);
        assert!((merged.mean() - reference.mean()).amax() < 1e-9);
        assert!((merged.covariance() - reference.covariance()).amax() < 1e-9);
        // The kept landmark now sits between its two records.
        let before = correlated_state();
        let fused = merged.landmark(0);
        let (x0, x3) = (before.landmark(0)[0], before.landmark(3)[0]);
        assert!(fused[0] > x0.min(x3) && fused[0] < x0.max(x3));
    }

    #[test]
    fn pose_replaced_and_landmarks_appended_in_place() {
        let mut state = correlated_state();
        let before = state.clone();
        let n = before.dim();
        let new = DVector::from_vec(vec![10.0, 11.0, 0.2, 12.0, 13.0]);
        let cross = CrossCovariance::new(
            DMatrix::from_fn(5, 3, |r, c| 0.1 * (r + c) as f64),
            DMatrix::from_fn(3, n, |r, c| 0.01 * (r + 2 * c) as f64),
        );
        let own = DMatrix::from_fn(5, 5, |r, c| if r == c { 2.0 } else { 0.1 });
        state.replace_pose_and_append(&new, &cross, &own);
        assert_eq!(state.landmark_count(), 5);
        assert_eq!(
            state.pose(),
            Pose2 {
                x_m: 10.0,
                y_m: 11.0,
                theta_rad: 0.2
            }
        );
        assert_eq!(state.landmark(4), [12.0, 13.0]);
        assert_eq!(state.landmark(1), before.landmark(1));
        let p = state.covariance();
        // Old landmarks untouched, new pose with new landmark from `own`, new pose with an
        // old landmark from `cross`.
        assert_eq!(p[(5, 6)], before.covariance()[(5, 6)]);
        assert_eq!(p[(0, n)], own[(0, 3)]);
        assert_eq!(p[(1, 4)], cross.entry(1, 4));
        assert_eq!(p[(4, 1)], cross.entry(1, 4));
        assert_eq!(p[(n + 1, 3)], cross.entry(4, 3));
        assert_eq!(p[(n + 1, n + 1)], 2.0);
    }

    #[test]
    fn a_rigid_transform_in_place_is_the_dense_jacobian_product() {
        let mut state = correlated_state();
        let before = state.clone();
        let new_from_old = Pose2 {
            x_m: 3.0,
            y_m: -2.0,
            theta_rad: 2.4,
        };
        state.transform_rigid(new_from_old);
        let n = before.dim();
        let mut jacobian = DMatrix::zeros(n, n);
        let (pose, _, d_pose) = super::super::frames::compose_pose(new_from_old, before.pose());
        jacobian.view_mut((0, 0), (3, 3)).copy_from(&d_pose);
        assert_eq!(state.pose(), pose);
        for i in 0..before.landmark_count() {
            let (point, _, d_point) =
                super::super::frames::transform_point(new_from_old, before.landmark(i));
            let o = before.landmark_offset(i);
            jacobian.view_mut((o, o), (2, 2)).copy_from(&d_point);
            assert_eq!(state.landmark(i), point);
        }
        let dense = &jacobian * before.covariance() * jacobian.transpose();
        let scale = dense.amax();
        assert!(
            (state.covariance() - &dense).amax() <= 1e-14 * scale,
            "{}",
            state.covariance() - dense
        );
        assert_eq!(state.covariance(), &state.covariance().transpose());
    }

    #[test]
    fn joining_with_fusion_gives_the_append_then_the_merge_to_the_bit() {
        // Four old landmarks; a new pose and three new landmarks, the first and the third
        // fused into old landmarks 2 and 0.
        let state = correlated_state();
        joined_and_merged_agree(state, 9, &[(0, 2), (2, 0)]);
        // A map large enough for the blocked product and its bands: 80 landmarks, 12 new,
        // 5 of them fused.
        let n = 163;
        let a = DMatrix::from_fn(n, n, |r, c| ((r * 7 + c * 3) % 11) as f64 * 0.01 - 0.05);
        let covariance = &a * a.transpose() + DMatrix::identity(n, n) * 0.3;
        let mean = DVector::from_fn(n, |r, _| r as f64 * 0.1 - 2.0);
        let large = EkfState::from_parts(mean, covariance, 3);
        joined_and_merged_agree(large, 27, &[(0, 70), (3, 5), (4, 41), (8, 0), (11, 79)]);
    }

    /// `k` new entries (a pose, then landmarks) to join to a state of `n` entries: their
    /// mean, their covariance with the state and their own.
    fn join_inputs(n: usize, k: usize) -> (DVector<f64>, CrossCovariance, DMatrix<f64>) {
        let b = DMatrix::from_fn(k, k, |r, c| ((r * 5 + c * 2) % 7) as f64 * 0.04 - 0.1);
        let own = &b * b.transpose() + DMatrix::identity(k, k) * 0.5;
        let cross = CrossCovariance::new(
            DMatrix::from_fn(k, 3, |r, c| 0.1 * ((r * 3 + c) % 5) as f64),
            DMatrix::from_fn(3, n, |r, c| 0.02 * ((r + 2 * c) % 7) as f64),
        );
        let new = DVector::from_fn(k, |r, _| 1.0 + 0.3 * r as f64);
        (new, cross, own)
    }

    /// Joins `state` with `k` new entries (a pose, then landmarks) and fuses `pairs`, both
    /// ways, and checks they agree to the bit.
    fn joined_and_merged_agree(state: EkfState, k: usize, pairs: &[(usize, usize)]) {
        let (new, cross, own) = join_inputs(state.dim(), k);
        let sigma_m = 1e-3;
        let mut reference = state.clone();
        reference.replace_pose_and_append(&new, &cross, &own);
        let old = state.landmark_count();
        let merged: Vec<(usize, usize)> = pairs.iter().map(|&(new, o)| (old + new, o)).collect();
        reference.merge_landmarks(&merged, sigma_m).expect("merge");
        let mut joined = state.clone();
        joined
            .replace_pose_append_and_fuse(&new, &cross, &own, pairs, sigma_m)
            .expect("join");
        assert_eq!(joined.landmark_count(), old + (k - 3) / 2 - pairs.len());
        assert_eq!(joined.mean(), reference.mean());
        assert_eq!(joined.covariance(), reference.covariance());
        // Without pairs it is the append alone.
        let mut appended = state.clone();
        appended
            .replace_pose_append_and_fuse(&new, &cross, &own, &[], sigma_m)
            .expect("append");
        let mut plain = state;
        plain.replace_pose_and_append(&new, &cross, &own);
        assert_eq!(appended, plain);
    }

    #[test]
    fn a_state_as_one_triangle_follows_the_whole_matrix_through_joins() {
        let whole = correlated_state();
        let mut packed: EkfState<PackedCovariance> = EkfState::from_parts_with_store(
            whole.mean().clone(),
            whole.covariance().clone(),
            whole.robot_dim(),
        );
        let mut whole = whole;
        let agree = |packed: &EkfState<PackedCovariance>, whole: &EkfState| {
            assert_eq!(packed.dim(), whole.dim());
            assert!((packed.mean() - whole.mean()).amax() < 1e-12);
            let difference = packed.covariance().to_dense() - whole.covariance();
            assert!(difference.amax() < 1e-12, "{difference}");
        };
        let new_from_old = Pose2 {
            x_m: 1.5,
            y_m: -0.5,
            theta_rad: -0.7,
        };
        packed.transform_rigid(new_from_old);
        whole.transform_rigid(new_from_old);
        agree(&packed, &whole);
        let pose_covariance = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.05, 0.04, 0.01));
        let pose = Pose2 {
            x_m: 0.3,
            ..whole.pose()
        };
        packed.set_pose_marginal(pose, &pose_covariance).unwrap();
        whole.set_pose_marginal(pose, &pose_covariance).unwrap();
        agree(&packed, &whole);
        // Two joins of a new pose and three new landmarks: two of them fused into old ones,
        // then none.
        for pairs in [&[(0, 2), (2, 0)][..], &[]] {
            let (new, cross, own) = join_inputs(whole.dim(), 9);
            packed
                .replace_pose_append_and_fuse(&new, &cross, &own, pairs, 1e-3)
                .unwrap();
            whole
                .replace_pose_append_and_fuse(&new, &cross, &own, pairs, 1e-3)
                .unwrap();
            agree(&packed, &whole);
        }
        packed.merge_landmarks(&[(4, 1)], 1e-3).unwrap();
        whole.merge_landmarks(&[(4, 1)], 1e-3).unwrap();
        agree(&packed, &whole);
        packed.remove_landmarks(&[0, 2]);
        whole.remove_landmarks(&[0, 2]);
        agree(&packed, &whole);
    }

    #[test]
    fn pose_marginal_carries_a_pose_measurement_to_the_whole_state() {
        // Measuring the pose directly (linear) must give the same state as first updating the
        // pose's marginal alone and then regressing the rest on it.
        let mut reference = correlated_state();
        let h = DMatrix::from_fn(3, reference.dim(), |r, c| if r == c { 1.0 } else { 0.0 });
        let r = DMatrix::from_diagonal(&DVector::from_vec(vec![0.2, 0.3, 0.05]));
        let innovation = DVector::from_vec(vec![0.4, -0.3, 0.1]);
        let pose = reference.pose();
        let mut pose_only = EkfState::new(
            DVector::from_row_slice(&[pose.x_m, pose.y_m, pose.theta_rad]),
            DMatrix::from_column_slice(3, 3, reference.pose_covariance().as_slice()),
        );
        pose_only
            .update(&innovation, &DMatrix::identity(3, 3), &r)
            .unwrap();
        let mut regressed = reference.clone();
        regressed
            .set_pose_marginal(pose_only.pose(), &pose_only.pose_covariance())
            .unwrap();
        reference.update(&innovation, &h, &r).unwrap();
        assert!((regressed.mean() - reference.mean()).amax() < 1e-9);
        assert!((regressed.covariance() - reference.covariance()).amax() < 1e-9);
        // An exactly known pose has nothing to regress on.
        let mut exact = EkfState::new(DVector::zeros(3), DMatrix::zeros(3, 3));
        assert_eq!(
            exact.set_pose_marginal(
                Pose2 {
                    x_m: 1.0,
                    ..Pose2::IDENTITY
                },
                &Matrix3::identity()
            ),
            Err(EkfError::CovarianceNotPositiveDefinite)
        );
    }
}
