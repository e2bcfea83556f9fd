//! A precomputed, time-indexed robot trajectory with interpolated look-up.
//!
//! Samples are evenly spaced `step_s` apart from `t = 0`. [`Trajectory::pose_at`]
//! interpolates linearly between the two samples around `t_s` (the heading along the shorter
//! arc) and holds the first or last sample outside the covered span.

use super::robot_state::{RobotState, wrap_angle_rad};

/// The robot's true state sampled at a fixed step.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    step_s: f64,
    states: Vec<RobotState>,
}

impl Trajectory {
    /// A trajectory whose sample `i` is the state at `i · step_s` seconds.
    ///
    /// # Panics
    ///
    /// If `states` is empty or `step_s` is not positive and finite.
    pub fn from_samples(step_s: f64, states: Vec<RobotState>) -> Trajectory {
        assert!(!states.is_empty(), "a trajectory needs a sample");
        assert!(step_s.is_finite() && step_s > 0.0, "step must be positive");
        Trajectory { step_s, states }
    }

    /// Time between samples, seconds.
    pub fn step_s(&self) -> f64 {
        self.step_s
    }

    /// Time of the last sample, seconds.
    pub fn duration_s(&self) -> f64 {
        (self.states.len() - 1) as f64 * self.step_s
    }

    /// The samples; sample `i` is at `i · step_s()` seconds.
    pub fn states(&self) -> &[RobotState] {
        &self.states
    }

    /// The true state at `t_s` seconds, interpolated between samples; the first sample
    /// before `t = 0` and the last one after [`Self::duration_s`].
    pub fn pose_at(&self, t_s: f64) -> RobotState {
        let last = self.states.len() - 1;
        if t_s.is_nan() || t_s <= 0.0 {
            return self.states[0];
        }
        let position = t_s / self.step_s;
        let index = position.floor();
        if index >= last as f64 {
            return self.states[last];
        }
        let i = index as usize;
        let f = position - index;
        let (a, b) = (self.states[i], self.states[i + 1]);
        let lerp = |u: f64, v: f64| u + f * (v - u);
        RobotState {
            x_m: lerp(a.x_m, b.x_m),
            y_m: lerp(a.y_m, b.y_m),
            theta_rad: wrap_angle_rad(a.theta_rad + f * wrap_angle_rad(b.theta_rad - a.theta_rad)),
            speed_mps: lerp(a.speed_mps, b.speed_mps),
            yaw_rate_radps: lerp(a.yaw_rate_radps, b.yaw_rate_radps),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    #[test]
    fn interpolates_and_clamps() {
        let a = RobotState {
            x_m: 0.0,
            theta_rad: PI - 0.1,
            speed_mps: 1.0,
            ..RobotState::default()
        };
        let b = RobotState {
            x_m: 1.0,
            theta_rad: -PI + 0.1,
            speed_mps: 2.0,
            ..RobotState::default()
        };
        let trajectory = Trajectory::from_samples(0.5, vec![a, b]);
        assert_eq!(trajectory.duration_s(), 0.5);
        let mid = trajectory.pose_at(0.25);
        assert!((mid.x_m - 0.5).abs() < 1e-12);
        assert!((mid.speed_mps - 1.5).abs() < 1e-12);
        // Across ±π along the short way.
        assert!((mid.theta_rad.abs() - PI).abs() < 1e-9);
        assert_eq!(trajectory.pose_at(-3.0), a);
        assert_eq!(trajectory.pose_at(9.0), b);
        assert_eq!(trajectory.pose_at(f64::NAN), a);
    }
}
