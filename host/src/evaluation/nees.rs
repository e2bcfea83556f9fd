//! Normalised estimation error squared (NEES) of a robot pose and its chi-square bounds: the
//! filter-consistency test of Bar-Shalom, Li and Kirubarajan, "Estimation with Applications
//! to Tracking and Navigation" (2001), section 5.4.2.
//!
//! For a consistent filter the pose error `e` (estimate minus truth) is zero-mean with the
//! filter's covariance `P`, so `eᵀ P⁻¹ e` is chi-square distributed with 3 degrees of
//! freedom. Averaged over `N` independent Monte-Carlo runs at one time step, `N` times the
//! average is chi-square with `3 N` degrees of freedom; [`chi_square_bounds`] gives the
//! two-sided acceptance region of that average.

use nalgebra::{Matrix3, Vector3};
use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::geometry::wrap_angle_rad;

/// Largest asymmetry `|p_ij − p_ji|` [`pose_nees`] accepts, relative to the largest entry.
const SYMMETRY_TOLERANCE: f64 = 1e-6;

/// The NEES `eᵀ P⁻¹ e` of the pose error `error` (`[x_m, y_m, theta_rad]`, estimate minus
/// truth, either sign) under the covariance `covariance` (same order, row-major). The heading
/// error is wrapped into `(-π, π]` first.
///
/// Returns `None` if an input is not finite, or `covariance` is not symmetric (to a relative
/// 1e-6) and positive definite (its Cholesky factorisation fails).
pub fn pose_nees(error: [f64; 3], covariance: [[f64; 3]; 3]) -> Option<f64> {
    let e = Vector3::new(error[0], error[1], wrap_angle_rad(error[2]));
    let p = Matrix3::from_fn(|r, c| covariance[r][c]);
    if !e.iter().chain(p.iter()).all(|v| v.is_finite()) {
        return None;
    }
    let scale = p.amax();
    let asymmetry = (p - p.transpose()).amax();
    if asymmetry > SYMMETRY_TOLERANCE * scale {
        return None;
    }
    let cholesky = ((p + p.transpose()) * 0.5).cholesky()?;
    Some(e.dot(&cholesky.solve(&e)))
}

/// The two-sided `confidence` region (for example 0.95) of the NEES averaged over `runs`
/// independent runs, for a state of `dof` dimensions: the `(1 − confidence)/2` and
/// `(1 + confidence)/2` quantiles of `χ²(dof · runs)`, divided by `runs`.
///
/// For `dof = 3`, 95 %: `(0.216, 9.35)` for one run, `(2.36, 3.72)` for 50 runs.
///
/// Returns `None` if `dof` or `runs` is 0, `dof · runs` overflows, or `confidence` is not
/// strictly between 0 and 1.
pub fn chi_square_bounds(dof: usize, runs: usize, confidence: f64) -> Option<(f64, f64)> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return None;
    }
    let total_dof = dof.checked_mul(runs).filter(|&n| n > 0)?;
    let chi_square = ChiSquared::new(total_dof as f64).ok()?;
    let runs = runs as f64;
    Some((
        chi_square.inverse_cdf(0.5 * (1.0 - confidence)) / runs,
        chi_square.inverse_cdf(0.5 * (1.0 + confidence)) / runs,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn close(got: (f64, f64), want: (f64, f64), tolerance: f64) -> bool {
        (got.0 - want.0).abs() < tolerance && (got.1 - want.1).abs() < tolerance
    }

    #[test]
    fn bounds_for_one_and_fifty_runs() {
        let one = chi_square_bounds(3, 1, 0.95).unwrap();
        assert!(close(one, (0.2158, 9.348), 1e-3), "{one:?}");
        // χ²(150) quantiles 117.985 and 185.800, over 50.
        let fifty = chi_square_bounds(3, 50, 0.95).unwrap();
        assert!(close(fifty, (2.3597, 3.7160), 1e-3), "{fifty:?}");
        // Bar-Shalom et al. 2001, section 5.4.2: two dimensions, 50 runs, [1.5, 2.6].
        let textbook = chi_square_bounds(2, 50, 0.95).unwrap();
        assert!(close(textbook, (1.4844, 2.5912), 1e-3), "{textbook:?}");
    }

    #[test]
    fn bounds_reject_meaningless_arguments() {
        assert_eq!(chi_square_bounds(0, 10, 0.95), None);
        assert_eq!(chi_square_bounds(3, 0, 0.95), None);
        assert_eq!(chi_square_bounds(3, 10, 1.0), None);
        assert_eq!(chi_square_bounds(3, 10, f64::NAN), None);
        assert_eq!(chi_square_bounds(usize::MAX, 2, 0.95), None);
    }

    #[test]
    fn nees_of_a_known_error() {
        let p = [[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.01]];
        let nees = pose_nees([2.0, -1.0, 0.1], p).unwrap();
        assert!((nees - 3.0).abs() < 1e-12);
        // A heading error just short of a full turn is a small one.
        let wrapped = pose_nees([0.0, 0.0, 2.0 * PI - 0.1], p).unwrap();
        assert!((wrapped - 1.0).abs() < 1e-9);
    }

    #[test]
    fn nees_rejects_what_is_no_covariance() {
        let singular = [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(pose_nees([0.1, 0.0, 0.0], singular), None);
        let indefinite = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(pose_nees([0.1, 0.0, 0.0], indefinite), None);
        let asymmetric = [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(pose_nees([0.1, 0.0, 0.0], asymmetric), None);
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(pose_nees([f64::NAN, 0.0, 0.0], identity), None);
    }

    #[test]
    fn nees_of_samples_from_the_covariance_averages_the_dimension() {
        let p = Matrix3::new(
            0.04, 0.01, 0.002, //
            0.01, 0.09, -0.003, //
            0.002, -0.003, 0.0025,
        );
        // The test's own matrix is positive definite by construction.
        let l = p.cholesky().unwrap().l();
        let covariance = [0, 1, 2].map(|r| [0, 1, 2].map(|c| p[(r, c)]));
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let samples = 20_000;
        let mut sum = 0.0;
        for _ in 0..samples {
            let z = Vector3::from_fn(|_, _| StandardNormal.sample(&mut rng));
            let e = l * z;
            sum += pose_nees([e[0], e[1], e[2]], covariance).unwrap();
        }
        let mean = sum / f64::from(samples);
        // The mean's standard deviation is √(2·3 / 20000) ≈ 0.017.
        assert!((mean - 3.0).abs() < 0.06, "mean NEES {mean}");
        let (low, high) = chi_square_bounds(3, samples as usize, 0.99).unwrap();
        assert!(
            (low..=high).contains(&mean),
            "{mean} outside [{low}, {high}]"
        );
    }
}
