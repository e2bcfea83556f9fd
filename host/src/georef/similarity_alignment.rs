//! The 2D similarity `enu_from_map` (rotation, translation and scale) that best maps the
//! points of a map without a metric scale (a single camera's) onto GPS positions.
//!
//! With `a = s cos θ` and `b = s sin θ` the map is linear in its four numbers,
//!
//! ```text
//! q_i ≈ [a −b; b a] p_i + t = J_i x,   J_i = [1 0 p_x −p_y; 0 1 p_y p_x],   x = (t_x, t_y, a, b)
//! ```
//!
//! so the weighted least-squares fit `min Σ (J_i x − q_i)ᵀ Σ_i⁻¹ (J_i x − q_i)` is one solve
//! of its 4×4 normal equations, exact for any covariances (the rigid fit,
//! [`super::RigidAlignment2d`], needs iterations because its rotation is not linear). The
//! normal equations are sums over the pairs, so [`SimilarityFit2d`] keeps only the sums: a
//! pair costs the same however many came before, and the memory does not grow with them.
//! The covariance of `x` is the inverse of the normal matrix (a priori: it trusts the
//! `Σ_i`); scale and rotation take theirs through `s = |(a, b)|`, `θ = atan2(b, a)`.
//!
//! The sums are taken about an origin (by default the first pair's map point and GPS
//! position), so that points far from either frame's origin lose no precision to
//! cancellation. Fits about the same origin add up ([`SimilarityFit2d::add_fit`]): the fit
//! of a stretch of a run is the sum of its parts' fits.
//!
//! Only the GPS side carries uncertainty; the map points are taken as exact.

use nalgebra::{Matrix2x4, Matrix4, Vector2, Vector4};

use super::rigid_alignment::{WeightedPair, weighted_pair};
use super::{AlignmentPair, GeoRefError};

/// The running sums of a weighted similarity fit. See the [module documentation](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimilarityFit2d {
    /// `Σ J_iᵀ W_i J_i`.
    normal: Matrix4<f64>,
    /// `Σ J_iᵀ W_i q_i`.
    rhs: Vector4<f64>,
    /// `Σ J_iᵀ J_i`, `Σ J_iᵀ q_i` and `Σ q_iᵀ q_i`: the residual in metres.
    normal_unweighted: Matrix4<f64>,
    rhs_unweighted: Vector4<f64>,
    q2_unweighted: f64,
    /// `Σ q_iᵀ W_i q_i`: the weighted residual.
    q2_weighted: f64,
    pairs: usize,
    /// The map point and GPS position the sums are taken about; `None` until the first pair
    /// sets it.
    origin: Option<([f64; 2], [f64; 2])>,
}

impl Default for SimilarityFit2d {
    fn default() -> Self {
        SimilarityFit2d {
            normal: Matrix4::zeros(),
            rhs: Vector4::zeros(),
            normal_unweighted: Matrix4::zeros(),
            rhs_unweighted: Vector4::zeros(),
            q2_unweighted: 0.0,
            q2_weighted: 0.0,
            pairs: 0,
            origin: None,
        }
    }
}

/// The fitted similarity with its uncertainty and fit quality.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimilarityAlignment2d {
    /// Metres in the `enu` frame per unit of the map.
    pub scale: f64,
    /// Standard deviation of `scale` (a priori).
    pub scale_sigma: f64,
    /// Rotation from the map's axes to east/north, radians.
    pub rotation_rad: f64,
    /// Where the map's origin lies in the `enu` frame, m.
    pub translation_m: [f64; 2],
    /// A priori covariance of `(t_x, t_y, a, b)`, with `t` the translation of the sums'
    /// origin (the first pair's map point unless [`SimilarityFit2d::with_origin`] set
    /// another) rather than of the map's origin.
    pub covariance: Matrix4<f64>,
    /// Root mean square of the residual lengths, metres.
    pub rms_residual_m: f64,
    /// Pairs fitted.
    pub pairs: usize,
}

impl SimilarityAlignment2d {
    /// The point of the `enu` frame that `point_in_map` maps to.
    pub fn to_enu(&self, point_in_map: [f64; 2]) -> [f64; 2] {
        let (sin, cos) = self.rotation_rad.sin_cos();
        let [x, y] = point_in_map;
        [
            self.scale * (cos * x - sin * y) + self.translation_m[0],
            self.scale * (sin * x + cos * y) + self.translation_m[1],
        ]
    }
}

/// A change of a map's frame by a similarity, `p' = c p + d` with the points as complex
/// numbers (`c` turns and scales, `d` moves): where a camera map's frame jumped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapFrameChange {
    /// `c`: `(s cos θ, s sin θ)`.
    pub turn_scale: [f64; 2],
    /// `d`, in the new frame's units.
    pub shift: [f64; 2],
}

/// The product of two complex numbers.
fn complex_product(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]]
}

/// The 2 × 2 matrix that multiplies a vector, as a complex number, by `z`.
fn complex_matrix(z: [f64; 2]) -> nalgebra::Matrix2<f64> {
    nalgebra::Matrix2::new(z[0], -z[1], z[1], z[0])
}

impl MapFrameChange {
    /// No change.
    pub const IDENTITY: MapFrameChange = MapFrameChange {
        turn_scale: [1.0, 0.0],
        shift: [0.0, 0.0],
    };

    /// Where `point` of the old frame lies in the new one.
    pub fn apply(&self, point: [f64; 2]) -> [f64; 2] {
        let [x, y] = complex_product(self.turn_scale, point);
        [x + self.shift[0], y + self.shift[1]]
    }

    /// `self` after `first`: a point of `first`'s old frame taken through both.
    pub fn after(&self, first: &MapFrameChange) -> MapFrameChange {
        MapFrameChange {
            turn_scale: complex_product(self.turn_scale, first.turn_scale),
            shift: self.apply(first.shift),
        }
    }

    /// The change back, `None` for a degenerate one (`c = 0`).
    pub fn inverse(&self) -> Option<MapFrameChange> {
        let [a, b] = self.turn_scale;
        let norm = a * a + b * b;
        if !(norm.is_finite() && norm > 0.0) {
            return None;
        }
        let inverse_c = [a / norm, -b / norm];
        let [x, y] = complex_product(inverse_c, self.shift);
        Some(MapFrameChange {
            turn_scale: inverse_c,
            shift: [-x, -y],
        })
    }
}

/// `J_i` for the map point `p`.
fn jacobian(p: Vector2<f64>) -> Matrix2x4<f64> {
    Matrix2x4::new(1.0, 0.0, p.x, -p.y, 0.0, 1.0, p.y, p.x)
}

impl SimilarityFit2d {
    /// A fit with no pair.
    pub fn new() -> Self {
        Self::default()
    }

    /// A fit with no pair whose sums are taken about `point_in_map` and `point_in_enu`, so
    /// that it can be added to others about the same points.
    pub fn with_origin(point_in_map: [f64; 2], point_in_enu: [f64; 2]) -> Self {
        SimilarityFit2d {
            origin: Some((point_in_map, point_in_enu)),
            ..Self::default()
        }
    }

    /// The points the sums are taken about, once set.
    pub fn origin(&self) -> Option<([f64; 2], [f64; 2])> {
        self.origin
    }

    /// Adds the pairs of `other`, a fit about the same origin (or one without pairs).
    ///
    /// # Errors
    /// [`GeoRefError::InvalidOptions`] when the two have pairs about different origins; the
    /// fit is unchanged then.
    pub fn add_fit(&mut self, other: &SimilarityFit2d) -> Result<(), GeoRefError> {
        if other.pairs == 0 {
            return Ok(());
        }
        if self.pairs > 0 && self.origin != other.origin {
            return Err(GeoRefError::InvalidOptions(
                "similarity fits about different origins cannot be added",
            ));
        }
        self.origin = other.origin;
        self.normal += other.normal;
        self.rhs += other.rhs;
        self.normal_unweighted += other.normal_unweighted;
        self.rhs_unweighted += other.rhs_unweighted;
        self.q2_unweighted += other.q2_unweighted;
        self.q2_weighted += other.q2_weighted;
        self.pairs += other.pairs;
        Ok(())
    }

    /// Pairs added so far.
    pub fn pairs(&self) -> usize {
        self.pairs
    }

    /// Adds one pair.
    ///
    /// # Errors
    /// [`GeoRefError::NonFinite`] for a NaN or infinite point, [`GeoRefError::InvalidCovariance`]
    /// (with the index the pair gets) for a covariance that is not finite, symmetric and
    /// positive definite; the fit is unchanged then.
    pub fn add(&mut self, pair: &AlignmentPair) -> Result<(), GeoRefError> {
        let WeightedPair { p, q, information } = weighted_pair(self.pairs, pair)?;
        let (p0, q0) = *self
            .origin
            .get_or_insert((pair.point_in_map, pair.point_in_enu));
        let j = jacobian(p - Vector2::from(p0));
        let q = q - Vector2::from(q0);
        let jt_w = j.transpose() * information;
        self.normal += jt_w * j;
        self.rhs += jt_w * q;
        self.normal_unweighted += j.transpose() * j;
        self.rhs_unweighted += j.transpose() * q;
        self.q2_unweighted += q.norm_squared();
        self.q2_weighted += (q.transpose() * information * q)[(0, 0)];
        self.pairs += 1;
        Ok(())
    }

    /// The same pairs with their map points in the frame `change` takes them to (about the
    /// same origin): the fit's similarity composed with the change's inverse, and the same
    /// residuals. Exact, as the model is linear in its four numbers: with `p = (p' − d) / c`
    /// the numbers of the two fits are related by one 4 × 4 matrix `L`, and the sums by
    /// `N' = Lᵀ N L`, `r' = Lᵀ r`.
    pub fn moved(&self, change: &MapFrameChange) -> SimilarityFit2d {
        let Some((p0, _)) = self.origin else {
            return *self;
        };
        let c = change.turn_scale;
        // c e = p0 − d − c p0: the shift of the sums' origin the change brings.
        let [cx, cy] = complex_product(c, p0);
        let ce = [p0[0] - change.shift[0] - cx, p0[1] - change.shift[1] - cy];
        let mut l = Matrix4::identity();
        l.fixed_view_mut::<2, 2>(0, 2)
            .copy_from(&(-complex_matrix(ce)));
        l.fixed_view_mut::<2, 2>(2, 2).copy_from(&complex_matrix(c));
        let lt = l.transpose();
        SimilarityFit2d {
            normal: lt * self.normal * l,
            rhs: lt * self.rhs,
            normal_unweighted: lt * self.normal_unweighted * l,
            rhs_unweighted: lt * self.rhs_unweighted,
            ..*self
        }
    }

    /// The weighted sum of squared residuals at the best similarity, `Σ rᵢᵀ Wᵢ rᵢ`
    /// (χ²-distributed with `2n − 4` degrees of freedom when the map is a similarity of the
    /// GPS positions and their covariances are right); `None` while no similarity is fixed
    /// (fewer than two distinct points).
    pub fn weighted_residual(&self) -> Option<f64> {
        // `solve` tells where the points fix no similarity.
        self.solve().ok()?;
        let solution = self.normal.cholesky()?.solve(&self.rhs);
        let ssr = self.q2_weighted - self.rhs.dot(&solution);
        ssr.is_finite().then_some(ssr.max(0.0))
    }

    /// The weighted residual at the best similarity, or, where the pairs fix none (one
    /// pair, or a camera that stood still), at the best translation alone: no more than the
    /// least the pairs allow.
    fn least_residual(&self) -> f64 {
        self.weighted_residual().unwrap_or_else(|| {
            let n = self.normal.fixed_view::<2, 2>(0, 0).into_owned();
            let r = self.rhs.fixed_rows::<2>(0).into_owned();
            n.cholesky()
                .map_or(0.0, |c| (self.q2_weighted - r.dot(&c.solve(&r))).max(0.0))
        })
    }

    /// Whether the pairs of `other` (about the same origin) agree with this fit's: the
    /// increase of the weighted residual when both are fitted with one similarity instead of
    /// one each (the test of Chow 1960, χ² with four degrees of freedom, or fewer where one
    /// of them holds too few pairs to fix a similarity) lies within `max_chi2`. Where even
    /// both together fix no similarity there is nothing to test, and they agree.
    pub fn agrees_with(&self, other: &SimilarityFit2d, max_chi2: f64) -> bool {
        if self.pairs == 0 || other.pairs == 0 {
            return true;
        }
        let mut both = *self;
        if both.add_fit(other).is_err() {
            return false;
        }
        both.weighted_residual()
            .is_none_or(|joint| joint - self.least_residual() - other.least_residual() <= max_chi2)
    }

    /// The best similarity for the pairs so far.
    ///
    /// # Errors
    /// [`GeoRefError::TooFewPairs`] for fewer than two pairs, [`GeoRefError::DegenerateGeometry`]
    /// when the map points coincide (nothing fixes the scale and rotation).
    pub fn solve(&self) -> Result<SimilarityAlignment2d, GeoRefError> {
        if self.pairs < 2 {
            return Err(GeoRefError::TooFewPairs { count: self.pairs });
        }
        // The map points' spread about their mean, from the unweighted sums (`N[0][0] = n`,
        // `N[0][2] = Σ p_x`, `N[1][2] = Σ p_y`, `N[2][2] = Σ |p|²`): points that coincide
        // to working precision fix no scale or rotation.
        let n = self.normal_unweighted[(0, 0)];
        let mean = Vector2::new(
            self.normal_unweighted[(0, 2)],
            self.normal_unweighted[(1, 2)],
        ) / n;
        let spread_m2 = self.normal_unweighted[(2, 2)] / n - mean.norm_squared();
        let ([p0x, p0y], [q0x, q0y]) = self.origin.unwrap_or_default();
        // Relative to the points' distance from the map's origin, where rounding sets in.
        let reach_m = 1.0 + p0x.hypot(p0y) + mean.norm();
        if spread_m2.is_nan() || spread_m2.max(0.0).sqrt() <= 1e-9 * reach_m {
            return Err(GeoRefError::DegenerateGeometry);
        }
        let covariance = self
            .normal
            .cholesky()
            .ok_or(GeoRefError::DegenerateGeometry)?
            .inverse();
        let x = covariance * self.rhs;
        if !x.iter().chain(covariance.iter()).all(|v| v.is_finite()) {
            return Err(GeoRefError::DegenerateGeometry);
        }
        let (a, b) = (x[2], x[3]);
        let scale = a.hypot(b);
        if scale <= 0.0 {
            return Err(GeoRefError::DegenerateGeometry);
        }
        let d_scale = Vector4::new(0.0, 0.0, a / scale, b / scale);
        let scale_variance = (d_scale.transpose() * covariance * d_scale)[(0, 0)];
        // Σ |J x − q|² = xᵀ N x − 2 xᵀ r + Σ |q|² with the unweighted sums.
        let squared = (x.transpose() * self.normal_unweighted * x)[(0, 0)]
            - 2.0 * x.dot(&self.rhs_unweighted)
            + self.q2_unweighted;
        // Back from the sums' origin: q = S (p − p0) + t' + q0 = S p + (t' + q0 − S p0).
        let translation_m = [
            x[0] + q0x - (a * p0x - b * p0y),
            x[1] + q0y - (b * p0x + a * p0y),
        ];
        Ok(SimilarityAlignment2d {
            scale,
            scale_sigma: scale_variance.max(0.0).sqrt(),
            rotation_rad: b.atan2(a),
            translation_m,
            covariance,
            rms_residual_m: (squared.max(0.0) / self.pairs as f64).sqrt(),
            pairs: self.pairs,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix2;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn pair(p: [f64; 2], q: [f64; 2], sigma_m: f64) -> AlignmentPair {
        AlignmentPair {
            point_in_map: p,
            point_in_enu: q,
            covariance_in_enu_m2: Matrix2::identity() * (sigma_m * sigma_m),
        }
    }

    fn truth() -> SimilarityAlignment2d {
        SimilarityAlignment2d {
            scale: 3.7,
            scale_sigma: 0.0,
            rotation_rad: 2.1,
            translation_m: [120.0, -45.0],
            covariance: Matrix4::zeros(),
            rms_residual_m: 0.0,
            pairs: 0,
        }
    }

    #[test]
    fn exact_pairs_give_the_similarity_back() {
        let truth = truth();
        let mut fit = SimilarityFit2d::new();
        for i in 0..5 {
            let p = [f64::from(i) * 2.0, (f64::from(i) * 0.7).sin()];
            fit.add(&pair(p, truth.to_enu(p), 0.5)).expect("valid pair");
        }
        let fitted = fit.solve().expect("determined");
        assert!((fitted.scale - truth.scale).abs() < 1e-9, "{fitted:?}");
        assert!((fitted.rotation_rad - truth.rotation_rad).abs() < 1e-9);
        assert!((fitted.translation_m[0] - 120.0).abs() < 1e-8);
        assert!((fitted.translation_m[1] + 45.0).abs() < 1e-8);
        assert!(fitted.rms_residual_m < 1e-9, "{fitted:?}");
    }

    #[test]
    fn noisy_pairs_give_a_scale_within_its_claimed_uncertainty() {
        // 200 fixes of 0.5 m noise along a 100-unit bent path: the scale's error and its
        // claimed σ agree (over 50 draws, the normalised error's RMS is about 1).
        let truth = truth();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut squared = 0.0;
        let mut residual = 0.0;
        for _ in 0..50 {
            let mut fit = SimilarityFit2d::new();
            for i in 0..200 {
                let s = f64::from(i) * 0.5;
                let p = [s, if s > 50.0 { s - 50.0 } else { 0.0 }];
                let [x, y] = truth.to_enu(p);
                let nx: f64 = StandardNormal.sample(&mut rng);
                let ny: f64 = StandardNormal.sample(&mut rng);
                fit.add(&pair(p, [x + 0.5 * nx, y + 0.5 * ny], 0.5))
                    .expect("valid pair");
            }
            let fitted = fit.solve().expect("determined");
            squared += ((fitted.scale - truth.scale) / fitted.scale_sigma).powi(2);
            residual += fitted.rms_residual_m;
        }
        let normalised_rms = (squared / 50.0).sqrt();
        assert!((0.7..1.4).contains(&normalised_rms), "{normalised_rms}");
        // The residual of 2-D noise of 0.5 m per axis is about 0.5 √2 m.
        let mean_residual = residual / 50.0;
        assert!((0.6..0.8).contains(&mean_residual), "{mean_residual}");
    }

    /// Fits about one origin of two stretches of a bent path with 0.5 m noise: the second
    /// stretch's map points put into the `enu` frame by `second`.
    fn two_stretches(
        second: &SimilarityAlignment2d,
        rng: &mut ChaCha8Rng,
    ) -> (SimilarityFit2d, SimilarityFit2d) {
        let truth = truth();
        let origin = ([0.0, 0.0], truth.to_enu([0.0, 0.0]));
        let mut fits = [origin; 2].map(|(p, q)| SimilarityFit2d::with_origin(p, q));
        for i in 0..120 {
            let s = f64::from(i) * 0.25;
            let p = [s, if s > 15.0 { s - 15.0 } else { 0.0 }];
            let (fit, alignment) = if s < 15.0 {
                (&mut fits[0], &truth)
            } else {
                (&mut fits[1], second)
            };
            let [x, y] = alignment.to_enu(p);
            let nx: f64 = StandardNormal.sample(rng);
            let ny: f64 = StandardNormal.sample(rng);
            fit.add(&pair(p, [x + 0.5 * nx, y + 0.5 * ny], 0.5))
                .expect("valid pair");
        }
        let [first, second] = fits;
        (first, second)
    }

    #[test]
    fn the_weighted_residual_is_chi_squared_with_the_pairs_degrees_of_freedom() {
        // 60 pairs, 2 × 60 − 4 = 116 degrees of freedom: over 50 draws the mean is about 116.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut sum = 0.0;
        for _ in 0..50 {
            let (first, _) = two_stretches(&truth(), &mut rng);
            assert_eq!(first.pairs(), 60);
            sum += first.weighted_residual().expect("determined");
        }
        let mean = sum / 50.0;
        assert!((105.0..127.0).contains(&mean), "{mean}");
    }

    #[test]
    fn stretches_of_one_similarity_agree_and_a_turned_one_does_not() {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let mut agreed = 0;
        for _ in 0..50 {
            let (first, second) = two_stretches(&truth(), &mut rng);
            agreed += usize::from(first.agrees_with(&second, 18.47));
        }
        // 99.9 % of draws agree.
        assert!(agreed >= 48, "{agreed} of 50");
        // The second stretch 3° and 1 m off: the path jumped where its frame says it did not.
        let turned = SimilarityAlignment2d {
            rotation_rad: truth().rotation_rad + 3f64.to_radians(),
            translation_m: [121.0, -45.0],
            ..truth()
        };
        let (first, second) = two_stretches(&turned, &mut rng);
        assert!(!first.agrees_with(&second, 18.47));
        assert!(!second.agrees_with(&first, 18.47));
        // One pair fixes no similarity of its own, but is tested against the other's.
        let origin = ([0.0, 0.0], truth().to_enu([0.0, 0.0]));
        let mut one = SimilarityFit2d::with_origin(origin.0, origin.1);
        one.add(&pair([3.0, 0.0], truth().to_enu([3.0, 0.0]), 0.5))
            .expect("valid");
        assert!(first.agrees_with(&one, 18.47));
        let mut stray = SimilarityFit2d::with_origin(origin.0, origin.1);
        let [x, y] = truth().to_enu([3.0, 0.0]);
        stray
            .add(&pair([3.0, 0.0], [x + 5.0, y], 0.5))
            .expect("valid");
        assert!(!first.agrees_with(&stray, 18.47));
        assert!(!stray.agrees_with(&first, 18.47));
        // Neither fixing a similarity, even together: nothing to test.
        assert!(one.agrees_with(&stray, 18.47));
    }

    #[test]
    fn a_moved_fit_is_the_fit_of_its_pairs_moved() {
        let truth = truth();
        let origin = ([1.0, 2.0], [100.0, 100.0]);
        let change = MapFrameChange {
            turn_scale: [0.8, 0.5],
            shift: [-3.0, 7.0],
        };
        let mut fit = SimilarityFit2d::with_origin(origin.0, origin.1);
        let mut moved = SimilarityFit2d::with_origin(origin.0, origin.1);
        for i in 0..6 {
            let p = [f64::from(i) * 2.0, (f64::from(i) * 0.7).sin()];
            let q = truth.to_enu(p);
            let q = [q[0] + 0.3 * f64::from(i % 3), q[1] - 0.2 * f64::from(i % 2)];
            fit.add(&pair(p, q, 0.5)).expect("valid");
            moved.add(&pair(change.apply(p), q, 0.5)).expect("valid");
        }
        let (a, b) = (
            fit.moved(&change).solve().expect("fit"),
            moved.solve().expect("fit"),
        );
        assert!((a.scale - b.scale).abs() < 1e-9, "{a:?} {b:?}");
        assert!((a.rotation_rad - b.rotation_rad).abs() < 1e-9);
        assert!((a.translation_m[0] - b.translation_m[0]).abs() < 1e-8);
        assert!((a.translation_m[1] - b.translation_m[1]).abs() < 1e-8);
        assert!((a.rms_residual_m - b.rms_residual_m).abs() < 1e-9);
        let (wa, wb) = (
            fit.moved(&change).weighted_residual(),
            moved.weighted_residual(),
        );
        assert!((wa.expect("fit") - wb.expect("fit")).abs() < 1e-8);
        // Back and forth is no change.
        let inverse = change.inverse().expect("invertible");
        let there_and_back = inverse.after(&change).apply([3.0, -4.0]);
        assert!((there_and_back[0] - 3.0).abs() < 1e-12 && (there_and_back[1] + 4.0).abs() < 1e-12);
    }

    #[test]
    fn one_point_or_one_pair_is_refused() {
        let mut fit = SimilarityFit2d::new();
        fit.add(&pair([1.0, 2.0], [3.0, 4.0], 1.0)).expect("valid");
        assert!(matches!(
            fit.solve(),
            Err(GeoRefError::TooFewPairs { count: 1 })
        ));
        fit.add(&pair([1.0, 2.0], [3.5, 4.0], 1.0)).expect("valid");
        assert!(matches!(fit.solve(), Err(GeoRefError::DegenerateGeometry)));
    }

    #[test]
    fn fits_about_one_origin_add_up_to_the_fit_of_all_their_pairs() {
        let truth = truth();
        let origin = ([5.0, 5.0], [100.0, 100.0]);
        let (mut all, mut first, mut second) = (
            SimilarityFit2d::with_origin(origin.0, origin.1),
            SimilarityFit2d::with_origin(origin.0, origin.1),
            SimilarityFit2d::with_origin(origin.0, origin.1),
        );
        for i in 0..10 {
            let p = [f64::from(i), f64::from(i * i) * 0.1];
            let [x, y] = truth.to_enu(p);
            let noisy = pair(p, [x + 0.3 * (f64::from(i) * 1.7).sin(), y], 0.5);
            all.add(&noisy).expect("valid");
            if i < 4 { &mut first } else { &mut second }
                .add(&noisy)
                .expect("valid");
        }
        first.add_fit(&second).expect("same origin");
        let (a, b) = (all.solve().expect("fit"), first.solve().expect("fit"));
        assert!(
            (a.scale - b.scale).abs() < 1e-12
                && (a.rms_residual_m - b.rms_residual_m).abs() < 1e-12
        );
        let mut elsewhere = SimilarityFit2d::new();
        elsewhere
            .add(&pair([0.0, 0.0], [0.0, 0.0], 1.0))
            .expect("valid");
        assert!(first.add_fit(&elsewhere).is_err());
    }

    #[test]
    fn a_bad_pair_is_named_and_leaves_the_fit_alone() {
        let mut fit = SimilarityFit2d::new();
        fit.add(&pair([0.0, 0.0], [0.0, 0.0], 1.0)).expect("valid");
        let before = fit;
        assert!(matches!(
            fit.add(&pair([f64::NAN, 0.0], [1.0, 1.0], 1.0)),
            Err(GeoRefError::NonFinite(_))
        ));
        assert!(matches!(
            fit.add(&pair([1.0, 0.0], [1.0, 1.0], 0.0)),
            Err(GeoRefError::InvalidCovariance { index: 1 })
        ));
        assert_eq!(fit, before);
    }
}
