//! The ideal EKF: a reference for the consistency test that only a simulator can run.
//!
//! It is EKF SLAM as the submap filter runs it (the same motion and sensor models, the same
//! [`EkfState`] with its Joseph-form update, one stacked update per scan), with the two things
//! a real filter cannot have: the simulator's landmark identities for data association, and
//! every Jacobian evaluated at the true state instead of the estimate (the motion's at the
//! previous true pose, the observation's at the true pose and the true landmark). The means
//! still move with the estimate: innovations are taken at the estimated state, and a new
//! landmark is placed from the estimated pose. Huang, Mourikis and Roumeliotis ("Analysis and
//! Improvement of the Consistency of Extended Kalman Filter based SLAM", ICRA 2008) use it to
//! separate the errors of linearisation from those of the test itself.
//!
//! Its NEES over a set of runs shows what the test yields when neither association nor
//! linearisation is at fault: the spread that comes from which runs were drawn.

use std::collections::HashMap;

use host::ekf_slam::{
    DifferentialDriveInput, DifferentialDriveModel, EkfError, EkfState, LandmarkObservation,
    MotionModel, RangeBearingModel,
};
use host::geometry::Pose2;
use nalgebra::{DMatrix, DVector, Matrix2, Matrix3};

use super::simulated_run::SimObservation;
use crate::world::Landmark;

/// The ideal EKF's state over one run. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct IdealEkf {
    state: EkfState,
    motion: DifferentialDriveModel,
    sensor: RangeBearingModel,
    /// True landmark centres by identity.
    true_centres: HashMap<u32, [f64; 2]>,
    /// State index of each landmark mapped so far, by identity.
    mapped: HashMap<u32, usize>,
}

/// Errors of the ideal EKF.
#[derive(Debug, thiserror::Error)]
pub enum IdealEkfError {
    /// An observation names a landmark the world does not have.
    #[error("observation of landmark {0}, which the world does not have")]
    UnknownLandmark(u32),
    /// A landmark lies on the sensor, where the bearing is undefined.
    #[error("landmark {0} lies on the sensor")]
    OnTheSensor(u32),
    /// The filter's update failed.
    #[error(transparent)]
    Update(#[from] EkfError),
}

/// The filter's pose for a simulated pose `[x_m, y_m, theta_rad]` (the angle as given).
fn filter_pose([x_m, y_m, theta_rad]: [f64; 3]) -> Pose2 {
    Pose2 {
        x_m,
        y_m,
        theta_rad,
    }
}

impl IdealEkf {
    /// A filter that starts exactly at the simulated pose `start` (zero covariance) in a world
    /// of `landmarks`.
    pub fn new(
        motion: DifferentialDriveModel,
        sensor: RangeBearingModel,
        landmarks: &[Landmark],
        start: [f64; 3],
    ) -> Self {
        let (mean, covariance) = motion.initial_robot(filter_pose(start));
        IdealEkf {
            state: EkfState::new(mean, covariance),
            motion,
            sensor,
            true_centres: landmarks.iter().map(|l| (l.id, l.center_m)).collect(),
            mapped: HashMap::new(),
        }
    }

    /// Moves the robot by `input` over `dt_s`, linearised at `previous_true_pose`.
    pub fn predict(
        &mut self,
        input: &DifferentialDriveInput,
        dt_s: f64,
        previous_true_pose: [f64; 3],
    ) {
        let estimated = self.motion.predict(&self.state.robot(), input, dt_s);
        let at_truth =
            self.motion
                .predict(&DVector::from_row_slice(&previous_true_pose), input, dt_s);
        self.state
            .predict_robot(&estimated.robot, &at_truth.f, &at_truth.q);
    }

    /// Updates with the landmarks already mapped among `observations` in one stacked update,
    /// then maps the others; every Jacobian at `true_pose` and the true landmark centres.
    ///
    /// # Errors
    /// An observation of a landmark the world lacks or on the sensor, or a failed update; the
    /// state is then unchanged.
    pub fn observe(
        &mut self,
        observations: &[SimObservation],
        true_pose: [f64; 3],
    ) -> Result<(), IdealEkfError> {
        let pose = self.state.pose();
        let true_pose = filter_pose(true_pose);
        let mut rows = Vec::new();
        let mut unmapped = Vec::new();
        for observation in observations {
            let id = observation.landmark_id;
            let true_centre = *self
                .true_centres
                .get(&id)
                .ok_or(IdealEkfError::UnknownLandmark(id))?;
            let Some(&index) = self.mapped.get(&id) else {
                unmapped.push(observation);
                continue;
            };
            let estimated = self
                .sensor
                .predict(pose, self.state.landmark(index))
                .ok_or(IdealEkfError::OnTheSensor(id))?;
            let at_truth = self
                .sensor
                .predict(true_pose, true_centre)
                .ok_or(IdealEkfError::OnTheSensor(id))?;
            let measured = LandmarkObservation {
                range_m: observation.range_m,
                bearing_rad: observation.bearing_rad,
                diameter_m: None,
            };
            let innovation = RangeBearingModel::innovation(&measured, &estimated);
            rows.push((index, at_truth, innovation));
        }
        if !rows.is_empty() {
            let n = self.state.dim();
            let m = 2 * rows.len();
            let mut h = DMatrix::zeros(m, n);
            let mut innovation = DVector::zeros(m);
            let mut r = DMatrix::zeros(m, m);
            for (row, (index, at_truth, nu)) in rows.iter().enumerate() {
                let offset = self.state.landmark_offset(*index);
                h.view_mut((2 * row, 0), (2, 3)).copy_from(&at_truth.d_pose);
                h.view_mut((2 * row, offset), (2, 2))
                    .copy_from(&at_truth.d_landmark);
                innovation.fixed_rows_mut::<2>(2 * row).copy_from(nu);
                r.fixed_view_mut::<2, 2>(2 * row, 2 * row)
                    .copy_from(&self.sensor.noise());
            }
            self.state.update(&innovation, &h, &r)?;
        }
        let pose = self.state.pose();
        for observation in unmapped {
            let (position, _, _) =
                self.sensor
                    .landmark_position(pose, observation.range_m, observation.bearing_rad);
            let (_, d_pose, d_observation) = self.sensor.landmark_position(
                true_pose,
                observation.range_m,
                observation.bearing_rad,
            );
            let noise: Matrix2<f64> =
                d_observation * self.sensor.noise() * d_observation.transpose();
            let index = self.state.add_landmark(position, &d_pose, &noise);
            self.mapped.insert(observation.landmark_id, index);
        }
        Ok(())
    }

    /// The estimated robot pose and its covariance.
    pub fn pose(&self) -> (Pose2, Matrix3<f64>) {
        (self.state.pose(), self.state.pose_covariance())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmark_sim::{NoiseModel, pose_nees, simulate};
    use crate::world::{Scenario, WorldKind};

    /// Runs the ideal EKF over one simulated run: the mean NEES over the steps after the
    /// first, and the final position error.
    fn run(scenario: &Scenario, noise: &NoiseModel, seed: u64) -> (f64, f64) {
        let data = simulate(scenario, noise, seed).unwrap();
        let mut filter = IdealEkf::new(
            noise.motion_model(),
            noise.sensor_model(),
            scenario.landmarks(),
            data.initial_pose().unwrap(),
        );
        let (mut sum, mut error_m) = (0.0, 0.0);
        for (k, step) in data.steps.iter().enumerate() {
            if k > 0 {
                let input = DifferentialDriveInput {
                    speed_mps: step.odometry.speed_mps,
                    yaw_rate_radps: step.odometry.yaw_rate_radps,
                };
                filter.predict(&input, step.dt_s, data.steps[k - 1].true_pose);
            }
            filter.observe(&step.observations, step.true_pose).unwrap();
            let (pose, covariance) = filter.pose();
            let error = [
                pose.x_m - step.true_pose[0],
                pose.y_m - step.true_pose[1],
                pose.theta_rad - step.true_pose[2],
            ];
            if k > 0 {
                let rows = [0, 1, 2].map(|r| [0, 1, 2].map(|c| covariance[(r, c)]));
                sum += pose_nees(error, rows).unwrap();
            }
            error_m = error[0].hypot(error[1]);
        }
        (sum / (data.steps.len() - 1) as f64, error_m)
    }

    #[test]
    fn tracks_the_park_with_a_nees_near_the_state_dimension() {
        let scenario = Scenario::generate_for(WorldKind::Outdoor, 3, 30.0);
        let noise = NoiseModel::default();
        let runs = 10;
        let (mut nees_sum, mut worst_error_m) = (0.0, 0.0f64);
        for seed in 0..runs {
            let (nees, error_m) = run(&scenario, &noise, seed);
            nees_sum += nees;
            worst_error_m = worst_error_m.max(error_m);
        }
        let mean_nees = nees_sum / runs as f64;
        // Three degrees of freedom; ten runs of persistent errors scatter by some tenths.
        assert!((2.0..4.0).contains(&mean_nees), "mean NEES {mean_nees}");
        assert!(worst_error_m < 0.3, "final error {worst_error_m} m");
    }

    #[test]
    fn an_observation_of_a_landmark_the_world_lacks_is_an_error() {
        let noise = NoiseModel::default();
        let mut filter = IdealEkf::new(noise.motion_model(), noise.sensor_model(), &[], [0.0; 3]);
        let stray = SimObservation {
            landmark_id: 7,
            range_m: 5.0,
            bearing_rad: 0.0,
            diameter_m: 0.3,
        };
        assert!(matches!(
            filter.observe(&[stray], [0.0; 3]),
            Err(IdealEkfError::UnknownLandmark(7))
        ));
    }
}
