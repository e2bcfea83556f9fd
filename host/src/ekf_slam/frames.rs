//! Pose composition with its Jacobians: the building block of the motion and observation
//! models and of map joining.
//!
//! A pose is `[x_m, y_m, theta_rad]`, read as `a_from_b` (see [`crate::geometry::Pose2`]):
//! composing `a_from_b ⊕ b_from_c` gives `a_from_c`, and `a_from_b ⊕ point_in_b` gives
//! `point_in_a`. The Jacobians are those of Smith, Self and Cheeseman's compounding operator.

use nalgebra::{Matrix2, Matrix2x3, Matrix3};

use crate::geometry::wrap_angle_rad;

/// `a_from_c = a_from_b ⊕ b_from_c`, with the Jacobians with respect to `a_from_b` and to
/// `b_from_c`.
pub fn compose_pose(
    a_from_b: [f64; 3],
    b_from_c: [f64; 3],
) -> ([f64; 3], Matrix3<f64>, Matrix3<f64>) {
    let (sin, cos) = a_from_b[2].sin_cos();
    let [x, y, theta] = b_from_c;
    let a_from_c = [
        a_from_b[0] + cos * x - sin * y,
        a_from_b[1] + sin * x + cos * y,
        wrap_angle_rad(a_from_b[2] + theta),
    ];
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
    a_from_b: [f64; 3],
    point_in_b: [f64; 2],
) -> ([f64; 2], Matrix2x3<f64>, Matrix2<f64>) {
    let (sin, cos) = a_from_b[2].sin_cos();
    let [x, y] = point_in_b;
    let point_in_a = [
        a_from_b[0] + cos * x - sin * y,
        a_from_b[1] + sin * x + cos * y,
    ];
    #[rustfmt::skip]
    let d_pose = Matrix2x3::new(
        1.0, 0.0, -sin * x - cos * y,
        0.0, 1.0, cos * x - sin * y,
    );
    let d_point = Matrix2::new(cos, -sin, sin, cos);
    (point_in_a, d_pose, d_point)
}

/// `b_from_a` for `a_from_b`.
pub fn invert_pose(a_from_b: [f64; 3]) -> [f64; 3] {
    let (sin, cos) = a_from_b[2].sin_cos();
    [
        -(cos * a_from_b[0] + sin * a_from_b[1]),
        sin * a_from_b[0] - cos * a_from_b[1],
        wrap_angle_rad(-a_from_b[2]),
    ]
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

    #[test]
    fn compose_jacobians_match_finite_differences() {
        let a = [1.0, -2.0, 0.7];
        let b = [0.5, 0.3, -0.2];
        let (_, d_a, d_b) = compose_pose(a, b);
        let num_a = numeric_jacobian(|v| compose_pose([v[0], v[1], v[2]], b).0.to_vec(), &a);
        let num_b = numeric_jacobian(|v| compose_pose(a, [v[0], v[1], v[2]]).0.to_vec(), &b);
        for r in 0..3 {
            for c in 0..3 {
                assert!((d_a[(r, c)] - num_a[r][c]).abs() < 1e-6);
                assert!((d_b[(r, c)] - num_b[r][c]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn point_jacobians_match_finite_differences() {
        let a = [1.0, -2.0, 2.7];
        let p = [4.0, -1.5];
        let (_, d_pose, d_point) = transform_point(a, p);
        let num_pose = numeric_jacobian(|v| transform_point([v[0], v[1], v[2]], p).0.to_vec(), &a);
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
        let a = [3.0, 1.0, -2.9];
        let (identity, _, _) = compose_pose(a, invert_pose(a));
        assert!(identity.iter().all(|v| v.abs() < 1e-12));
    }
}
