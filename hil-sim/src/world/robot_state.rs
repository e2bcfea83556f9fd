//! The true kinematic state of the simulated robot at one instant.

pub use host::geometry::wrap_angle_rad;

use super::pose::SensorPose;

/// The robot's pose and velocities in the world frame (see [`super`] for the frame).
///
/// The robot frame has its origin at the centre of the drive axle, `x` forward, `y` left.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RobotState {
    /// East coordinate of the robot origin, metres.
    pub x_m: f64,
    /// North coordinate of the robot origin, metres.
    pub y_m: f64,
    /// Heading of the robot's forward axis, radians counter-clockwise from `+x`, in
    /// `(-π, π]`.
    pub theta_rad: f64,
    /// Forward speed, metres per second.
    pub speed_mps: f64,
    /// Turn rate, radians per second, counter-clockwise positive.
    pub yaw_rate_radps: f64,
}

impl RobotState {
    /// The position as an array, metres.
    pub const fn position_m(&self) -> [f64; 2] {
        [self.x_m, self.y_m]
    }

    /// The pose of the laser, which is mounted at the robot origin facing forward.
    pub const fn sensor_pose(&self) -> SensorPose {
        SensorPose::new(self.x_m, self.y_m, self.theta_rad)
    }
}

impl From<RobotState> for SensorPose {
    /// The laser pose of [`RobotState::sensor_pose`].
    fn from(state: RobotState) -> SensorPose {
        state.sensor_pose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    #[test]
    fn wraps_into_half_open_interval() {
        assert!((wrap_angle_rad(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle_rad(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle_rad(-0.5) + 0.5).abs() < 1e-15);
        assert!((wrap_angle_rad(7.0) - (7.0 - 2.0 * PI)).abs() < 1e-12);
    }

    #[test]
    fn laser_at_robot_origin() {
        let state = RobotState {
            x_m: 1.0,
            y_m: 2.0,
            theta_rad: 0.5,
            ..RobotState::default()
        };
        assert_eq!(SensorPose::from(state), SensorPose::new(1.0, 2.0, 0.5));
    }
}
