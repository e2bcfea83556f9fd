//! The EKF submapping pipeline: predict with the motion model, associate and update in the
//! local map, close the local map when it is full and join it into the global map.
//!
//! ```text
//! predict(input, dt)      local map: robot block moves (O(n), n bounded)
//! observe(scan)           local map: gate + JCBB, Joseph update, new landmarks
//!   local map full?       prune one-off landmarks, join into the global map, start a new one
//! observe_position(gps)   local map: robot position update
//! ```
//!
//! With `max_landmarks_per_local_map = usize::MAX` the local map is never closed and the
//! filter is one global EKF, the baseline the submaps are compared against.

use nalgebra::{DVector, Matrix2, Matrix3};

use super::frames::{compose_pose, transform_point};
use super::global_map::{GlobalMap, JoinReport};
use super::history_memory::HistoryMemory;
use super::landmark_info::LandmarkInfo;
use super::local_map::{LocalMap, ObservationReport};
use super::local_map_anchors::LocalMapAnchors;
use super::motion_model::MotionModel;
use super::options::SubmapSlamOptions;
use super::range_bearing::{LandmarkObservation, RangeBearingModel};
use crate::geometry::Pose2;

/// A landmark of the map, in the map frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MappedLandmark {
    /// Position, metres.
    pub position_in_map: [f64; 2],
    /// Covariance of the position.
    pub covariance: Matrix2<f64>,
    /// What is known of it besides its position.
    pub info: LandmarkInfo,
}

/// Running totals of a [`SubmapSlam`] run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SubmapSlamStats {
    /// Motion steps.
    pub predictions: usize,
    /// Observation batches.
    pub scans: usize,
    /// Sum of the observation reports.
    pub observations: ObservationReport,
    /// Local maps joined.
    pub joins: usize,
    /// Landmarks fused across local maps when joining.
    pub fused: usize,
    /// Joins that fused landmarks first mapped at least two local maps earlier.
    pub loop_closures: usize,
    /// Revisits the history memory confirmed.
    pub recognised_places: usize,
    /// Of those, the places the join turned down as implausible and too thinly backed.
    pub rejected_places: usize,
    /// Updates skipped because the innovation covariance was not positive definite.
    pub failed_updates: usize,
    /// Records found to be of one trunk with another and merged into it when joining.
    pub merged_records: usize,
}

/// EKF SLAM with local maps. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct SubmapSlam<M: MotionModel> {
    motion: M,
    sensor: RangeBearingModel,
    options: SubmapSlamOptions,
    global: GlobalMap,
    local: LocalMap,
    history: Option<HistoryMemory>,
    anchors: LocalMapAnchors,
    stats: SubmapSlamStats,
}

impl<M: MotionModel> SubmapSlam<M> {
    /// A filter whose robot starts exactly at `start_in_map`.
    pub fn new(
        motion: M,
        sensor: RangeBearingModel,
        options: SubmapSlamOptions,
        start_in_map: Pose2,
    ) -> SubmapSlam<M> {
        let (robot, covariance) = motion.initial_robot(Pose2::IDENTITY);
        SubmapSlam {
            global: GlobalMap::new(start_in_map, Matrix3::zeros()),
            local: LocalMap::new(robot, covariance),
            history: options.history.map(HistoryMemory::new),
            anchors: LocalMapAnchors::default(),
            motion,
            sensor,
            options,
            stats: SubmapSlamStats::default(),
        }
    }

    /// Moves the robot over `dt_s` seconds driven by `input`.
    pub fn predict(&mut self, input: &M::Input, dt_s: f64) {
        self.local.predict(&self.motion, input, dt_s);
        self.stats.predictions += 1;
    }

    /// Uses one scan's landmark observations; closes and joins the local map when it is full.
    pub fn observe(&mut self, observations: &[LandmarkObservation]) -> ObservationReport {
        self.stats.scans += 1;
        let report = match self
            .local
            .observe(observations, &self.sensor, &self.options.association)
        {
            Ok(report) => report,
            Err(_) => {
                self.stats.failed_updates += 1;
                ObservationReport::default()
            }
        };
        let totals = &mut self.stats.observations;
        totals.associated += report.associated;
        totals.new_landmarks += report.new_landmarks;
        totals.ambiguous += report.ambiguous;
        if self.local.landmark_count() >= self.options.max_landmarks_per_local_map {
            self.close_local_map();
        }
        report
    }

    /// Uses a measured position in the map frame of the point `antenna_in_robot` (a GPS fix
    /// already expressed in the map frame) with covariance `noise`, unless its squared
    /// Mahalanobis distance exceeds `gate_distance2` (a GPS jump). Returns whether it was used.
    ///
    /// The local map estimates its base in the map frame from the first fix on (started from
    /// the global map's estimate, see [`LocalMap::add_base`]), so the fix is compared with
    /// the whole uncertainty of the robot's position in the map (drift accumulated over
    /// earlier local maps included), and what it says about the base reaches the global map
    /// when the local map is joined. Only when the base is exactly known (the first local
    /// map) is the fix expressed in the base frame with the base taken as given.
    pub fn observe_position(
        &mut self,
        position_in_map: [f64; 2],
        antenna_in_robot: [f64; 2],
        noise: &Matrix2<f64>,
        gate_distance2: f64,
    ) -> bool {
        let global_base_known = self.global.state().pose_covariance().cholesky().is_some();
        if self.local.base_in_map().is_none() && global_base_known {
            self.local.add_base(
                self.global.current_base(),
                &self.global.state().pose_covariance(),
            );
        }
        if self.local.base_in_map().is_some() {
            return match self.local.observe_position_in_map(
                position_in_map,
                antenna_in_robot,
                noise,
                gate_distance2,
            ) {
                Ok(used) => used,
                Err(_) => {
                    self.stats.failed_updates += 1;
                    false
                }
            };
        }
        let base_from_map = self.global.current_base().inverse();
        let (in_base, _, d_point) = transform_point(base_from_map, position_in_map);
        let total = d_point * noise * d_point.transpose();
        match self
            .local
            .observe_position(in_base, antenna_in_robot, &total, gate_distance2)
        {
            Ok(used) => used,
            Err(_) => {
                self.stats.failed_updates += 1;
                false
            }
        }
    }

    /// Re-expresses the map in another frame (`new_from_old`); the local map, relative to
    /// its base, is unchanged (its estimate of the base, if any, moves with the map).
    pub fn transform_map(&mut self, new_from_old: Pose2) {
        self.global.transform(new_from_old);
        self.local.transform_base(new_from_old);
    }

    /// Closes the local map now: drops one-off landmarks, joins it, starts the next one at
    /// the robot's pose with the calibration entries carried over.
    pub fn close_local_map(&mut self) -> JoinReport {
        let robot = self.local.state().robot();
        let robot_covariance = self.local.state().robot_covariance();
        let mut local = self.local.clone();
        local.prune(self.options.min_observations);
        let recognised = self.recognise_place(&local);
        // Only the first local map's anchors are used (the smoother's start), and keeping
        // every map's would grow with the time driven, not the area mapped.
        let first_in_base: Option<Vec<[f64; 2]>> = self.anchors.is_empty().then(|| {
            (0..local.landmark_count())
                .map(|i| local.state().landmark(i))
                .collect()
        });
        let report = match self
            .global
            .join(local, &self.options.join_association, &recognised)
        {
            Ok(report) => report,
            Err(_) => {
                self.stats.failed_updates += 1;
                JoinReport::default()
            }
        };
        if let Some(landmarks_in_base) = first_in_base {
            self.anchors
                .record(self.global.last_joined_ids().to_vec(), landmarks_in_base);
        }
        self.anchors.follow(self.global.last_merged_ids());
        self.stats.joins += 1;
        self.stats.fused += report.fused;
        self.stats.merged_records += report.merged_records;
        if report.revisited >= 2 {
            self.stats.loop_closures += 1;
        }
        if report.place_rejected {
            self.stats.rejected_places += 1;
        }
        let (mut mean, mut covariance) = self.motion.initial_robot(Pose2::IDENTITY);
        for i in 3..mean.len() {
            mean[i] = robot[i];
            for j in 3..mean.len() {
                covariance[(i, j)] = robot_covariance[(i, j)];
            }
        }
        self.local = LocalMap::new(mean, covariance);
        report
    }

    /// Asks the history memory whether `local` (about to be joined) revisits an older part of
    /// the map; returns the pairs `(local landmark, global landmark)` of a confirmed revisit.
    fn recognise_place(&mut self, local: &LocalMap) -> Vec<(usize, usize)> {
        let Some(history) = self.history.as_mut() else {
            return Vec::new();
        };
        let local_map = self.global.bases_in_map().len() - 1;
        let old = self
            .global
            .landmarks_older_than(local_map.saturating_sub(2));
        let global_in_map = global_landmarks(&self.global);
        let local_in_map = local_landmarks(&self.global, local);
        match history.add_local_map(local_map, &local_in_map, &global_in_map, &old) {
            Some(closure) => {
                self.stats.recognised_places += 1;
                closure.pairs
            }
            None => Vec::new(),
        }
    }

    /// The robot pose in the map frame and its covariance.
    pub fn pose_in_map(&self) -> (Pose2, Matrix3<f64>) {
        if let Some(offset) = self.local.base_offset() {
            // Base and robot are both local entries, correlated through the fixes.
            let state = self.local.state();
            let (base, _) = self.local.base_in_map().unwrap_or_default();
            let (pose, d_base, d_local) = compose_pose(base, state.pose());
            let p = state.covariance();
            let p_bb = p.fixed_view::<3, 3>(offset, offset);
            let p_rr = p.fixed_view::<3, 3>(0, 0);
            let p_rb = p.fixed_view::<3, 3>(0, offset);
            let cross = d_local * p_rb * d_base.transpose();
            let covariance = d_base * p_bb * d_base.transpose()
                + d_local * p_rr * d_local.transpose()
                + cross
                + cross.transpose();
            return (pose, covariance);
        }
        let base = self.global.current_base();
        let (pose, d_base, d_local) = compose_pose(base, self.local.state().pose());
        let covariance = d_base * self.global.state().pose_covariance() * d_base.transpose()
            + d_local * self.local.state().pose_covariance() * d_local.transpose();
        (pose, covariance)
    }

    /// The first local map's base, fitted to where the map now puts its landmarks
    /// ([`LocalMapAnchors`]): a pose recorded in that local map's frame lies at
    /// `base ⊕ pose` in the map as it stands now. `None` before the first local map is
    /// closed, or when too few of its landmarks are left.
    pub fn first_local_map_base_in_map(&self) -> Option<Pose2> {
        self.anchors
            .bases_in_map(&self.global)
            .first()
            .copied()
            .flatten()
    }

    /// Closes the local map being built if it holds landmarks (or if none was closed yet), as
    /// at the end of a run; a new, empty one starts.
    pub fn close_last_local_map(&mut self) {
        if self.local.landmark_count() > 0 || self.stats.joins == 0 {
            self.close_local_map();
        }
    }

    /// The robot block of the local map (pose in the base frame, then the model's entries).
    pub fn robot_in_local_map(&self) -> DVector<f64> {
        self.local.state().robot()
    }

    /// Every landmark: the global map's and the current local map's (the latter transformed
    /// into the map frame, not yet fused).
    pub fn landmarks_in_map(&self) -> Vec<MappedLandmark> {
        let mut landmarks = global_landmarks(&self.global);
        landmarks.extend(local_landmarks(&self.global, &self.local));
        landmarks
    }

    /// Landmarks in the current local map.
    pub fn local_landmark_count(&self) -> usize {
        self.local.landmark_count()
    }

    /// Landmarks in the global map (not counting the current local map's).
    pub fn global_landmark_count(&self) -> usize {
        self.global.landmark_info().len()
    }

    /// The global map.
    pub fn global_map(&self) -> &GlobalMap {
        &self.global
    }

    /// Running totals.
    pub fn stats(&self) -> SubmapSlamStats {
        self.stats
    }

    /// Closes the last local map and returns the global map.
    pub fn finish(mut self) -> (GlobalMap, SubmapSlamStats) {
        self.close_last_local_map();
        (self.global, self.stats)
    }
}

/// The global map's landmarks.
fn global_landmarks(global: &GlobalMap) -> Vec<MappedLandmark> {
    let state = global.state();
    global
        .landmark_info()
        .iter()
        .enumerate()
        .map(|(i, info)| MappedLandmark {
            position_in_map: state.landmark(i),
            covariance: state.landmark_covariance(i),
            info: *info,
        })
        .collect()
}

/// The landmarks of `local`, built in its base, in the map frame (through the local map's
/// estimate of the base when it has one; its correlation with the landmarks is left out).
fn local_landmarks(global: &GlobalMap, local: &LocalMap) -> Vec<MappedLandmark> {
    let (base, p_base) = local
        .base_in_map()
        .unwrap_or_else(|| (global.current_base(), global.state().pose_covariance()));
    let state = local.state();
    local
        .landmark_info()
        .iter()
        .enumerate()
        .map(|(i, info)| {
            let (position, d_base, d_point) = transform_point(base, state.landmark(i));
            MappedLandmark {
                position_in_map: position,
                covariance: d_base * p_base * d_base.transpose()
                    + d_point * state.landmark_covariance(i) * d_point.transpose(),
                info: *info,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ekf_slam::{DifferentialDriveInput, DifferentialDriveModel};

    /// A robot driving along x whose odometry reads 2 % short, in local maps closed every
    /// 10 s, with no landmarks.
    fn drive(slam: &mut SubmapSlam<DifferentialDriveModel>, seconds: usize) {
        let input = DifferentialDriveInput {
            speed_mps: 0.98,
            yaw_rate_radps: 0.0,
        };
        for step in 0..seconds {
            slam.predict(&input, 1.0);
            if step % 10 == 9 {
                slam.close_local_map();
            }
        }
    }

    #[test]
    fn fixes_reach_the_global_map_through_the_local_base() {
        let model = DifferentialDriveModel {
            sigma_speed_per_speed: 0.05,
            ..DifferentialDriveModel::default()
        };
        let mut slam = SubmapSlam::new(
            model,
            RangeBearingModel::default(),
            SubmapSlamOptions::default(),
            Pose2::IDENTITY,
        );
        drive(&mut slam, 100);
        let (pose, covariance) = slam.pose_in_map();
        // The truth is 100 m on; the filter says 98 m, 2 m short, which its own uncertainty
        // (accumulated over ten local maps, σ ≈ 1 m) covers but the current local map's
        // (σ ≈ 0.3 m) does not.
        assert!((pose.x_m - 98.0).abs() < 1e-6);
        let sigma_x = covariance[(0, 0)].sqrt();
        assert!(2.0 / sigma_x < 3.0, "σx = {sigma_x}");
        let noise = Matrix2::identity() * 0.25;
        assert!(slam.observe_position([100.0, 0.0], [0.0; 2], &noise, 25.0));
        let (after, after_covariance) = slam.pose_in_map();
        assert!((after.x_m - 100.0).abs() < 0.5, "x = {}", after.x_m);
        assert!(after_covariance[(0, 0)] < 0.25);
        // Joining moves the global map's base (the new local map's start) onto the fix too.
        slam.close_local_map();
        let base = slam.global_map().current_base();
        assert!((base.x_m - 100.0).abs() < 0.5, "base x = {}", base.x_m);
        assert!(slam.global_map().state().pose_covariance()[(0, 0)] < 0.25);
    }
}
