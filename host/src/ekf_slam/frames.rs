//! Pose composition with its Jacobians: the building block of the motion and observation
//! models and of map joining.
//!
//! A pose is a [`Pose2`], read as `a_from_b`: composing `a_from_b ⊕ b_from_c` gives
//! `a_from_c`, and `a_from_b ⊕ point_in_b` gives `point_in_a`. The Jacobians are those of
//! Smith, Self and Cheeseman's compounding operator, with respect to (`x_m`, `y_m`,
//! `theta_rad`) in that order.
//!
//! The filter's results depend on the exact floating-point expressions here (the translation
//! first, then the rotated terms; the angle wrapped once), which are not the order of
//! [`Pose2::transform_point`] and [`Pose2::compose`]. The inverse is [`Pose2::inverse`], whose
//! expressions are the ones the filter has always used.

use nalgebra::{Matrix2, Matrix2x3, Matrix3};

use crate::geometry::{Pose2, wrap_angle_rad};

/// `a_from_c = a_from_b ⊕ b_from_c`, with the Jacobians with respect to `a_from_b` and to
/// `b_from_c`.
pub fn compose_pose(a_from_b: Pose2, b_from_c: Pose2) -> (Pose2, Matrix3<f64>, Matrix3<f64>) {
    let (sin, cos) = a_from_b.theta_rad.sin_cos();
    let Pose2 {
        x_m: x,
        y_m: y,
        theta_rad: theta,
    } = b_from_c;
    let a_from_c = Pose2 {
        x_m: a_from_b.x_m + cos * x - sin * y,
        y_m: a_from_b.y_m + sin * x + cos * y,
        theta_rad: wrap_angle_rad(a_from_b.theta_rad + theta),
    };
    #[rustfmt::skip]
    let d_a = Matrix3::new(
        1.0, 0.0, -sin * x - cos * y,
        0.0, 1.0, cos * x - sin * y,
        0.0, 0.0, 1.0,
    );
    #[rustfmt::skip]
    let d_b = Matrix3::new(
        cos, -sin, 0.0,
        sin, cos, 0.0,
        0.0, 0.0, 1.0,
    );
    (a_from_c, d_a, d_b)
}

/// `point_in_a = a_from_b ⊕ point_in_b`, with the Jacobians with respect to `a_from_b`
/// (2 × 3) and to `point_in_b` (2 × 2, the rotation).
pub fn transform_point(
    a_from_b: Pose2,
    point_in_b: [f64; 2],
) -> ([f64; 2], Matrix2x3<f64>, Matrix2<f64>) {
    let (sin, cos) = a_from_b.theta_rad.sin_cos();
    let [x, y] = point_in_b;
    let point_in_a = [
        a_from_b.x_m + cos * x - sin * y,
        a_from_b.y_m + sin * x + cos * y,
    ];
    #[rustfmt::skip]
    let d_pose = Matrix2x3::new(
        1.0, 0.0, -sin * x - cos * y,
        0.0, 1.0, cos * x - sin * y,
    );
    let d_point = Matrix2::new(cos, -sin, sin, cos);
    (point_in_a, d_pose, d_point)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numeric_jacobian(f: impl Fn(&[f64]) -> Vec<f64>, at: &[f64]) -> Vec<Vec<f64>> {
        let eps = 1e-6;
        let base = f(at);
        (0..base.len())
            .map(|row| {
                (0..at.len())
                    .map(|col| {
                        let mut plus = at.to_vec();
                        plus[col] += eps;
                        let mut minus = at.to_vec();
                        minus[col] -= eps;
                        (f(&plus)[row] - f(&minus)[row]) / (2.0 * eps)
                    })
                    .collect()
            })
            .collect()
    }

    /// The pose held in `v[0..3]`.
    fn pose(v: &[f64]) -> Pose2 {
        Pose2 {
            x_m: v[0],
            y_m: v[1],
            theta_rad: v[2],
        }
    }

    /// `[x_m, y_m, theta_rad]` of `p`.
    fn entries(p: Pose2) -> Vec<f64> {
        vec![p.x_m, p.y_m, p.theta_rad]
    }

    #[test]
    fn compose_jacobians_match_finite_differences() {
        let a = pose(&[1.0, -2.0, 0.7]);
        let b = pose(&[0.5, 0.3, -0.2]);
        let (_, d_a, d_b) = compose_pose(a, b);
        let num_a = numeric_jacobian(|v| entries(compose_pose(pose(v), b).0), &entries(a));
        let num_b = numeric_jacobian(|v| entries(compose_pose(a, pose(v)).0), &entries(b));
        for r in 0..3 {
            for c in 0..3 {
                assert!((d_a[(r, c)] - num_a[r][c]).abs() < 1e-6);
                assert!((d_b[(r, c)] - num_b[r][c]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn point_jacobians_match_finite_differences() {
        let a = pose(&[1.0, -2.0, 2.7]);
        let p = [4.0, -1.5];
        let (_, d_pose, d_point) = transform_point(a, p);
        let num_pose = numeric_jacobian(|v| transform_point(pose(v), p).0.to_vec(), &entries(a));
        let num_point = numeric_jacobian(|v| transform_point(a, [v[0], v[1]]).0.to_vec(), &p);
        for r in 0..2 {
            for c in 0..3 {
                assert!((d_pose[(r, c)] - num_pose[r][c]).abs() < 1e-6);
            }
            for c in 0..2 {
                assert!((d_point[(r, c)] - num_point[r][c]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn inverse_composes_to_identity() {
        let a = pose(&[3.0, 1.0, -2.9]);
        let (identity, _, _) = compose_pose(a, a.inverse());
        assert!(entries(identity).iter().all(|v| v.abs() < 1e-12));
    }
}
