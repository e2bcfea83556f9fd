//! The rigid 2D transform `enu_from_map` that best maps SLAM map points onto GPS positions.
//!
//! Given pairs (`p_i` in the `map` frame, `q_i` in the `enu` frame with covariance `Σ_i`),
//! minimises the weighted least-squares cost
//!
//! ```text
//! F(t, θ) = Σ_i r_iᵀ Σ_i⁻¹ r_i,   r_i = R(θ) p_i + t − q_i
//! ```
//!
//! over the rotation `θ` and translation `t` (no scale: both frames are metric).
//!
//! 1. **Start**, in closed form: the weighted Procrustes solution (Umeyama, "Least-squares
//!    estimation of transformation parameters between two point patterns", IEEE PAMI 13(4),
//!    1991, without the scale), with the scalar weight `w_i = trace(Σ_i⁻¹) / 2` per pair (the
//!    information averaged over both axes). It is the exact optimum when every `Σ_i` is
//!    isotropic.
//! 2. **Refinement** by Gauss-Newton on `(t_x, t_y, θ)` with the full 2×2 information matrices,
//!    Jacobian `J_i = [I₂ | R'(θ) p_i]`. The residuals are linear in `t` and mildly non-linear
//!    in `θ`; Gauss-Newton, which drops the residual-weighted second derivative, converges
//!    linearly at a rate set by the residuals (about ×0.03 per iteration for metre-level GPS
//!    noise over a 200 m map), so under ten iterations reach the step tolerance.
//! 3. **Covariance**: `(Σ_i J_iᵀ Σ_i⁻¹ J_i)⁻¹` at the optimum, the a priori covariance: it
//!    trusts the given `Σ_i` and is *not* scaled by the residual. The a posteriori variance
//!    factor `F / (2n − 3)` is reported beside it (about 1 when the `Σ_i` are right), and
//!    [`RigidAlignment2d::a_posteriori_covariance`] scales by it, for GPS covariances of doubtful
//!    scale (HDOP-based ones). With few pairs the factor is itself noisy (one degree of freedom
//!    for two pairs).
//!
//! Only the GPS side carries uncertainty here; the map points are taken as exact.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

use super::{GeoRefError, GpsMeasurement};
use crate::geometry::Pose2;

/// Gauss-Newton stops once a step moves the translation less than this, metres…
const TRANSLATION_STEP_TOLERANCE_M: f64 = 1e-10;
/// …and the rotation less than this, radians.
const ROTATION_STEP_TOLERANCE_RAD: f64 = 1e-13;

/// One correspondence: a point of the `map` frame and where GPS saw it in the `enu` frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlignmentPair {
    /// `[x_m, y_m]` of the point in the `map` frame (a local map's base, a trajectory pose).
    pub point_in_map: [f64; 2],
    /// `[east_m, north_m]` of the same point from GPS.
    pub point_in_enu: [f64; 2],
    /// Covariance of `point_in_enu`, m², east-north order; symmetric positive definite.
    pub covariance_in_enu_m2: Matrix2<f64>,
}

impl AlignmentPair {
    /// Pairs `point_in_map` with the GPS measurement `gps` taken at the same place.
    pub fn new(point_in_map: [f64; 2], gps: &GpsMeasurement) -> Self {
        AlignmentPair {
            point_in_map,
            point_in_enu: gps.position_in_enu_m,
            covariance_in_enu_m2: gps.covariance_in_enu_m2,
        }
    }
}

/// Options of [`RigidAlignment2d::estimate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidAlignmentOptions {
    /// Most Gauss-Newton iterations after the closed-form start; 0 keeps the start. Default 20
    /// (under ten are typical; isotropic covariances need none).
    pub max_iterations: usize,
}

impl Default for RigidAlignmentOptions {
    fn default() -> Self {
        RigidAlignmentOptions { max_iterations: 20 }
    }
}

/// The estimated `enu_from_map` transform with its uncertainty and fit quality.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidAlignment2d {
    /// Maps `point_in_map` to `point_in_enu = enu_from_map * point_in_map`.
    pub enu_from_map: Pose2,
    /// A priori covariance of (`x_m`, `y_m`, `theta_rad`) of `enu_from_map`, in that order:
    /// the inverse Gauss-Newton information at the optimum, not scaled by the residual.
    pub covariance: Matrix3<f64>,
    /// A posteriori variance factor: the weighted cost over its `2n − 3` degrees of freedom.
    pub variance_factor: f64,
    /// Root mean square of the residual lengths `|enu_from_map * p_i − q_i|`, metres.
    pub rms_residual_m: f64,
    /// Gauss-Newton iterations taken after the closed-form start.
    pub iterations: usize,
}

/// A pair in solver form: map point, ENU point, information matrix.
#[derive(Clone, Copy, Debug)]
pub(super) struct WeightedPair {
    pub(super) p: Vector2<f64>,
    pub(super) q: Vector2<f64>,
    pub(super) information: Matrix2<f64>,
}

/// The transform parameters `(x_m, y_m, theta_rad)` the solver works on, unwrapped.
type Parameters = Vector3<f64>;

impl RigidAlignment2d {
    /// Estimates the `enu_from_map` that best maps each `pairs[i].point_in_map` onto
    /// `pairs[i].point_in_enu`, weighted by the inverse of `pairs[i].covariance_in_enu_m2`.
    ///
    /// # Errors
    ///
    /// * [`GeoRefError::TooFewPairs`] for fewer than two pairs;
    /// * [`GeoRefError::NonFinite`] for a NaN or infinite point;
    /// * [`GeoRefError::InvalidCovariance`] for a covariance that is not finite, symmetric and
    ///   positive definite;
    /// * [`GeoRefError::DegenerateGeometry`] if the map points coincide, so the rotation is not
    ///   determined.
    pub fn estimate(
        pairs: &[AlignmentPair],
        options: &RigidAlignmentOptions,
    ) -> Result<Self, GeoRefError> {
        if pairs.len() < 2 {
            return Err(GeoRefError::TooFewPairs { count: pairs.len() });
        }
        let weighted = pairs
            .iter()
            .enumerate()
            .map(|(index, pair)| weighted_pair(index, pair))
            .collect::<Result<Vec<_>, _>>()?;

        // Stage 1: closed-form weighted Procrustes start.
        let mut x = closed_form_start(&weighted)?;
        let mut cost = weighted_cost(&weighted, &x);

        // Stage 2: Gauss-Newton with the full information matrices.
        let mut iterations = 0;
        while iterations < options.max_iterations {
            let (h, g) = normal_equations(&weighted, &x);
            let cholesky = h.cholesky().ok_or(GeoRefError::DegenerateGeometry)?;
            let delta = -cholesky.solve(&g);
            let candidate = x + delta;
            let candidate_cost = weighted_cost(&weighted, &candidate);
            if !candidate_cost.is_finite() || candidate_cost > cost * (1.0 + 1e-12) + 1e-300 {
                // The step does not lower the cost: the estimate is the optimum to working
                // precision.
                break;
            }
            x = candidate;
            cost = candidate_cost;
            iterations += 1;
            let step_m = delta.fixed_rows::<2>(0).norm();
            if step_m < TRANSLATION_STEP_TOLERANCE_M && delta[2].abs() < ROTATION_STEP_TOLERANCE_RAD
            {
                break;
            }
        }

        // Stage 3: covariance from the information at the optimum.
        let (h, _) = normal_equations(&weighted, &x);
        let covariance = h
            .cholesky()
            .ok_or(GeoRefError::DegenerateGeometry)?
            .inverse();
        if !covariance.iter().all(|value| value.is_finite()) {
            // Only absurd scales (weights or coordinates near the f64 range) get here.
            return Err(GeoRefError::NonFinite("the alignment covariance"));
        }
        debug_assert!(
            (covariance - covariance.transpose()).abs().max() <= 1e-9 * covariance.abs().max(),
            "alignment covariance is not symmetric"
        );
        let degrees_of_freedom = (2 * weighted.len() - 3) as f64;
        let sum_squared_m2: f64 = weighted
            .iter()
            .map(|pair| residual(pair, &x).norm_squared())
            .sum();
        Ok(RigidAlignment2d {
            enu_from_map: Pose2::new(x[0], x[1], x[2]),
            covariance,
            variance_factor: cost / degrees_of_freedom,
            rms_residual_m: (sum_squared_m2 / weighted.len() as f64).sqrt(),
            iterations,
        })
    }

    /// The covariance scaled by the a posteriori variance factor: `covariance * variance_factor`,
    /// for pair covariances whose scale is doubtful.
    pub fn a_posteriori_covariance(&self) -> Matrix3<f64> {
        self.covariance * self.variance_factor
    }
}

/// Checks one pair and inverts its covariance; `index` names the pair in the error.
pub(super) fn weighted_pair(
    index: usize,
    pair: &AlignmentPair,
) -> Result<WeightedPair, GeoRefError> {
    let [px, py] = pair.point_in_map;
    let [qx, qy] = pair.point_in_enu;
    if !(px.is_finite() && py.is_finite()) {
        return Err(GeoRefError::NonFinite("a map point of the alignment"));
    }
    if !(qx.is_finite() && qy.is_finite()) {
        return Err(GeoRefError::NonFinite("an ENU point of the alignment"));
    }
    let covariance = pair.covariance_in_enu_m2;
    let invalid = GeoRefError::InvalidCovariance { index };
    let scale = covariance.abs().max();
    if !covariance.iter().all(|value| value.is_finite())
        || (covariance[(0, 1)] - covariance[(1, 0)]).abs() > 1e-9 * scale
    {
        return Err(invalid);
    }
    let information = covariance.cholesky().ok_or(invalid)?.inverse();
    if !information.iter().all(|value| value.is_finite()) {
        return Err(GeoRefError::InvalidCovariance { index });
    }
    Ok(WeightedPair {
        p: Vector2::new(px, py),
        q: Vector2::new(qx, qy),
        information,
    })
}

/// The weighted Procrustes solution with the scalar weight `trace(Σ_i⁻¹) / 2` (the information
/// averaged over both axes) per pair; exact for isotropic covariances.
fn closed_form_start(pairs: &[WeightedPair]) -> Result<Parameters, GeoRefError> {
    let weights: Vec<f64> = pairs
        .iter()
        .map(|pair| pair.information.trace() / 2.0)
        .collect();
    let total_weight: f64 = weights.iter().sum();
    let p_mean = pairs
        .iter()
        .zip(&weights)
        .fold(Vector2::zeros(), |sum, (pair, w)| sum + pair.p * *w)
        / total_weight;
    let q_mean = pairs
        .iter()
        .zip(&weights)
        .fold(Vector2::zeros(), |sum, (pair, w)| sum + pair.q * *w)
        / total_weight;

    let mut spread_m2 = 0.0;
    let mut dot_sum = 0.0;
    let mut cross_sum = 0.0;
    for (pair, w) in pairs.iter().zip(&weights) {
        let p = pair.p - p_mean;
        let q = pair.q - q_mean;
        spread_m2 += w * p.norm_squared();
        dot_sum += w * p.dot(&q);
        cross_sum += w * (p.x * q.y - p.y * q.x);
    }
    let spread_rms_m = (spread_m2 / total_weight).sqrt();
    // Points closer together than this (relative to their distance from the map origin) are
    // one point to working precision (a NaN spread, from overflowing weights, counts too).
    if spread_rms_m.is_nan() || spread_rms_m <= 1e-9 * (1.0 + p_mean.norm()) {
        return Err(GeoRefError::DegenerateGeometry);
    }
    let theta_rad = cross_sum.atan2(dot_sum);
    let t = q_mean - rotation(theta_rad) * p_mean;
    Ok(Vector3::new(t.x, t.y, theta_rad))
}

fn rotation(theta_rad: f64) -> Matrix2<f64> {
    let (sin, cos) = theta_rad.sin_cos();
    Matrix2::new(cos, -sin, sin, cos)
}

/// `r_i = R(θ) p_i + t − q_i`.
fn residual(pair: &WeightedPair, x: &Parameters) -> Vector2<f64> {
    rotation(x[2]) * pair.p + Vector2::new(x[0], x[1]) - pair.q
}

/// The weighted cost `Σ r_iᵀ W_i r_i`.
fn weighted_cost(pairs: &[WeightedPair], x: &Parameters) -> f64 {
    pairs
        .iter()
        .map(|pair| {
            let r = residual(pair, x);
            r.dot(&(pair.information * r))
        })
        .sum()
}

/// The Gauss-Newton normal equations at `x`: `h = Σ Jᵀ W J` and `g = Σ Jᵀ W r` (textbook names).
fn normal_equations(pairs: &[WeightedPair], x: &Parameters) -> (Matrix3<f64>, Vector3<f64>) {
    let (sin, cos) = x[2].sin_cos();
    let mut h = Matrix3::zeros();
    let mut g = Vector3::zeros();
    for pair in pairs {
        let r = residual(pair, x);
        // d(R(θ) p)/dθ.
        let d_rotated = Vector2::new(
            -sin * pair.p.x - cos * pair.p.y,
            cos * pair.p.x - sin * pair.p.y,
        );
        let j = Matrix2x3::new(1.0, 0.0, d_rotated.x, 0.0, 1.0, d_rotated.y);
        let jt_w = j.transpose() * pair.information;
        h += jt_w * j;
        g += jt_w * r;
    }
    (h, g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// Eight map points along a loop some way off the map origin.
    fn map_points() -> Vec<[f64; 2]> {
        vec![
            [30.0, 10.0],
            [80.0, 15.0],
            [140.0, 5.0],
            [190.0, 40.0],
            [200.0, 110.0],
            [150.0, 160.0],
            [90.0, 150.0],
            [40.0, 100.0],
        ]
    }

    /// Covariance of an error ellipse: `major_m`, `minor_m` 1σ, major axis `orientation_rad`
    /// from east.
    fn ellipse(major_m: f64, minor_m: f64, orientation_rad: f64) -> Matrix2<f64> {
        let rot = rotation(orientation_rad);
        rot * Matrix2::new(major_m * major_m, 0.0, 0.0, minor_m * minor_m) * rot.transpose()
    }

    /// Anisotropic, correlated covariances, a different one per point.
    fn anisotropic_covariances(count: usize) -> Vec<Matrix2<f64>> {
        (0..count)
            .map(|i| {
                let i = i as f64;
                ellipse(1.0 + 0.4 * i, 0.5 + 0.1 * i, 0.7 * i)
            })
            .collect()
    }

    fn truth() -> Pose2 {
        Pose2::new(40.0, -25.0, 0.6)
    }

    fn noiseless_pairs(covariances: &[Matrix2<f64>]) -> Vec<AlignmentPair> {
        map_points()
            .into_iter()
            .zip(covariances)
            .map(|(point_in_map, covariance)| AlignmentPair {
                point_in_map,
                point_in_enu: truth().transform_point(point_in_map),
                covariance_in_enu_m2: *covariance,
            })
            .collect()
    }

    fn assert_pose_close(a: Pose2, b: Pose2, tolerance: f64) {
        assert!((a.x_m - b.x_m).abs() < tolerance, "{a:?} != {b:?}");
        assert!((a.y_m - b.y_m).abs() < tolerance, "{a:?} != {b:?}");
        assert!(
            (a.theta_rad - b.theta_rad).abs() < tolerance,
            "{a:?} != {b:?}"
        );
    }

    #[test]
    fn test_exact_recovery_from_noiseless_points() {
        let covariances = anisotropic_covariances(map_points().len());
        let pairs = noiseless_pairs(&covariances);
        let alignment =
            RigidAlignment2d::estimate(&pairs, &RigidAlignmentOptions::default()).unwrap();
        assert_pose_close(alignment.enu_from_map, truth(), 1e-9);
        assert!(alignment.rms_residual_m < 1e-9);
        assert!(alignment.variance_factor < 1e-18);
        // Two pairs suffice.
        let alignment =
            RigidAlignment2d::estimate(&pairs[..2], &RigidAlignmentOptions::default()).unwrap();
        assert_pose_close(alignment.enu_from_map, truth(), 1e-9);
    }

    #[test]
    fn test_closed_form_is_optimal_for_isotropic_weights() {
        let covariances: Vec<_> = (0..8)
            .map(|i| Matrix2::identity() * (1.0 + f64::from(i)))
            .collect();
        let mut pairs = noiseless_pairs(&covariances);
        // Perturb the GPS points so the optimum has a residual.
        for (i, pair) in pairs.iter_mut().enumerate() {
            let i = i as f64;
            pair.point_in_enu[0] += (1.3 * i).sin();
            pair.point_in_enu[1] += (2.1 * i).cos();
        }
        let weighted: Vec<_> = pairs
            .iter()
            .enumerate()
            .map(|(index, pair)| weighted_pair(index, pair).unwrap())
            .collect();
        let start = closed_form_start(&weighted).unwrap();
        let (_, g) = normal_equations(&weighted, &start);
        assert!(g.norm() < 1e-9, "gradient at the closed form {g}");
        let alignment =
            RigidAlignment2d::estimate(&pairs, &RigidAlignmentOptions::default()).unwrap();
        assert!(alignment.iterations <= 1);
        assert!((alignment.enu_from_map.theta_rad - start[2]).abs() < 1e-12);
    }

    #[test]
    fn test_gauss_newton_improves_on_the_start_for_anisotropic_weights() {
        let covariances = anisotropic_covariances(8);
        let mut pairs = noiseless_pairs(&covariances);
        for (i, pair) in pairs.iter_mut().enumerate() {
            let i = i as f64;
            pair.point_in_enu[0] += 2.0 * (1.3 * i).sin();
            pair.point_in_enu[1] += 2.0 * (2.1 * i).cos();
        }
        let weighted: Vec<_> = pairs
            .iter()
            .enumerate()
            .map(|(index, pair)| weighted_pair(index, pair).unwrap())
            .collect();
        let start = closed_form_start(&weighted).unwrap();
        let alignment =
            RigidAlignment2d::estimate(&pairs, &RigidAlignmentOptions::default()).unwrap();
        let x = Vector3::new(
            alignment.enu_from_map.x_m,
            alignment.enu_from_map.y_m,
            alignment.enu_from_map.theta_rad,
        );
        assert!(weighted_cost(&weighted, &x) < weighted_cost(&weighted, &start));
        let (_, g) = normal_equations(&weighted, &x);
        assert!(g.norm() < 1e-8, "gradient at the optimum {g}");
        assert!(alignment.iterations >= 1);
    }

    /// Draws from N(0, `covariance`) with a seeded generator.
    fn sample(rng: &mut ChaCha8Rng, covariance: &Matrix2<f64>) -> Vector2<f64> {
        let l = covariance.cholesky().unwrap().l();
        let z = Vector2::new(
            StandardNormal.sample(&mut *rng),
            StandardNormal.sample(&mut *rng),
        );
        l * z
    }

    #[test]
    fn test_covariance_matches_monte_carlo_spread() {
        const TRIALS: usize = 4000;
        let covariances = anisotropic_covariances(8);
        let clean = noiseless_pairs(&covariances);
        let predicted = RigidAlignment2d::estimate(&clean, &RigidAlignmentOptions::default())
            .unwrap()
            .covariance;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut estimates = Vec::with_capacity(TRIALS);
        let mut variance_factor_sum = 0.0;
        for _ in 0..TRIALS {
            let noisy: Vec<_> = clean
                .iter()
                .map(|pair| {
                    let noise = sample(&mut rng, &pair.covariance_in_enu_m2);
                    AlignmentPair {
                        point_in_enu: [
                            pair.point_in_enu[0] + noise.x,
                            pair.point_in_enu[1] + noise.y,
                        ],
                        ..*pair
                    }
                })
                .collect();
            let alignment =
                RigidAlignment2d::estimate(&noisy, &RigidAlignmentOptions::default()).unwrap();
            let pose = alignment.enu_from_map;
            estimates.push(Vector3::new(pose.x_m, pose.y_m, pose.theta_rad));
            variance_factor_sum += alignment.variance_factor;
        }
        let mean = estimates.iter().sum::<Vector3<f64>>() / TRIALS as f64;
        let spread = estimates
            .iter()
            .map(|x| (x - mean) * (x - mean).transpose())
            .sum::<Matrix3<f64>>()
            / (TRIALS - 1) as f64;
        for i in 0..3 {
            let ratio = spread[(i, i)] / predicted[(i, i)];
            assert!(
                (0.8..1.2).contains(&ratio),
                "variance {i}: Monte-Carlo {} vs predicted {} (ratio {ratio})",
                spread[(i, i)],
                predicted[(i, i)]
            );
            for j in 0..i {
                let rho_spread = spread[(i, j)] / (spread[(i, i)] * spread[(j, j)]).sqrt();
                let rho_predicted =
                    predicted[(i, j)] / (predicted[(i, i)] * predicted[(j, j)]).sqrt();
                assert!(
                    (rho_spread - rho_predicted).abs() < 0.1,
                    "correlation {i},{j}: {rho_spread} vs {rho_predicted}"
                );
            }
        }
        // Unbiased, and the variance factor averages to one.
        let bias = mean - Vector3::new(truth().x_m, truth().y_m, truth().theta_rad);
        for i in 0..3 {
            assert!(bias[i].abs() < 4.0 * (predicted[(i, i)] / TRIALS as f64).sqrt());
        }
        let variance_factor_mean = variance_factor_sum / TRIALS as f64;
        assert!(
            (variance_factor_mean - 1.0).abs() < 0.05,
            "{variance_factor_mean}"
        );
    }

    #[test]
    fn test_a_posteriori_covariance_scales_by_variance_factor() {
        let covariances = anisotropic_covariances(8);
        let mut pairs = noiseless_pairs(&covariances);
        pairs[3].point_in_enu[0] += 3.0;
        let alignment =
            RigidAlignment2d::estimate(&pairs, &RigidAlignmentOptions::default()).unwrap();
        assert!(alignment.variance_factor > 0.0);
        let scaled = alignment.a_posteriori_covariance();
        assert!(
            (scaled - alignment.covariance * alignment.variance_factor)
                .abs()
                .max()
                < 1e-15
        );
    }

    #[test]
    fn test_rejects_bad_input() {
        let options = RigidAlignmentOptions::default();
        let covariances = anisotropic_covariances(8);
        let pairs = noiseless_pairs(&covariances);
        assert!(matches!(
            RigidAlignment2d::estimate(&[], &options),
            Err(GeoRefError::TooFewPairs { count: 0 })
        ));
        assert!(matches!(
            RigidAlignment2d::estimate(&pairs[..1], &options),
            Err(GeoRefError::TooFewPairs { count: 1 })
        ));
        let mut coincident = pairs.clone();
        for pair in &mut coincident {
            pair.point_in_map = [12.0, -3.0];
        }
        assert!(matches!(
            RigidAlignment2d::estimate(&coincident, &options),
            Err(GeoRefError::DegenerateGeometry)
        ));
        let mut nan_point = pairs.clone();
        nan_point[2].point_in_map[1] = f64::NAN;
        assert!(matches!(
            RigidAlignment2d::estimate(&nan_point, &options),
            Err(GeoRefError::NonFinite(_))
        ));
        let mut nan_gps = pairs.clone();
        nan_gps[5].point_in_enu[0] = f64::INFINITY;
        assert!(matches!(
            RigidAlignment2d::estimate(&nan_gps, &options),
            Err(GeoRefError::NonFinite(_))
        ));
        for bad in [
            Matrix2::new(1.0, 0.0, 0.0, -1.0),
            Matrix2::new(1.0, 2.0, 2.0, 1.0),
            Matrix2::new(1.0, 0.5, 0.0, 1.0),
            Matrix2::new(f64::NAN, 0.0, 0.0, 1.0),
            Matrix2::zeros(),
        ] {
            let mut bad_covariance = pairs.clone();
            bad_covariance[4].covariance_in_enu_m2 = bad;
            assert!(
                matches!(
                    RigidAlignment2d::estimate(&bad_covariance, &options),
                    Err(GeoRefError::InvalidCovariance { index: 4 })
                ),
                "{bad}"
            );
        }
    }
}
