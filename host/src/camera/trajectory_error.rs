//! A monocular trajectory against the truth: aligned by the best similarity transform
//! (rotation, translation and scale; Umeyama 1991), as a monocular run fixes no scale.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The error of an estimated trajectory after alignment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryError {
    /// Pairs compared.
    pub poses: usize,
    /// RMS of the position error after the similarity alignment (absolute trajectory
    /// error), in the truth's units.
    pub ate_rmse_m: f64,
    /// The scale that took the estimate to the truth.
    pub scale: f64,
    /// Mean angle between the estimated and the true rotation since the first pose, degrees.
    pub rotation_error_deg: f64,
    /// Length of the true path, m.
    pub true_path_m: f64,
}

/// Compares `estimate` with `truth`, pose for pose (`position`, `world_from_camera`), each in
/// its own world frame; `None` with fewer than three pairs or no spread in the estimate.
pub fn trajectory_error(
    estimate: &[(Vector3<f64>, UnitQuaternion<f64>)],
    truth: &[(Vector3<f64>, UnitQuaternion<f64>)],
) -> Option<TrajectoryError> {
    let n = estimate.len().min(truth.len());
    if n < 3 {
        return None;
    }
    let mean = |points: &mut dyn Iterator<Item = Vector3<f64>>| {
        points.fold(Vector3::zeros(), |a, p| a + p) / n as f64
    };
    let mu_e = mean(&mut estimate[..n].iter().map(|p| p.0));
    let mu_t = mean(&mut truth[..n].iter().map(|p| p.0));
    let mut covariance = Matrix3::zeros();
    let mut variance_e = 0.0;
    for i in 0..n {
        let (de, dt) = (estimate[i].0 - mu_e, truth[i].0 - mu_t);
        covariance += dt * de.transpose();
        variance_e += de.norm_squared();
    }
    covariance /= n as f64;
    variance_e /= n as f64;
    if variance_e <= 1e-18 {
        return None;
    }
    let svd = covariance.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut sign = Matrix3::identity();
    if (u.determinant() * v_t.determinant()) < 0.0 {
        sign[(2, 2)] = -1.0;
    }
    let rotation = u * sign * v_t;
    let scale = (Matrix3::from_diagonal(&svd.singular_values) * sign).trace() / variance_e;
    let translation = mu_t - scale * rotation * mu_e;
    let squared: f64 = (0..n)
        .map(|i| (scale * rotation * estimate[i].0 + translation - truth[i].0).norm_squared())
        .sum();
    let rotation_error_deg = (0..n)
        .map(|i| {
            let e = estimate[0].1.inverse() * estimate[i].1;
            let t = truth[0].1.inverse() * truth[i].1;
            (t.inverse() * e).angle().to_degrees()
        })
        .sum::<f64>()
        / n as f64;
    let true_path_m = truth[..n]
        .windows(2)
        .map(|w| (w[1].0 - w[0].0).norm())
        .sum();
    Some(TrajectoryError {
        poses: n,
        ate_rmse_m: (squared / n as f64).sqrt(),
        scale,
        rotation_error_deg,
        true_path_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scaled_rotated_copy_has_no_error() {
        let truth: Vec<_> = (0..10)
            .map(|i| {
                let t = f64::from(i);
                (
                    Vector3::new(t, (t * 0.5).sin(), 0.1 * t * t),
                    UnitQuaternion::from_euler_angles(0.0, 0.1 * t, 0.0),
                )
            })
            .collect();
        let turn = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0);
        let estimate: Vec<_> = truth
            .iter()
            .map(|(p, q)| (turn * (p * 0.25) + Vector3::new(1.0, 2.0, 3.0), turn * q))
            .collect();
        let error = trajectory_error(&estimate, &truth).expect("aligned");
        assert!(error.ate_rmse_m < 1e-9, "{error:?}");
        assert!((error.scale - 4.0).abs() < 1e-9, "{error:?}");
        assert!(error.rotation_error_deg < 1e-6, "{error:?}");
    }
}
