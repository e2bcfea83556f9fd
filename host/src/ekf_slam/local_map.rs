//! One local map: an EKF over the robot and the landmarks seen since the map was started,
//! expressed in the map's base frame (the robot pose when it started).
//!
//! A local map starts with the robot at the origin of its base frame with zero uncertainty,
//! so it is statistically independent of every earlier local map (Tardós et al., "Robust
//! mapping and localization in indoor environments using sonar data", IJRR 2002); its size is
//! bounded, so each of its steps costs the same however large the global map grows.
//!
//! A measurement made in the map frame (a GPS fix) depends on where the base lies in the
//! map. For those, the local map also estimates its base: three entries appended to the robot
//! block, started from the global map's estimate of the base and untouched by motion and by
//! landmark observations. The local map then stays independent of the global map *given the
//! base*, and at the join what it learnt about the base flows back into the global map
//! ([`super::GlobalMap::join`]; Piniés and Tardós, "Large-scale SLAM building conditionally
//! independent local maps", IEEE T-RO 2008).

use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Vector2};

use super::ekf_state::{EkfError, EkfState};
use super::frames::transform_point;
use super::jcbb::{JacobianBlock, PairingCandidate, chi_square_quantile, jcbb};
use super::landmark_info::LandmarkInfo;
use super::motion_model::MotionModel;
use super::options::AssociationOptions;
use super::range_bearing::{LandmarkObservation, PredictedObservation, RangeBearingModel};
use crate::geometry::Pose2;

/// What one batch of observations did to the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ObservationReport {
    /// Observations paired with a landmark and used in the update.
    pub associated: usize,
    /// Observations that started a landmark.
    pub new_landmarks: usize,
    /// Observations dropped as ambiguous (close to a landmark but not jointly compatible).
    pub ambiguous: usize,
}

/// An EKF local map. See the [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct LocalMap {
    state: EkfState,
    info: Vec<LandmarkInfo>,
    /// Offset in the robot block of the base's pose in the map frame, when estimated.
    base_offset: Option<usize>,
}

/// A local map taken apart for joining.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LocalMapParts {
    /// The filter state in the base frame.
    pub state: EkfState,
    /// Bookkeeping of each landmark.
    pub info: Vec<LandmarkInfo>,
    /// Offset of the base's pose in the robot block, when estimated.
    pub base_offset: Option<usize>,
}

/// Squared Mahalanobis distance of a range-bearing pairing with landmark entries at
/// `landmark_offset`, from the pose and landmark blocks of `covariance` (fixed-size, no
/// allocation); `None` when the innovation covariance is singular.
fn pairing_distance2(
    covariance: &DMatrix<f64>,
    predicted: &PredictedObservation,
    landmark_offset: usize,
    innovation: &Vector2<f64>,
    noise: &Matrix2<f64>,
) -> Option<f64> {
    let p_pp = covariance.fixed_view::<3, 3>(0, 0);
    let p_pl = covariance.fixed_view::<3, 2>(0, landmark_offset);
    let p_ll = covariance.fixed_view::<2, 2>(landmark_offset, landmark_offset);
    let (h_p, h_l) = (&predicted.d_pose, &predicted.d_landmark);
    let cross = h_p * p_pl * h_l.transpose();
    let s = h_p * p_pp * h_p.transpose()
        + cross
        + cross.transpose()
        + h_l * p_ll * h_l.transpose()
        + noise;
    Some((innovation.transpose() * s.try_inverse()? * innovation)[0])
}

impl LocalMap {
    /// A local map whose robot block starts as `robot_mean` / `robot_covariance`, the pose
    /// entries at the origin of the base frame.
    pub fn new(robot_mean: DVector<f64>, robot_covariance: DMatrix<f64>) -> LocalMap {
        LocalMap {
            state: EkfState::new(robot_mean, robot_covariance),
            info: Vec::new(),
            base_offset: None,
        }
    }

    /// The filter state in the base frame.
    pub fn state(&self) -> &EkfState {
        &self.state
    }

    /// Bookkeeping of each landmark, in state order.
    pub fn landmark_info(&self) -> &[LandmarkInfo] {
        &self.info
    }

    /// Number of landmarks.
    pub fn landmark_count(&self) -> usize {
        self.info.len()
    }

    /// The base's pose in the map frame and its covariance, when the local map estimates it
    /// (see [`Self::add_base`]).
    pub fn base_in_map(&self) -> Option<(Pose2, Matrix3<f64>)> {
        let offset = self.base_offset?;
        let mean = self.state.mean();
        let covariance = self
            .state
            .covariance()
            .fixed_view::<3, 3>(offset, offset)
            .into_owned();
        Some((
            Pose2 {
                x_m: mean[offset],
                y_m: mean[offset + 1],
                theta_rad: mean[offset + 2],
            },
            covariance,
        ))
    }

    /// Offset in the robot block of the base's estimate, when there is one.
    pub fn base_offset(&self) -> Option<usize> {
        self.base_offset
    }

    /// Starts estimating the base's pose in the map frame from `base_in_map` with
    /// `covariance` (the global map's marginal of it). Does nothing if already estimated.
    pub fn add_base(&mut self, base_in_map: Pose2, covariance: &Matrix3<f64>) {
        if self.base_offset.is_some() {
            return;
        }
        let offset = self.state.extend_robot(
            &DVector::from_row_slice(&[base_in_map.x_m, base_in_map.y_m, base_in_map.theta_rad]),
            &DMatrix::from_column_slice(3, 3, covariance.as_slice()),
        );
        self.base_offset = Some(offset);
    }

    /// Re-expresses the estimate of the base, if any, in another map frame.
    pub fn transform_base(&mut self, new_from_old: Pose2) {
        if let Some(offset) = self.base_offset {
            self.state.transform_pose_entries(offset, new_from_old);
        }
    }

    /// Moves the robot over `dt_s` seconds (the base, if estimated, stays).
    pub fn predict<M: MotionModel>(&mut self, model: &M, input: &M::Input, dt_s: f64) {
        if dt_s <= 0.0 || !dt_s.is_finite() {
            return;
        }
        let robot = self.state.robot();
        let Some(offset) = self.base_offset else {
            let prediction = model.predict(&robot, input, dt_s);
            self.state
                .predict_robot(&prediction.robot, &prediction.f, &prediction.q);
            return;
        };
        let prediction = model.predict(&robot.rows(0, offset).into_owned(), input, dt_s);
        let r = robot.len();
        let mut mean = robot;
        mean.rows_mut(0, offset).copy_from(&prediction.robot);
        let mut f = DMatrix::identity(r, r);
        f.view_mut((0, 0), (offset, offset))
            .copy_from(&prediction.f);
        let mut q = DMatrix::zeros(r, r);
        q.view_mut((0, 0), (offset, offset))
            .copy_from(&prediction.q);
        self.state.predict_robot(&mean, &f, &q);
    }

    /// Pairs one scan's observations with the map (individual gate, then JCBB), updates the
    /// filter with the pairs, and starts landmarks for clearly new observations.
    ///
    /// # Errors
    /// [`EkfError`] when the update's innovation covariance is not positive definite; the
    /// map is then left as it was before the update.
    pub fn observe(
        &mut self,
        observations: &[LandmarkObservation],
        sensor: &RangeBearingModel,
        options: &AssociationOptions,
    ) -> Result<ObservationReport, EkfError> {
        let pose = self.state.pose();
        let noise = sensor.noise();
        let gate = chi_square_quantile(2, options.individual_confidence);
        let covariance = self.state.covariance();
        let mut candidates: Vec<Vec<PairingCandidate>> = Vec::with_capacity(observations.len());
        let mut nearest_distance2 = vec![f64::INFINITY; observations.len()];
        for (i, observation) in observations.iter().enumerate() {
            let mut list = Vec::new();
            for (j, info) in self.info.iter().enumerate() {
                let landmark = self.state.landmark(j);
                let Some(predicted) = sensor.predict(pose, landmark) else {
                    continue;
                };
                // Cheap rejection before the covariance products: more than 10 m off in range.
                if (observation.range_m - predicted.z[0]).abs() > 10.0 {
                    continue;
                }
                let innovation = RangeBearingModel::innovation(observation, &predicted);
                // The distance with fixed-size blocks first; the candidate (with its
                // allocated Jacobian blocks) only for pairings that pass.
                let Some(distance2) = pairing_distance2(
                    covariance,
                    &predicted,
                    self.state.landmark_offset(j),
                    &innovation,
                    &noise,
                ) else {
                    continue;
                };
                nearest_distance2[i] = nearest_distance2[i].min(distance2);
                let diameter_ok = info.diameter_compatible(
                    observation.diameter_m,
                    options.diameter_tolerance_m,
                    options.diameter_tolerance_fraction,
                );
                if distance2 >= gate || !diameter_ok {
                    continue;
                }
                let jacobian = vec![
                    JacobianBlock {
                        column: 0,
                        matrix: DMatrix::from_column_slice(2, 3, predicted.d_pose.as_slice()),
                    },
                    JacobianBlock {
                        column: self.state.landmark_offset(j),
                        matrix: DMatrix::from_column_slice(2, 2, predicted.d_landmark.as_slice()),
                    },
                ];
                if let Some(candidate) =
                    PairingCandidate::new(j, innovation, jacobian, covariance, &noise)
                {
                    list.push(candidate);
                }
            }
            list.sort_by(|a, b| a.distance2.total_cmp(&b.distance2));
            candidates.push(list);
        }
        let noises = vec![noise; observations.len()];
        let pairing = jcbb(&candidates, &noises, covariance, &options.jcbb);

        // One stacked update with every pair.
        let pairs: Vec<(usize, &PairingCandidate)> = pairing
            .iter()
            .enumerate()
            .filter_map(|(i, target)| {
                target.and_then(|t| candidates[i].iter().find(|c| c.target == t).map(|c| (i, c)))
            })
            .collect();
        // The Jacobian by its non-zero entries, row by row; the blocks (pose, then landmark)
        // are in column order and apart, so the update is the dense Jacobian's to the bit.
        let m = 2 * pairs.len();
        let mut nonzeros = Vec::with_capacity(m * 5);
        let mut innovation = DVector::zeros(m);
        let mut r = DMatrix::zeros(m, m);
        for (pair, (_, candidate)) in pairs.iter().enumerate() {
            debug_assert!(
                candidate
                    .jacobian
                    .windows(2)
                    .all(|w| w[0].column + w[0].matrix.ncols() <= w[1].column)
            );
            for within in 0..2 {
                for block in &candidate.jacobian {
                    for k in 0..block.matrix.ncols() {
                        let value = block.matrix[(within, k)];
                        if value != 0.0 {
                            nonzeros.push((2 * pair + within, block.column + k, value));
                        }
                    }
                }
            }
            innovation
                .fixed_rows_mut::<2>(2 * pair)
                .copy_from(&candidate.innovation);
            r.fixed_view_mut::<2, 2>(2 * pair, 2 * pair)
                .copy_from(&noise);
        }
        self.state.update_sparse(&innovation, &nonzeros, &r)?;
        for (i, candidate) in &pairs {
            self.info[candidate.target].observe(observations[*i].diameter_m);
        }

        let mut report = ObservationReport {
            associated: pairs.len(),
            ..ObservationReport::default()
        };
        let pose = self.state.pose();
        for (i, observation) in observations.iter().enumerate() {
            if pairing[i].is_some() {
                continue;
            }
            if nearest_distance2[i] <= options.new_landmark_distance2 {
                report.ambiguous += 1;
                continue;
            }
            self.add_landmark(pose, observation, sensor, &noise);
            report.new_landmarks += 1;
        }
        Ok(report)
    }

    /// Starts a landmark where `observation` puts it.
    fn add_landmark(
        &mut self,
        pose: Pose2,
        observation: &LandmarkObservation,
        sensor: &RangeBearingModel,
        noise: &Matrix2<f64>,
    ) {
        let (position, d_pose, d_obs) =
            sensor.landmark_position(pose, observation.range_m, observation.bearing_rad);
        let added_noise = d_obs * noise * d_obs.transpose();
        self.state.add_landmark(position, &d_pose, &added_noise);
        self.info
            .push(LandmarkInfo::first_seen(observation.diameter_m));
    }

    /// Drops landmarks seen fewer than `min_observations` times (marginalising them out).
    pub fn prune(&mut self, min_observations: u32) {
        let drop: Vec<usize> = self
            .info
            .iter()
            .enumerate()
            .filter(|(_, info)| info.observations < min_observations)
            .map(|(i, _)| i)
            .collect();
        self.state.remove_landmarks(&drop);
        let mut index = 0;
        self.info.retain(|_| {
            let keep = drop.binary_search(&index).is_err();
            index += 1;
            keep
        });
    }

    /// Applies a measured position, in the base frame, of the point `antenna_in_robot` on the
    /// robot (a GPS antenna), with covariance `noise` (for GPS, already including the base
    /// frame's own uncertainty), unless its squared Mahalanobis distance exceeds
    /// `gate_distance2`. Returns whether it was applied.
    ///
    /// # Errors
    /// [`EkfError`] when the innovation covariance is not positive definite.
    pub fn observe_position(
        &mut self,
        position_in_base: [f64; 2],
        antenna_in_robot: [f64; 2],
        noise: &Matrix2<f64>,
        gate_distance2: f64,
    ) -> Result<bool, EkfError> {
        let n = self.state.dim();
        let (predicted, d_pose, _) = transform_point(self.state.pose(), antenna_in_robot);
        let innovation = DVector::from_vec(vec![
            position_in_base[0] - predicted[0],
            position_in_base[1] - predicted[1],
        ]);
        let mut h = DMatrix::zeros(2, n);
        h.view_mut((0, 0), (2, 3)).copy_from(&d_pose);
        self.gated_update(&innovation, &h, noise, gate_distance2)
    }

    /// Applies a measured position, in the map frame, of the point `antenna_in_robot` on the
    /// robot (a GPS antenna) with covariance `noise`, through the estimated base, unless its
    /// squared Mahalanobis distance (with the base's uncertainty) exceeds `gate_distance2`.
    /// Returns whether it was applied.
    ///
    /// # Errors
    /// [`EkfError::MissingBase`] when the base is not estimated ([`Self::add_base`]),
    /// [`EkfError::CovarianceNotPositiveDefinite`] when the innovation covariance is not
    /// positive definite.
    pub fn observe_position_in_map(
        &mut self,
        position_in_map: [f64; 2],
        antenna_in_robot: [f64; 2],
        noise: &Matrix2<f64>,
        gate_distance2: f64,
    ) -> Result<bool, EkfError> {
        let (base, _) = self.base_in_map().ok_or(EkfError::MissingBase)?;
        let offset = self.base_offset.ok_or(EkfError::MissingBase)?;
        let n = self.state.dim();
        let (in_base, d_pose, _) = transform_point(self.state.pose(), antenna_in_robot);
        let (predicted, d_base, d_in_base) = transform_point(base, in_base);
        let innovation = DVector::from_vec(vec![
            position_in_map[0] - predicted[0],
            position_in_map[1] - predicted[1],
        ]);
        let mut h = DMatrix::zeros(2, n);
        h.view_mut((0, 0), (2, 3)).copy_from(&(d_in_base * d_pose));
        h.view_mut((0, offset), (2, 3)).copy_from(&d_base);
        self.gated_update(&innovation, &h, noise, gate_distance2)
    }

    /// The update with `innovation`, measurement Jacobian `h` and noise `noise`, unless the
    /// innovation's squared Mahalanobis distance exceeds `gate_distance2`. Returns whether it
    /// was applied.
    fn gated_update(
        &mut self,
        innovation: &DVector<f64>,
        h: &DMatrix<f64>,
        noise: &Matrix2<f64>,
        gate_distance2: f64,
    ) -> Result<bool, EkfError> {
        let r = DMatrix::from_column_slice(2, 2, noise.as_slice());
        let s = self.state.innovation_covariance(h, &r);
        let Some(s_inv) = s.try_inverse() else {
            return Err(EkfError::CovarianceNotPositiveDefinite);
        };
        if innovation.dot(&(s_inv * innovation)) > gate_distance2 {
            return Ok(false);
        }
        self.state.update(innovation, h, &r)?;
        Ok(true)
    }

    /// Takes the local map apart for the map-joining step.
    pub(crate) fn into_parts(self) -> LocalMapParts {
        LocalMapParts {
            state: self.state,
            info: self.info,
            base_offset: self.base_offset,
        }
    }
}

/// A local map at the origin of its base that has seen `trees` (positions in the base frame,
/// 0.3 m trunks) once, without noise: test set-up for the join.
#[cfg(test)]
pub(crate) fn seen_once(trees: &[[f64; 2]]) -> LocalMap {
    let observations: Vec<LandmarkObservation> = trees
        .iter()
        .map(|&[x, y]| LandmarkObservation {
            range_m: x.hypot(y),
            bearing_rad: y.atan2(x),
            diameter_m: Some(0.3),
        })
        .collect();
    let mut local = LocalMap::new(DVector::zeros(3), DMatrix::zeros(3, 3));
    local
        .observe(
            &observations,
            &RangeBearingModel::default(),
            &AssociationOptions::default(),
        )
        .expect("first observations");
    local
}
