//! A unicycle robot driven round a [`Route`] by a pure-pursuit controller.
//!
//! Pure pursuit (Coulter, "Implementation of the Pure Pursuit Path Tracking Algorithm",
//! CMU-RI-TR-92-01): the robot tracks a carrot `lookahead_m` ahead along the route of its own
//! projection onto it, steering on the arc through the carrot, curvature `2 sin α / d`
//! (`α` the carrot's bearing, `d` its distance). The speed set-point is the maximum speed,
//! lowered so the turn rate of that arc stays within its limit and scaled by `cos α` (the
//! robot turns on the spot when the carrot is beside or behind it). Speed and turn rate then
//! follow their set-points within the acceleration limits, and the unicycle is integrated
//! with the midpoint heading at a fixed step.
//!
//! The robot starts at rest on the first waypoint facing along the first leg, and keeps
//! driving laps until the requested duration.

use super::robot_state::{RobotState, wrap_angle_rad};
use super::route::Route;
use super::trajectory::Trajectory;

/// Limits and gains of the simulated robot and its controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PurePursuit {
    /// Top forward speed, metres per second.
    pub max_speed_mps: f64,
    /// Largest change of forward speed, metres per second squared.
    pub max_accel_mps2: f64,
    /// Top turn rate, radians per second.
    pub max_yaw_rate_radps: f64,
    /// Largest change of turn rate, radians per second squared.
    pub max_yaw_accel_radps2: f64,
    /// Distance along the route from the robot's projection to the carrot, metres.
    pub lookahead_m: f64,
    /// Integration and sampling step, seconds.
    pub step_s: f64,
}

impl PurePursuit {
    /// An office robot: 0.8 m/s, 1 rad/s, 1 m lookahead, 10 ms step.
    pub const fn indoor() -> PurePursuit {
        PurePursuit {
            max_speed_mps: 0.8,
            max_accel_mps2: 0.5,
            max_yaw_rate_radps: 1.0,
            max_yaw_accel_radps2: 3.0,
            lookahead_m: 1.0,
            step_s: 0.01,
        }
    }

    /// A field robot: 2 m/s, 0.8 rad/s, 3 m lookahead, 10 ms step.
    pub const fn outdoor() -> PurePursuit {
        PurePursuit {
            max_speed_mps: 2.0,
            max_accel_mps2: 0.6,
            max_yaw_rate_radps: 0.8,
            max_yaw_accel_radps2: 2.0,
            lookahead_m: 3.0,
            step_s: 0.01,
        }
    }

    /// Drives round `route` for `duration_s` seconds (at least one step) and records the
    /// state at every step.
    pub fn drive(&self, route: &Route, duration_s: f64) -> Trajectory {
        let dt_s = self.step_s;
        let steps = (duration_s / dt_s).ceil().max(1.0) as usize;
        let start_m = route.point_at(0.0);
        let start_dir = route.direction_at(0.0);
        let mut state = RobotState {
            x_m: start_m[0],
            y_m: start_m[1],
            theta_rad: start_dir[1].atan2(start_dir[0]),
            speed_mps: 0.0,
            yaw_rate_radps: 0.0,
        };
        // Turning on the spot uses the curvature command at this speed.
        let min_turn_speed_mps = 0.25 * self.max_speed_mps;
        let window_m = (2.0 * self.lookahead_m).max(1.0);
        let mut progress_m = 0.0_f64;
        let mut states = Vec::with_capacity(steps + 1);
        states.push(state);
        for _ in 0..steps {
            progress_m = route
                .project_forward(state.position_m(), progress_m, window_m)
                .max(progress_m);
            let carrot_m = route.point_at(progress_m + self.lookahead_m);
            let dx_m = carrot_m[0] - state.x_m;
            let dy_m = carrot_m[1] - state.y_m;
            let alpha_rad = wrap_angle_rad(dy_m.atan2(dx_m) - state.theta_rad);
            let curvature_per_m = 2.0 * alpha_rad.sin() / dx_m.hypot(dy_m).max(1e-3);

            let turn_limited_mps = self.max_yaw_rate_radps / curvature_per_m.abs().max(1e-9);
            let speed_set_mps = self.max_speed_mps.min(turn_limited_mps) * alpha_rad.cos().max(0.0);
            let yaw_rate_set_radps = (state.speed_mps.max(min_turn_speed_mps) * curvature_per_m)
                .clamp(-self.max_yaw_rate_radps, self.max_yaw_rate_radps);

            let speed_mps = approach(state.speed_mps, speed_set_mps, self.max_accel_mps2 * dt_s);
            let yaw_rate_radps = approach(
                state.yaw_rate_radps,
                yaw_rate_set_radps,
                self.max_yaw_accel_radps2 * dt_s,
            );
            let mid_theta_rad = state.theta_rad + 0.5 * yaw_rate_radps * dt_s;
            state = RobotState {
                x_m: state.x_m + speed_mps * dt_s * mid_theta_rad.cos(),
                y_m: state.y_m + speed_mps * dt_s * mid_theta_rad.sin(),
                theta_rad: wrap_angle_rad(state.theta_rad + yaw_rate_radps * dt_s),
                speed_mps,
                yaw_rate_radps,
            };
            states.push(state);
        }
        Trajectory::from_samples(dt_s, states)
    }
}

/// `value` moved towards `target` by at most `max_change`.
fn approach(value: f64, target: f64, max_change: f64) -> f64 {
    value + (target - value).clamp(-max_change, max_change)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drives_a_square_within_limits() {
        let route = Route::closed(vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]);
        let controller = PurePursuit::indoor();
        let trajectory = controller.drive(&route, 120.0);
        let states = trajectory.states();
        for pair in states.windows(2) {
            let dv = (pair[1].speed_mps - pair[0].speed_mps).abs();
            assert!(dv <= controller.max_accel_mps2 * controller.step_s + 1e-12);
            assert!(pair[1].speed_mps <= controller.max_speed_mps + 1e-12);
            assert!(pair[1].yaw_rate_radps.abs() <= controller.max_yaw_rate_radps + 1e-12);
        }
        // Never strays far from the square's outline.
        for state in states.iter().step_by(10) {
            assert!(route.distance_m(state.position_m()) < 0.4, "{state:?}");
        }
        // One lap of 40 m at up to 0.8 m/s takes a little over 50 s; two minutes is two laps.
        let back_home = states[states.len() / 2..]
            .iter()
            .any(|s| s.x_m.hypot(s.y_m) < 0.5);
        assert!(back_home);
    }
}
