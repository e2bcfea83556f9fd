//! The exact arc motion model of a differential-drive robot and its inverse.
//!
//! Driving at constant forward speed `v` and yaw rate `ω` for `dt` seconds from
//! `(x, y, θ)` ends at
//!
//! ```text
//! x' = x + v/ω (sin(θ + ω dt) − sin θ)
//! y' = y − v/ω (cos(θ + ω dt) − cos θ)
//! θ' = θ + ω dt
//! ```
//!
//! (a straight line of length `v dt` along `θ` when `ω = 0`). The code evaluates the same
//! formula in chord form, `x' = x + v dt sinc(ω dt / 2) cos(θ + ω dt / 2)` and likewise for
//! `y'` with `sin`, where `sinc(u) = sin(u) / u`: identical for every `ω ≠ 0`, and continuous
//! and free of cancellation as `ω → 0`, so no threshold switches to the straight line.
//!
//! [`arc_odometry`] inverts it: the speed and yaw rate whose arc turns exactly from one
//! heading to another and lands as close as an arc can to the end position.

use super::simulated_run::OdometryInput;
use crate::world::robot_state::wrap_angle_rad;

/// The pose after driving `odometry` for `dt_s` seconds from `pose` (`[x_m, y_m, theta_rad]`,
/// world frame) along the exact arc; the heading is wrapped into `(-π, π]`.
pub fn arc_step(pose: [f64; 3], odometry: OdometryInput, dt_s: f64) -> [f64; 3] {
    let [x_m, y_m, theta_rad] = pose;
    let turn_rad = odometry.yaw_rate_radps * dt_s;
    let chord_m = odometry.speed_mps * dt_s * sinc(0.5 * turn_rad);
    let (sin, cos) = (theta_rad + 0.5 * turn_rad).sin_cos();
    [
        x_m + chord_m * cos,
        y_m + chord_m * sin,
        wrap_angle_rad(theta_rad + turn_rad),
    ]
}

/// The odometry whose arc over `dt_s` seconds starts at `from` and ends at `to` (both
/// `[x_m, y_m, theta_rad]`, world frame).
///
/// The yaw rate turns `from`'s heading into `to`'s along the shorter way, exactly. An arc
/// with that turn can only move along one direction (the chord at `θ + ω dt / 2`), so the
/// speed is the one whose end position is nearest `to`: it reaches `to` exactly when `to`
/// lies on that chord line, as it does for any pose [`arc_step`] produced. The part of the
/// displacement across the chord is what an arc cannot represent; it is left out.
///
/// # Panics
///
/// In debug builds, if `dt_s` is not positive.
pub fn arc_odometry(from: [f64; 3], to: [f64; 3], dt_s: f64) -> OdometryInput {
    debug_assert!(dt_s > 0.0, "odometry interval must be positive");
    let turn_rad = wrap_angle_rad(to[2] - from[2]);
    let (sin, cos) = (from[2] + 0.5 * turn_rad).sin_cos();
    let along_m = (to[0] - from[0]) * cos + (to[1] - from[1]) * sin;
    // |turn| ≤ π, so sinc(turn / 2) ≥ 2/π: no division by zero.
    OdometryInput {
        speed_mps: along_m / (dt_s * sinc(0.5 * turn_rad)),
        yaw_rate_radps: turn_rad / dt_s,
    }
}

/// `sin(u) / u`, and 1 at `u = 0` (its Taylor series below 1e-4, where it is exact to
/// rounding).
fn sinc(u: f64) -> f64 {
    if u.abs() < 1e-4 {
        1.0 - u * u / 6.0
    } else {
        u.sin() / u
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The textbook form from the module documentation.
    fn textbook(pose: [f64; 3], v: f64, w: f64, dt: f64) -> [f64; 3] {
        let [x, y, th] = pose;
        [
            x + v / w * ((th + w * dt).sin() - th.sin()),
            y - v / w * ((th + w * dt).cos() - th.cos()),
            wrap_angle_rad(th + w * dt),
        ]
    }

    #[test]
    fn matches_the_textbook_arc_and_the_straight_line() {
        let pose = [3.0, -2.0, 2.5];
        for (v, w) in [
            (1.5, 0.7),
            (2.0, -0.3),
            (0.0, 1.0),
            (-0.5, 2.0),
            (1.0, 1e-3),
        ] {
            let odometry = OdometryInput {
                speed_mps: v,
                yaw_rate_radps: w,
            };
            let got = arc_step(pose, odometry, 0.2);
            let want = textbook(pose, v, w, 0.2);
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-12,
                    "{v} {w}: {got:?} {want:?}"
                );
            }
        }
        let straight = OdometryInput {
            speed_mps: 2.0,
            yaw_rate_radps: 0.0,
        };
        let end = arc_step([1.0, 1.0, PI / 2.0], straight, 0.5);
        assert!((end[0] - 1.0).abs() < 1e-15 && (end[1] - 2.0).abs() < 1e-15);
        assert_eq!(end[2], PI / 2.0);
    }

    #[test]
    fn a_quarter_circle_ends_where_it_should() {
        // Radius 2 m, a quarter turn to the left from the origin facing +x.
        let odometry = OdometryInput {
            speed_mps: PI,
            yaw_rate_radps: PI / 2.0,
        };
        let end = arc_step([0.0, 0.0, 0.0], odometry, 1.0);
        assert!((end[0] - 2.0).abs() < 1e-12 && (end[1] - 2.0).abs() < 1e-12);
        assert!((end[2] - PI / 2.0).abs() < 1e-12);
    }

    #[test]
    fn odometry_inverts_the_step() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for _ in 0..1000 {
            let from = [
                rng.random_range(-50.0..50.0),
                rng.random_range(-50.0..50.0),
                rng.random_range(-PI..PI),
            ];
            let odometry = OdometryInput {
                speed_mps: rng.random_range(-3.0..3.0),
                yaw_rate_radps: rng.random_range(-4.0..4.0),
            };
            let dt_s = rng.random_range(0.01..0.5);
            let to = arc_step(from, odometry, dt_s);
            let back = arc_odometry(from, to, dt_s);
            assert!(
                (back.speed_mps - odometry.speed_mps).abs() < 1e-9,
                "{back:?}"
            );
            assert!((back.yaw_rate_radps - odometry.yaw_rate_radps).abs() < 1e-9);
        }
    }

    #[test]
    fn heading_wraps_the_short_way() {
        let from = [0.0, 0.0, PI - 0.05];
        let to = [0.0, 0.0, -PI + 0.05];
        let odometry = arc_odometry(from, to, 0.1);
        assert!((odometry.yaw_rate_radps - 1.0).abs() < 1e-9);
        assert_eq!(odometry.speed_mps, 0.0);
    }
}
