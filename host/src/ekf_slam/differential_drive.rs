//! Odometry-driven motion of a differential-drive robot: measured forward speed and turn rate.

use nalgebra::{DMatrix, DVector};

use super::motion_model::{MotionModel, MotionPrediction, midpoint_step};
use crate::geometry::Pose2;

/// Forward speed and turn rate measured by wheel odometry over one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DifferentialDriveInput {
    /// Forward speed, metres per second.
    pub speed_mps: f64,
    /// Turn rate, radians per second, counter-clockwise.
    pub yaw_rate_radps: f64,
}

/// A differential-drive robot whose pose is moved by odometry; the robot block is the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DifferentialDriveModel {
    /// Standard deviation of the measured speed, metres per second.
    pub sigma_speed_mps: f64,
    /// Standard deviation of the measured turn rate, radians per second.
    pub sigma_yaw_rate_radps: f64,
    /// Extra speed standard deviation per unit of measured speed (slip grows with speed).
    pub sigma_speed_per_speed: f64,
    /// Extra turn-rate standard deviation per unit of measured turn rate.
    pub sigma_yaw_rate_per_yaw_rate: f64,
    /// Position noise the two inputs cannot express (sideways slip), metres per √s. It also
    /// keeps the pose covariance full rank when the robot stands still.
    pub sigma_slip_m_per_sqrt_s: f64,
}

impl Default for DifferentialDriveModel {
    /// 0.05 m/s + 2 % and 1°/s + 2 %, slip 2 mm/√s.
    fn default() -> Self {
        DifferentialDriveModel {
            sigma_speed_mps: 0.05,
            sigma_yaw_rate_radps: 1f64.to_radians(),
            sigma_speed_per_speed: 0.02,
            sigma_yaw_rate_per_yaw_rate: 0.02,
            sigma_slip_m_per_sqrt_s: 0.002,
        }
    }
}

impl MotionModel for DifferentialDriveModel {
    type Input = DifferentialDriveInput;

    fn robot_dim(&self) -> usize {
        3
    }

    fn initial_robot(&self, pose: Pose2) -> (DVector<f64>, DMatrix<f64>) {
        (
            DVector::from_row_slice(&[pose.x_m, pose.y_m, pose.theta_rad]),
            DMatrix::zeros(3, 3),
        )
    }

    fn predict(
        &self,
        robot: &DVector<f64>,
        input: &DifferentialDriveInput,
        dt_s: f64,
    ) -> MotionPrediction {
        let pose = Pose2 {
            x_m: robot[0],
            y_m: robot[1],
            theta_rad: robot[2],
        };
        let (next, d) = midpoint_step(pose, input.speed_mps, input.yaw_rate_radps, dt_s);
        let mut f = DMatrix::identity(3, 3);
        let mut g = DMatrix::zeros(3, 2);
        for row in 0..3 {
            f[(row, 2)] = d[row][0];
            g[(row, 0)] = d[row][1];
            g[(row, 1)] = d[row][2];
        }
        let sigma_speed = self.sigma_speed_mps + self.sigma_speed_per_speed * input.speed_mps.abs();
        let sigma_yaw_rate = self.sigma_yaw_rate_radps
            + self.sigma_yaw_rate_per_yaw_rate * input.yaw_rate_radps.abs();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![
            sigma_speed.powi(2),
            sigma_yaw_rate.powi(2),
        ]));
        let mut q = &g * noise * g.transpose();
        let slip = self.sigma_slip_m_per_sqrt_s.powi(2) * dt_s;
        q[(0, 0)] += slip;
        q[(1, 1)] += slip;
        MotionPrediction {
            robot: DVector::from_row_slice(&[next.x_m, next.y_m, next.theta_rad]),
            q,
            f,
        }
    }
}
