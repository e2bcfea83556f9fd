//! The statistics of a set of relation errors: count, mean, root mean square and maximum of the
//! translational and rotational errors.

use serde::{Deserialize, Serialize};

use super::relation_residual::RelationResidual;

/// Mean, RMS and maximum of the translational and rotational errors of some relations.
///
/// With no relations every statistic is 0 and `count` says so. The `_deg` fields repeat the
/// rotational statistics in degrees for display.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorSummary {
    /// Number of relations summarised.
    pub count: usize,
    /// Mean translational error, metres.
    pub mean_translation_m: f64,
    /// Root mean square of the translational errors, metres.
    pub rms_translation_m: f64,
    /// Largest translational error, metres.
    pub max_translation_m: f64,
    /// Mean rotational error, radians.
    pub mean_rotation_rad: f64,
    /// Root mean square of the rotational errors, radians.
    pub rms_rotation_rad: f64,
    /// Largest rotational error, radians.
    pub max_rotation_rad: f64,
    /// Mean rotational error, degrees.
    pub mean_rotation_deg: f64,
    /// Root mean square of the rotational errors, degrees.
    pub rms_rotation_deg: f64,
    /// Largest rotational error, degrees.
    pub max_rotation_deg: f64,
}

impl ErrorSummary {
    /// Summarises `residuals`. A NaN error makes the means and RMS values NaN, so a broken
    /// estimate cannot look good; the maxima skip it.
    pub fn from_residuals(residuals: &[RelationResidual]) -> Self {
        if residuals.is_empty() {
            return ErrorSummary::default();
        }
        let count = residuals.len();
        let n = count as f64;
        let mut sum_t = 0.0;
        let mut sum_t2 = 0.0;
        let mut max_t: f64 = 0.0;
        let mut sum_r = 0.0;
        let mut sum_r2 = 0.0;
        let mut max_r: f64 = 0.0;
        for residual in residuals {
            let (t, r) = (residual.translation_m, residual.rotation_rad);
            sum_t += t;
            sum_t2 += t * t;
            max_t = max_t.max(t);
            sum_r += r;
            sum_r2 += r * r;
            max_r = max_r.max(r);
        }
        let mean_rotation_rad = sum_r / n;
        let rms_rotation_rad = (sum_r2 / n).sqrt();
        ErrorSummary {
            count,
            mean_translation_m: sum_t / n,
            rms_translation_m: (sum_t2 / n).sqrt(),
            max_translation_m: max_t,
            mean_rotation_rad,
            rms_rotation_rad,
            max_rotation_rad: max_r,
            mean_rotation_deg: mean_rotation_rad.to_degrees(),
            rms_rotation_deg: rms_rotation_rad.to_degrees(),
            max_rotation_deg: max_r.to_degrees(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn residual(translation_m: f64, rotation_rad: f64) -> RelationResidual {
        RelationResidual {
            relation_index: 0,
            t1_s: 0.0,
            t2_s: 1.0,
            translation_m,
            rotation_rad,
        }
    }

    #[test]
    fn test_empty_is_all_zero() {
        assert_eq!(ErrorSummary::from_residuals(&[]), ErrorSummary::default());
    }

    #[test]
    fn test_statistics() {
        let summary = ErrorSummary::from_residuals(&[residual(0.3, 0.0), residual(0.4, 0.02)]);
        assert_eq!(summary.count, 2);
        assert!((summary.mean_translation_m - 0.35).abs() < 1e-12);
        // sqrt((0.09 + 0.16) / 2) = sqrt(0.125)
        assert!((summary.rms_translation_m - 0.125_f64.sqrt()).abs() < 1e-12);
        assert_eq!(summary.max_translation_m, 0.4);
        assert!((summary.mean_rotation_rad - 0.01).abs() < 1e-12);
        assert!((summary.rms_rotation_rad - 0.0002_f64.sqrt()).abs() < 1e-12);
        assert_eq!(summary.max_rotation_rad, 0.02);
        assert!((summary.mean_rotation_deg - 0.01_f64.to_degrees()).abs() < 1e-12);
        assert!((summary.max_rotation_deg - 0.02_f64.to_degrees()).abs() < 1e-12);
    }

    #[test]
    fn test_serializes_every_field() {
        let json = serde_json::to_string(&ErrorSummary::from_residuals(&[residual(1.0, 0.5)]))
            .expect("plain numbers serialize");
        for key in [
            "\"count\":1",
            "\"mean_translation_m\":1.0",
            "\"rms_rotation_rad\":0.5",
            "\"max_rotation_deg\":",
        ] {
            assert!(json.contains(key), "{key} missing from {json}");
        }
    }
}
