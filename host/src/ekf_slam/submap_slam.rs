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

use super::frames::{compose_pose, invert_pose, transform_point};
use super::global_map::{GlobalMap, JoinReport};
use super::history_memory::HistoryMemory;
use super::landmark_info::LandmarkInfo;
use super::local_map::{LocalMap, ObservationReport};
use super::motion_model::MotionModel;
use super::options::SubmapSlamOptions;
use super::range_bearing::{LandmarkObservation, RangeBearingModel};

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
    /// Updates skipped because the innovation covariance was not positive definite.
    pub failed_updates: usize,
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
    stats: SubmapSlamStats,
}

impl<M: MotionModel> SubmapSlam<M> {
    /// A filter whose robot starts exactly at `start_in_map`.
    pub fn new(
        motion: M,
        sensor: RangeBearingModel,
        options: SubmapSlamOptions,
        start_in_map: [f64; 3],
    ) -> SubmapSlam<M> {
        let (robot, covariance) = motion.initial_robot([0.0; 3]);
        SubmapSlam {
            global: GlobalMap::new(start_in_map, Matrix3::zeros()),
            local: LocalMap::new(robot, covariance),
            history: options.history.map(HistoryMemory::new),
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
    /// The fix is expressed in the local map's base frame taking the base as known: the
    /// joined map's base accumulates the odometry drift of every local map, and folding its
    /// covariance into the fix would make GPS count for ever less as the run goes on. The
    /// price is that the local map's covariance ignores the base's share of the fix's error.
    pub fn observe_position(
        &mut self,
        position_in_map: [f64; 2],
        antenna_in_robot: [f64; 2],
        noise: &Matrix2<f64>,
        gate_distance2: f64,
    ) -> bool {
        let base_from_map = invert_pose(self.global.current_base());
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
    /// its base, is unchanged.
    pub fn transform_map(&mut self, new_from_old: [f64; 3]) {
        self.global.transform(new_from_old);
    }

    /// Closes the local map now: drops one-off landmarks, joins it, starts the next one at
    /// the robot's pose with the calibration entries carried over.
    pub fn close_local_map(&mut self) -> JoinReport {
        let robot = self.local.state().robot();
        let robot_covariance = self.local.state().robot_covariance();
        let mut local = self.local.clone();
        local.prune(self.options.min_observations);
        let recognised = self.recognise_place(&local);
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
        self.stats.joins += 1;
        self.stats.fused += report.fused;
        if report.revisited >= 2 {
            self.stats.loop_closures += 1;
        }
        let (mut mean, mut covariance) = self.motion.initial_robot([0.0; 3]);
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
    pub fn pose_in_map(&self) -> ([f64; 3], Matrix3<f64>) {
        let base = self.global.current_base();
        let (pose, d_base, d_local) = compose_pose(base, self.local.state().pose());
        let covariance = d_base * self.global.state().pose_covariance() * d_base.transpose()
            + d_local * self.local.state().pose_covariance() * d_local.transpose();
        (pose, covariance)
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
        if self.local.landmark_count() > 0 || self.stats.joins == 0 {
            self.close_local_map();
        }
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

/// The landmarks of `local`, built in the global map's current base, in the map frame.
fn local_landmarks(global: &GlobalMap, local: &LocalMap) -> Vec<MappedLandmark> {
    let base = global.current_base();
    let p_base = global.state().pose_covariance();
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
