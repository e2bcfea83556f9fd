//! Robust kernels: costs that grow slower than the squared error, so that a wrong constraint
//! (typically a false loop closure) pulls less on the graph.
//!
//! A kernel maps an edge's squared Mahalanobis error `s = eᵀ Ω e` (its χ²) to a cost `ρ(s)`.
//! The optimiser applies it by iteratively reweighted least squares: at every linearisation the
//! edge's information is scaled by the weight `ρ'(s)`, which is 1 for small errors and falls off
//! for large ones. Both kernels here equal `s` near zero, so inliers keep their full weight.

use super::error::PoseGraphError;

/// A robust cost applied to one edge's χ².
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RobustKernel {
    /// Quadratic up to a Mahalanobis distance `delta` (in standard deviations), linear beyond:
    /// `ρ(s) = s` for `√s ≤ delta`, else `2·delta·√s − delta²`. Still convex, so it keeps
    /// convergence well behaved; an outlier's pull stays bounded but never vanishes.
    Huber {
        /// Mahalanobis distance at which the cost turns from quadratic to linear; `> 0`.
        delta: f64,
    },
    /// `ρ(s) = scale² · ln(1 + s / scale²)`: the pull of an error far beyond `scale` standard
    /// deviations almost vanishes. Not convex, so it needs a reasonable initial guess.
    Cauchy {
        /// Mahalanobis distance around which the weight halves; `> 0`.
        scale: f64,
    },
    /// Dynamic covariance scaling (Agarwal, Tipaldi, Spinello, Stachniss and Burgard 2013,
    /// "Robust map optimization using dynamic covariance scaling"): the edge's information is
    /// scaled by `s² = min(1, 2Φ/(Φ + χ²))²`, so an edge that disagrees with the rest of the
    /// graph by far more than `Φ` all but switches itself off. The cost whose derivative that
    /// weight is: `χ²` up to `Φ`, then `3Φ − 4Φ²/(Φ + χ²)`, bounded by `3Φ`. Not convex.
    Dcs {
        /// `Φ`, the χ² up to which the edge counts in full; `> 0`.
        phi: f64,
    },
}

impl RobustKernel {
    /// Checks that the kernel parameter is finite and strictly positive.
    ///
    /// # Errors
    ///
    /// [`PoseGraphError::NonFinite`] for a NaN or infinite parameter,
    /// [`PoseGraphError::InvalidKernel`] for one that is zero or negative.
    pub fn validate(&self) -> Result<(), PoseGraphError> {
        let parameter = match *self {
            RobustKernel::Huber { delta } => delta,
            RobustKernel::Cauchy { scale } => scale,
            RobustKernel::Dcs { phi } => phi,
        };
        if !parameter.is_finite() {
            return Err(PoseGraphError::NonFinite("a robust kernel parameter"));
        }
        if parameter <= 0.0 {
            return Err(PoseGraphError::InvalidKernel);
        }
        Ok(())
    }

    /// The robust cost `ρ(chi2)` of an edge whose squared Mahalanobis error is `chi2` (`≥ 0`).
    pub fn cost(&self, chi2: f64) -> f64 {
        match *self {
            RobustKernel::Huber { delta } => {
                if chi2 <= delta * delta {
                    chi2
                } else {
                    2.0 * delta * chi2.sqrt() - delta * delta
                }
            }
            RobustKernel::Cauchy { scale } => {
                let scale_sq = scale * scale;
                scale_sq * (chi2 / scale_sq).ln_1p()
            }
            RobustKernel::Dcs { phi } => {
                if chi2 <= phi {
                    chi2
                } else {
                    3.0 * phi - 4.0 * phi * phi / (phi + chi2)
                }
            }
        }
    }

    /// The reweighting factor `ρ'(chi2)` in `(0, 1]` by which the edge's information is scaled
    /// when the graph is linearised at an edge error of `chi2`.
    pub fn weight(&self, chi2: f64) -> f64 {
        match *self {
            RobustKernel::Huber { delta } => {
                if chi2 <= delta * delta {
                    1.0
                } else {
                    delta / chi2.sqrt()
                }
            }
            RobustKernel::Cauchy { scale } => 1.0 / (1.0 + chi2 / (scale * scale)),
            RobustKernel::Dcs { phi } => {
                let scaling = (2.0 * phi / (phi + chi2)).min(1.0);
                scaling * scaling
            }
        }
    }
}

/// The cost of an edge with squared Mahalanobis error `chi2` under an optional `kernel`.
pub(crate) fn robust_cost(kernel: Option<RobustKernel>, chi2: f64) -> f64 {
    kernel.map_or(chi2, |kernel| kernel.cost(chi2))
}

/// The reweighting factor of an edge with squared Mahalanobis error `chi2` under an optional
/// `kernel`.
pub(crate) fn robust_weight(kernel: Option<RobustKernel>, chi2: f64) -> f64 {
    kernel.map_or(1.0, |kernel| kernel.weight(chi2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_kernels_are_quadratic_near_zero() {
        for kernel in [
            RobustKernel::Huber { delta: 1.5 },
            RobustKernel::Cauchy { scale: 2.0 },
            RobustKernel::Dcs { phi: 1.0 },
        ] {
            assert!((kernel.cost(1e-6) - 1e-6).abs() < 1e-11, "{kernel:?}");
            assert!((kernel.weight(1e-6) - 1.0).abs() < 1e-6, "{kernel:?}");
        }
    }

    #[test]
    fn test_weight_is_derivative_of_cost() {
        for kernel in [
            RobustKernel::Huber { delta: 1.5 },
            RobustKernel::Cauchy { scale: 2.0 },
            RobustKernel::Dcs { phi: 1.0 },
        ] {
            for chi2 in [0.5, 2.0, 9.0, 100.0] {
                let step = 1e-6;
                let slope = (kernel.cost(chi2 + step) - kernel.cost(chi2 - step)) / (2.0 * step);
                assert!(
                    (slope - kernel.weight(chi2)).abs() < 1e-6,
                    "{kernel:?} at {chi2}"
                );
            }
        }
    }

    #[test]
    fn test_huber_is_linear_in_distance_beyond_delta() {
        let kernel = RobustKernel::Huber { delta: 1.0 };
        let at_10 = kernel.cost(100.0);
        let at_20 = kernel.cost(400.0);
        assert!((at_20 - at_10 - 20.0).abs() < 1e-12);
    }

    #[test]
    fn test_validate_rejects_bad_parameters() {
        assert_eq!(
            RobustKernel::Huber { delta: 0.0 }.validate(),
            Err(PoseGraphError::InvalidKernel)
        );
        assert_eq!(
            RobustKernel::Cauchy { scale: -1.0 }.validate(),
            Err(PoseGraphError::InvalidKernel)
        );
        assert!(matches!(
            RobustKernel::Huber { delta: f64::NAN }.validate(),
            Err(PoseGraphError::NonFinite(_))
        ));
        assert_eq!(RobustKernel::Cauchy { scale: 3.0 }.validate(), Ok(()));
    }
}
