//! The trajectory estimated again against the finished map, forwards and backwards.
//!
//! While SLAM runs, each pose is the filter's estimate at the time: it knows only the past,
//! and it is relative to a map that later loops and fixes still move. Once the map is
//! finished, the run's inputs are replayed through a filter over the robot pose alone, with
//! the map's landmarks held where the map puts them:
//!
//! ```text
//! forward   predict with the motion model, update with each tree paired in the map
//!           (nearest within the gate, unambiguous, diameter compatible) and with each fix
//! backward  Rauch–Tung–Striebel: every pose also learns from what came after it
//! ```
//!
//! so the end of a GPS outage, or a stretch between two groups of trees, is bridged from both
//! sides. The landmarks' own errors are shared by neighbouring trees (they come from the same
//! local maps), so a landmark counts here as a point with a fixed spread,
//! [`MapSmootherOptions::landmark_sigma_m`], not with its covariance in the map frame, which
//! holds the drift of the whole map and would make every tree useless.
//!
//! The model's own entries (odometry calibration) are held at the values the map ended with.

use std::collections::HashMap;

use nalgebra::{DVector, Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

use super::frames::transform_point;
use super::motion_model::MotionModel;
use super::range_bearing::{LandmarkObservation, RangeBearingModel};
use super::submap_slam::MappedLandmark;
use crate::geometry::{Pose2, wrap_angle_rad};

/// Settings of [`MapSmoother`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSmootherOptions {
    /// Spread of a landmark around where the map puts it, metres.
    pub landmark_sigma_m: f64,
    /// Squared Mahalanobis distance within which an observation may pair with a landmark.
    pub gate_distance2: f64,
    /// A measured diameter pairs with a landmark's within this many metres…
    pub diameter_tolerance_m: f64,
    /// …plus this fraction of the larger of the two.
    pub diameter_tolerance_fraction: f64,
}

impl Default for MapSmootherOptions {
    fn default() -> Self {
        MapSmootherOptions {
            landmark_sigma_m: 0.2,
            // χ²(2) at 99 %.
            gate_distance2: 9.21,
            diameter_tolerance_m: 0.15,
            diameter_tolerance_fraction: 0.3,
        }
    }
}

/// Side of the cells of the landmark index, metres.
const CELL_M: f64 = 5.0;
/// Farthest from an observation's predicted position that a landmark is looked for, metres.
const MAX_SEARCH_M: f64 = 15.0;

/// One point in time of the forward pass that the backward pass revisits.
#[derive(Debug, Clone, Copy)]
struct Epoch {
    /// Predicted pose and covariance, before this epoch's updates.
    predicted: (Vector3<f64>, Matrix3<f64>),
    /// Jacobian of the predicted pose with respect to the previous epoch's pose.
    transition: Matrix3<f64>,
    /// Pose and covariance after this epoch's updates.
    filtered: (Vector3<f64>, Matrix3<f64>),
}

/// An observation paired with a landmark.
#[derive(Debug, Clone, Copy)]
struct Pairing {
    /// Jacobian of the observation with respect to the pose.
    h_pose: Matrix2x3<f64>,
    innovation: Vector2<f64>,
    /// Measurement noise: the sensor's and the landmark's spread, seen through the sensor.
    noise: Matrix2<f64>,
    /// Inverse of the innovation covariance.
    s_inverse: Matrix2<f64>,
}

/// Running totals of a [`MapSmoother`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MapSmootherStats {
    /// Observations paired with a landmark and used.
    pub paired: usize,
    /// Observations left out: no landmark within the gate, or more than one.
    pub unpaired: usize,
    /// Position fixes used.
    pub fixes_used: usize,
    /// Position fixes outside the gate.
    pub fixes_rejected: usize,
}

/// Localisation against a finished map with a backward smoothing pass. See the
/// [module documentation](self).
#[derive(Debug)]
pub struct MapSmoother<'a, M: MotionModel> {
    motion: &'a M,
    sensor: RangeBearingModel,
    options: MapSmootherOptions,
    landmarks: &'a [MappedLandmark],
    index: HashMap<(i64, i64), Vec<usize>>,
    /// The robot block; its entries beyond the pose stay at their starting values.
    robot: DVector<f64>,
    covariance: Matrix3<f64>,
    /// Product of the motion Jacobians since the last epoch.
    transition: Matrix3<f64>,
    epochs: Vec<Epoch>,
    stats: MapSmootherStats,
}

impl<'a, M: MotionModel> MapSmoother<'a, M> {
    /// A smoother over `landmarks` whose robot block starts at `robot` (pose first, then the
    /// model's entries) with pose covariance `covariance`. Epoch 0 is the start.
    pub fn new(
        motion: &'a M,
        sensor: RangeBearingModel,
        options: MapSmootherOptions,
        landmarks: &'a [MappedLandmark],
        robot: DVector<f64>,
        covariance: Matrix3<f64>,
    ) -> Self {
        let mut index: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, landmark) in landmarks.iter().enumerate() {
            index
                .entry(cell(landmark.position_in_map))
                .or_default()
                .push(i);
        }
        let pose = Vector3::new(robot[0], robot[1], robot[2]);
        MapSmoother {
            motion,
            sensor,
            options,
            landmarks,
            index,
            robot,
            covariance,
            transition: Matrix3::identity(),
            epochs: vec![Epoch {
                predicted: (pose, covariance),
                transition: Matrix3::identity(),
                filtered: (pose, covariance),
            }],
            stats: MapSmootherStats::default(),
        }
    }

    /// Moves the robot over `dt_s` seconds driven by `input`.
    pub fn predict(&mut self, input: &M::Input, dt_s: f64) {
        if dt_s <= 0.0 {
            return;
        }
        let prediction = self.motion.predict(&self.robot, input, dt_s);
        let f = prediction.f.fixed_view::<3, 3>(0, 0).into_owned();
        let q = prediction.q.fixed_view::<3, 3>(0, 0).into_owned();
        for i in 0..3 {
            self.robot[i] = prediction.robot[i];
        }
        self.covariance = f * self.covariance * f.transpose() + q;
        self.transition = f * self.transition;
    }

    /// Starts an epoch at the current time and returns its number.
    fn begin_epoch(&mut self) -> usize {
        let pose = self.pose();
        self.epochs.push(Epoch {
            predicted: (pose, self.covariance),
            transition: self.transition,
            filtered: (pose, self.covariance),
        });
        self.transition = Matrix3::identity();
        self.epochs.len() - 1
    }

    /// Uses one scan's observations (none is fine): each pairs with the one landmark within
    /// the gate, or is left out. Returns the scan's epoch, its index in [`Self::smooth`].
    pub fn observe(&mut self, observations: &[LandmarkObservation]) -> usize {
        let epoch = self.begin_epoch();
        let landmark_noise = Matrix2::identity() * self.options.landmark_sigma_m.powi(2);
        for observation in observations {
            let Some(pairing) = self.pair(observation, &landmark_noise) else {
                self.stats.unpaired += 1;
                continue;
            };
            self.update(
                &pairing.innovation,
                &pairing.h_pose,
                &pairing.noise,
                &pairing.s_inverse,
            );
            self.stats.paired += 1;
        }
        self.store();
        epoch
    }

    /// Uses a measured position in the map frame of the point `antenna_in_robot`, with
    /// covariance `noise`, unless its squared Mahalanobis distance exceeds `gate_distance2`.
    /// Returns whether it was used.
    pub fn observe_position(
        &mut self,
        position_in_map: [f64; 2],
        antenna_in_robot: [f64; 2],
        noise: &Matrix2<f64>,
        gate_distance2: f64,
    ) -> bool {
        self.begin_epoch();
        let (predicted, d_pose, _) = transform_point(self.robot_pose(), antenna_in_robot);
        let innovation = Vector2::new(
            position_in_map[0] - predicted[0],
            position_in_map[1] - predicted[1],
        );
        let s = d_pose * self.covariance * d_pose.transpose() + noise;
        let s_inverse = s.try_inverse().filter(|s_inverse| {
            (innovation.transpose() * s_inverse * innovation)[0] <= gate_distance2
        });
        if let Some(s_inverse) = &s_inverse {
            self.update(&innovation, &d_pose, noise, s_inverse);
        }
        let used = s_inverse.is_some();
        if used {
            self.stats.fixes_used += 1;
        } else {
            self.stats.fixes_rejected += 1;
        }
        self.store();
        used
    }

    /// Running totals.
    pub fn stats(&self) -> MapSmootherStats {
        self.stats
    }

    /// The smoothed pose of every epoch: the start (epoch 0), then each scan and fix.
    pub fn smooth(&self) -> Vec<Pose2> {
        let mut smoothed = vec![Pose2::IDENTITY; self.epochs.len()];
        let Some(last) = self.epochs.last() else {
            return smoothed;
        };
        let mut next = last.filtered.0;
        smoothed[self.epochs.len() - 1] = Pose2 {
            x_m: next[0],
            y_m: next[1],
            theta_rad: next[2],
        };
        for k in (0..self.epochs.len() - 1).rev() {
            let (filtered, p_filtered) = self.epochs[k].filtered;
            let (predicted, p_predicted) = self.epochs[k + 1].predicted;
            let transition = self.epochs[k + 1].transition;
            let pose = match p_predicted.try_inverse() {
                Some(inverse) => {
                    let gain = p_filtered * transition.transpose() * inverse;
                    let mut difference = next - predicted;
                    difference[2] = wrap_angle_rad(difference[2]);
                    let mut pose = filtered + gain * difference;
                    pose[2] = wrap_angle_rad(pose[2]);
                    pose
                }
                None => filtered,
            };
            smoothed[k] = Pose2 {
                x_m: pose[0],
                y_m: pose[1],
                theta_rad: pose[2],
            };
            next = pose;
        }
        smoothed
    }

    fn pose(&self) -> Vector3<f64> {
        Vector3::new(self.robot[0], self.robot[1], self.robot[2])
    }

    /// The pose entries of the robot block, as the motion and sensor models take them.
    fn robot_pose(&self) -> Pose2 {
        Pose2 {
            x_m: self.robot[0],
            y_m: self.robot[1],
            theta_rad: self.robot[2],
        }
    }

    /// Records the current estimate as the last epoch's filtered one.
    fn store(&mut self) {
        let pose = self.pose();
        if let Some(epoch) = self.epochs.last_mut() {
            epoch.filtered = (pose, self.covariance);
        }
    }

    /// The landmark `observation` pairs with, if exactly one lies within the gate: the
    /// observation's Jacobian with respect to the pose, the innovation and its covariance.
    fn pair(
        &self,
        observation: &LandmarkObservation,
        landmark_noise: &Matrix2<f64>,
    ) -> Option<Pairing> {
        let pose = self.robot_pose();
        let noise = self.sensor.noise();
        let (at, d_pose, d_observation) =
            self.sensor
                .landmark_position(pose, observation.range_m, observation.bearing_rad);
        let spread = d_pose * self.covariance * d_pose.transpose()
            + d_observation * noise * d_observation.transpose()
            + landmark_noise;
        let largest = spread.symmetric_eigenvalues().max().max(0.0);
        let radius_m = (self.options.gate_distance2 * largest)
            .sqrt()
            .min(MAX_SEARCH_M);
        let low = cell([at[0] - radius_m, at[1] - radius_m]);
        let high = cell([at[0] + radius_m, at[1] + radius_m]);
        let mut found: Option<Pairing> = None;
        for cx in low.0..=high.0 {
            for cy in low.1..=high.1 {
                for &i in self.index.get(&(cx, cy)).into_iter().flatten() {
                    let landmark = &self.landmarks[i];
                    if !landmark.info.diameter_compatible(
                        observation.diameter_m,
                        self.options.diameter_tolerance_m,
                        self.options.diameter_tolerance_fraction,
                    ) {
                        continue;
                    }
                    let Some(predicted) = self.sensor.predict(pose, landmark.position_in_map)
                    else {
                        continue;
                    };
                    let innovation = RangeBearingModel::innovation(observation, &predicted);
                    let (h_pose, h_landmark) = (predicted.d_pose, predicted.d_landmark);
                    let total_noise = h_landmark * landmark_noise * h_landmark.transpose() + noise;
                    let s = h_pose * self.covariance * h_pose.transpose() + total_noise;
                    let Some(s_inverse) = s.try_inverse() else {
                        continue;
                    };
                    if (innovation.transpose() * s_inverse * innovation)[0]
                        > self.options.gate_distance2
                    {
                        continue;
                    }
                    if found.is_some() {
                        // A second landmark fits as well: ambiguous.
                        return None;
                    }
                    found = Some(Pairing {
                        h_pose,
                        innovation,
                        noise: total_noise,
                        s_inverse,
                    });
                }
            }
        }
        found
    }

    /// The Kalman update of the pose with `innovation`, Jacobian `h`, measurement noise
    /// `noise` and the inverse of the innovation covariance (Joseph form).
    fn update(
        &mut self,
        innovation: &Vector2<f64>,
        h: &Matrix2x3<f64>,
        noise: &Matrix2<f64>,
        s_inverse: &Matrix2<f64>,
    ) {
        let p = self.covariance;
        let gain = p * h.transpose() * s_inverse;
        let correction = gain * innovation;
        for i in 0..3 {
            self.robot[i] += correction[i];
        }
        self.robot[2] = wrap_angle_rad(self.robot[2]);
        let i_kh = Matrix3::identity() - gain * h;
        let updated = i_kh * p * i_kh.transpose() + gain * noise * gain.transpose();
        self.covariance = 0.5 * (updated + updated.transpose());
    }
}

fn cell(position: [f64; 2]) -> (i64, i64) {
    (
        (position[0] / CELL_M).floor() as i64,
        (position[1] / CELL_M).floor() as i64,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ekf_slam::{DifferentialDriveInput, DifferentialDriveModel, LandmarkInfo};

    fn landmark(x_m: f64, y_m: f64) -> MappedLandmark {
        MappedLandmark {
            position_in_map: [x_m, y_m],
            covariance: Matrix2::identity() * 0.01,
            info: LandmarkInfo::first_seen(None),
        }
    }

    fn sensor() -> RangeBearingModel {
        RangeBearingModel {
            sensor_in_robot: Pose2::IDENTITY,
            sigma_range_m: 0.05,
            sigma_bearing_rad: 0.5f64.to_radians(),
        }
    }

    /// A smoother over `landmarks` starting at the origin, known to 0.1 m and 0.1 rad.
    fn at_origin<'a>(
        model: &'a DifferentialDriveModel,
        landmarks: &'a [MappedLandmark],
    ) -> MapSmoother<'a, DifferentialDriveModel> {
        MapSmoother::new(
            model,
            sensor(),
            MapSmootherOptions::default(),
            landmarks,
            DVector::zeros(3),
            Matrix3::identity() * 0.01,
        )
    }

    /// What the sensor reads of `landmarks` from `pose`, without noise.
    fn observe(pose: Pose2, landmarks: &[MappedLandmark]) -> Vec<LandmarkObservation> {
        landmarks
            .iter()
            .filter_map(|l| sensor().predict(pose, l.position_in_map))
            .map(|predicted| LandmarkObservation {
                range_m: predicted.z[0],
                bearing_rad: predicted.z[1],
                diameter_m: None,
            })
            .collect()
    }

    /// Drives along x at 1 m/s for `seconds`, odometry reading 5 % short; at each whole
    /// second, `at_second` observes something and records the epoch of that second. Returns
    /// the smoothed pose at each second.
    fn drive_short(
        model: &DifferentialDriveModel,
        landmarks: &[MappedLandmark],
        seconds: usize,
        mut at_second: impl FnMut(&mut MapSmoother<'_, DifferentialDriveModel>, Pose2, &mut Vec<usize>),
    ) -> Vec<Pose2> {
        let mut smoother = MapSmoother::new(
            model,
            sensor(),
            MapSmootherOptions::default(),
            landmarks,
            DVector::zeros(3),
            Matrix3::identity() * 1e-6,
        );
        let odometry = DifferentialDriveInput {
            speed_mps: 0.95,
            yaw_rate_radps: 0.0,
        };
        let mut epochs = vec![0];
        for second in 1..=seconds {
            for _ in 0..10 {
                smoother.predict(&odometry, 0.1);
            }
            let truth = Pose2 {
                x_m: second as f64,
                ..Pose2::IDENTITY
            };
            at_second(&mut smoother, truth, &mut epochs);
        }
        let smoothed = smoother.smooth();
        epochs.into_iter().map(|e| smoothed[e]).collect()
    }

    #[test]
    fn trees_of_the_map_hold_the_pose_against_biased_odometry() {
        let model = DifferentialDriveModel::default();
        let trees: Vec<MappedLandmark> = (0..12)
            .flat_map(|i| {
                [
                    landmark(2.0 * i as f64, 4.0),
                    landmark(2.0 * i as f64 + 1.0, -5.0),
                ]
            })
            .collect();
        let poses = drive_short(&model, &trees, 20, |smoother, truth, epochs| {
            epochs.push(smoother.observe(&observe(truth, &trees)));
        });
        // Odometry alone would be 1 m short at 20 s.
        for (second, pose) in poses.iter().enumerate() {
            let error_m = (pose.x_m - second as f64).hypot(pose.y_m);
            assert!(error_m < 0.1, "{second} s: {pose:?}");
        }
    }

    #[test]
    fn a_later_fix_corrects_the_poses_before_it() {
        // Speed noise that covers the odometry's 5 % error over the 20 s.
        let model = DifferentialDriveModel {
            sigma_speed_mps: 0.5,
            ..DifferentialDriveModel::default()
        };
        let noise = Matrix2::identity() * 0.01;
        let mut filtered_at_10_s = Pose2::IDENTITY;
        let poses = drive_short(&model, &[], 20, |smoother, truth, epochs| {
            epochs.push(smoother.observe(&[]));
            if truth.x_m == 10.0 {
                filtered_at_10_s = smoother.robot_pose();
            }
            if truth.x_m == 20.0 {
                assert!(smoother.observe_position([20.0, 0.0], [0.0; 2], &noise, 25.0));
            }
        });
        // Filtered, the pose at 10 s is 0.5 m short; the fix at 20 s takes most of that back.
        assert!(
            (filtered_at_10_s.x_m - 9.5).abs() < 1e-6,
            "{filtered_at_10_s:?}"
        );
        assert!((poses[10].x_m - 10.0).abs() < 0.1, "{:?}", poses[10]);
        assert!((poses[20].x_m - 20.0).abs() < 0.2, "{:?}", poses[20]);
    }

    #[test]
    fn an_observation_near_two_trees_is_left_out() {
        let model = DifferentialDriveModel::default();
        // Two trees 0.3 m apart: at 10 m, closer than the bearing noise tells apart.
        let trees = [landmark(10.0, 0.0), landmark(10.0, 0.3)];
        let mut smoother = at_origin(&model, &trees);
        smoother.observe(&observe(Pose2::IDENTITY, &trees[..1]));
        assert_eq!(smoother.stats().paired, 0);
        assert_eq!(smoother.stats().unpaired, 1);

        let alone = [landmark(10.0, 0.0)];
        let mut smoother = at_origin(&model, &alone);
        smoother.observe(&observe(Pose2::IDENTITY, &alone));
        assert_eq!(smoother.stats().paired, 1);
    }
}
