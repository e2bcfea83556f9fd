//! Constant-velocity motion for runs without odometry: the robot block carries its own
//! forward speed and turn rate, which drift as white-noise accelerations.

use nalgebra::{DMatrix, DVector};

use super::motion_model::{MotionModel, MotionPrediction, midpoint_step};
use crate::geometry::Pose2;

/// Robot block `[x_m, y_m, theta_rad, speed_mps, yaw_rate_radps]` moved at constant velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantVelocityModel {
    /// Spectral density of the forward acceleration noise, m/s² per √Hz.
    pub sigma_acceleration_mps2: f64,
    /// Spectral density of the angular acceleration noise, rad/s² per √Hz.
    pub sigma_yaw_acceleration_radps2: f64,
    /// Prior standard deviation of the speed when a run starts, m/s.
    pub initial_sigma_speed_mps: f64,
    /// Prior standard deviation of the turn rate when a run starts, rad/s.
    pub initial_sigma_yaw_rate_radps: f64,
}

impl Default for ConstantVelocityModel {
    /// 0.5 m/s² and 0.5 rad/s² per √Hz; at rest within 1 m/s and 0.5 rad/s.
    fn default() -> Self {
        ConstantVelocityModel {
            sigma_acceleration_mps2: 0.5,
            sigma_yaw_acceleration_radps2: 0.5,
            initial_sigma_speed_mps: 1.0,
            initial_sigma_yaw_rate_radps: 0.5,
        }
    }
}

impl MotionModel for ConstantVelocityModel {
    type Input = ();

    fn robot_dim(&self) -> usize {
        5
    }

    fn initial_robot(&self, pose: Pose2) -> (DVector<f64>, DMatrix<f64>) {
        let mean = DVector::from_vec(vec![pose.x_m, pose.y_m, pose.theta_rad, 0.0, 0.0]);
        let mut covariance = DMatrix::zeros(5, 5);
        covariance[(3, 3)] = self.initial_sigma_speed_mps.powi(2);
        covariance[(4, 4)] = self.initial_sigma_yaw_rate_radps.powi(2);
        (mean, covariance)
    }

    fn predict(&self, robot: &DVector<f64>, _input: &(), dt_s: f64) -> MotionPrediction {
        let pose = Pose2 {
            x_m: robot[0],
            y_m: robot[1],
            theta_rad: robot[2],
        };
        let (speed, yaw_rate) = (robot[3], robot[4]);
        let (next, d) = midpoint_step(pose, speed, yaw_rate, dt_s);
        let mut f = DMatrix::identity(5, 5);
        for row in 0..3 {
            f[(row, 2)] = d[row][0];
            f[(row, 3)] = d[row][1];
            f[(row, 4)] = d[row][2];
        }
        let mut q = DMatrix::zeros(5, 5);
        q[(3, 3)] = self.sigma_acceleration_mps2.powi(2) * dt_s;
        q[(4, 4)] = self.sigma_yaw_acceleration_radps2.powi(2) * dt_s;
        MotionPrediction {
            robot: DVector::from_vec(vec![next.x_m, next.y_m, next.theta_rad, speed, yaw_rate]),
            f,
            q,
        }
    }
}
