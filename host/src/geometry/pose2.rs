//! A rigid transform of the plane, used both as a pose and as a change of frame.
//!
//! Frames follow the robot convention: x forward, y left, theta counter-clockwise from x, all in
//! metres and radians. A value named `a_from_b` maps points expressed in frame `b` into frame
//! `a`; the pose of the robot in the map, `pose_in_map`, is the same thing as `map_from_robot`.
//! Composition reads like the names: `map_from_robot * robot_from_sensor` is `map_from_sensor`.

use std::f64::consts::{PI, TAU};
use std::ops::Mul;

/// A rotation by `theta_rad` followed by a translation by (`x_m`, `y_m`).
///
/// As `a_from_b`, it maps `point_in_b` to `point_in_a = R(theta_rad) * point_in_b + (x_m, y_m)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose2 {
    /// Translation along x of the target frame, in metres.
    pub x_m: f64,
    /// Translation along y of the target frame, in metres.
    pub y_m: f64,
    /// Rotation, counter-clockwise, in radians; kept in `(-pi, pi]` by [`Pose2::new`] and `*`.
    pub theta_rad: f64,
}

impl Pose2 {
    /// The identity transform.
    pub const IDENTITY: Pose2 = Pose2 {
        x_m: 0.0,
        y_m: 0.0,
        theta_rad: 0.0,
    };

    /// Builds a transform, wrapping `theta_rad` into `(-pi, pi]`.
    pub fn new(x_m: f64, y_m: f64, theta_rad: f64) -> Self {
        Pose2 {
            x_m,
            y_m,
            theta_rad: wrap_angle_rad(theta_rad),
        }
    }

    /// Maps `point_in_b` (metres) through this `a_from_b` transform, giving the point in `a`.
    pub fn transform_point(&self, point_in_b: [f64; 2]) -> [f64; 2] {
        let (sin, cos) = self.theta_rad.sin_cos();
        [
            cos * point_in_b[0] - sin * point_in_b[1] + self.x_m,
            sin * point_in_b[0] + cos * point_in_b[1] + self.y_m,
        ]
    }

    /// Composes this `a_from_b` with `b_from_c` into `a_from_c` (also written `a_from_b * b_from_c`).
    pub fn compose(&self, b_from_c: Pose2) -> Pose2 {
        let [x_m, y_m] = self.transform_point([b_from_c.x_m, b_from_c.y_m]);
        Pose2::new(x_m, y_m, self.theta_rad + b_from_c.theta_rad)
    }

    /// The inverse transform: `b_from_a` for this `a_from_b`.
    pub fn inverse(&self) -> Pose2 {
        let (sin, cos) = self.theta_rad.sin_cos();
        Pose2::new(
            -(cos * self.x_m + sin * self.y_m),
            sin * self.x_m - cos * self.y_m,
            -self.theta_rad,
        )
    }
}

impl Mul for Pose2 {
    type Output = Pose2;

    /// Composes `a_from_b * b_from_c` into `a_from_c`; see [`Pose2::compose`].
    fn mul(self, b_from_c: Pose2) -> Pose2 {
        self.compose(b_from_c)
    }
}

/// Wraps an angle into `(-pi, pi]`; non-finite angles are returned unchanged.
pub fn wrap_angle_rad(angle_rad: f64) -> f64 {
    if !angle_rad.is_finite() {
        return angle_rad;
    }
    let wrapped = (angle_rad + PI).rem_euclid(TAU) - PI;
    if wrapped == -PI { PI } else { wrapped }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_close(a: Pose2, b: Pose2) {
        assert!((a.x_m - b.x_m).abs() < 1e-12, "{a:?} != {b:?}");
        assert!((a.y_m - b.y_m).abs() < 1e-12, "{a:?} != {b:?}");
        assert!((a.theta_rad - b.theta_rad).abs() < 1e-12, "{a:?} != {b:?}");
    }

    #[test]
    fn test_transform_point_rotates_then_translates() {
        let map_from_robot = Pose2::new(1.0, 2.0, PI / 2.0);
        let [x, y] = map_from_robot.transform_point([1.0, 0.0]);
        assert!((x - 1.0).abs() < 1e-12 && (y - 3.0).abs() < 1e-12);
    }

    #[test]
    fn test_compose_matches_point_mapping() {
        let a_from_b = Pose2::new(0.5, -1.0, 0.3);
        let b_from_c = Pose2::new(2.0, 0.25, -1.1);
        let point_in_c = [0.7, -0.2];
        let direct = (a_from_b * b_from_c).transform_point(point_in_c);
        let stepwise = a_from_b.transform_point(b_from_c.transform_point(point_in_c));
        assert!((direct[0] - stepwise[0]).abs() < 1e-12);
        assert!((direct[1] - stepwise[1]).abs() < 1e-12);
    }

    #[test]
    fn test_inverse() {
        let a_from_b = Pose2::new(0.5, -1.0, 2.9);
        assert_close(a_from_b * a_from_b.inverse(), Pose2::IDENTITY);
        assert_close(a_from_b.inverse() * a_from_b, Pose2::IDENTITY);
    }

    #[test]
    fn test_angle_wraps() {
        assert!((Pose2::new(0.0, 0.0, 3.0 * PI).theta_rad - PI).abs() < 1e-12);
        assert!((Pose2::new(0.0, 0.0, -PI).theta_rad - PI).abs() < 1e-12);
    }
}
