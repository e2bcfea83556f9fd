//! The motion-model interface of the EKF: how the robot block moves over one time step.
//!
//! A model owns the robot block's layout beyond the pose (`[x_m, y_m, theta_rad]` always come
//! first): odometry calibration entries, or velocities for the constant-velocity model. It
//! returns the predicted robot block, the Jacobian `F` with respect to the robot block, and
//! the process noise already mapped into robot coordinates (`G Q Gᵀ`).

use nalgebra::{DMatrix, DVector};

use crate::geometry::{Pose2, wrap_angle_rad};

/// The outcome of one motion step.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionPrediction {
    /// The predicted robot block.
    pub robot: DVector<f64>,
    /// Jacobian of the prediction with respect to the robot block.
    pub f: DMatrix<f64>,
    /// Process noise in robot coordinates.
    pub q: DMatrix<f64>,
}

/// A model that moves the robot block over `dt_s` seconds given an input.
pub trait MotionModel {
    /// What drives the model over a step (odometry, or nothing).
    type Input: Copy + core::fmt::Debug;

    /// Entries of the robot block (three or more).
    fn robot_dim(&self) -> usize;

    /// Mean and covariance of the robot block at `pose` (known exactly) when a run starts,
    /// with the model's own entries at their priors.
    fn initial_robot(&self, pose: Pose2) -> (DVector<f64>, DMatrix<f64>);

    /// Predicts `robot` over `dt_s` seconds driven by `input`.
    fn predict(&self, robot: &DVector<f64>, input: &Self::Input, dt_s: f64) -> MotionPrediction;
}

/// Moves a pose along the arc of speed `speed_mps` and turn rate `yaw_rate_radps` over `dt_s`
/// with the mid-point heading, and returns the new pose and the derivatives of the new pose
/// (rows: `x_m`, `y_m`, `theta_rad`) with respect to heading, speed and turn rate (columns).
pub(crate) fn midpoint_step(
    pose: Pose2,
    speed_mps: f64,
    yaw_rate_radps: f64,
    dt_s: f64,
) -> (Pose2, [[f64; 3]; 3]) {
    let phi = pose.theta_rad + 0.5 * yaw_rate_radps * dt_s;
    let (sin, cos) = phi.sin_cos();
    let next = Pose2 {
        x_m: pose.x_m + speed_mps * dt_s * cos,
        y_m: pose.y_m + speed_mps * dt_s * sin,
        theta_rad: wrap_angle_rad(pose.theta_rad + yaw_rate_radps * dt_s),
    };
    // Columns: d/dtheta, d/dspeed, d/dyaw_rate; rows: x, y, theta.
    let d = [
        [
            -speed_mps * dt_s * sin,
            dt_s * cos,
            -speed_mps * dt_s * sin * 0.5 * dt_s,
        ],
        [
            speed_mps * dt_s * cos,
            dt_s * sin,
            speed_mps * dt_s * cos * 0.5 * dt_s,
        ],
        [1.0, 0.0, dt_s],
    ];
    (next, d)
}
