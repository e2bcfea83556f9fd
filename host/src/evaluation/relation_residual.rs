//! The error of one relation: how far the estimated motion between two timestamps is from the
//! true one, as a translation length and an angle.

use serde::{Deserialize, Serialize};

use crate::geometry::Pose2;

/// The error pose `ε = inverse(true_from1_to2) * estimated_from1_to2` of one relation, reduced
/// to its translation length and the magnitude of its angle.
///
/// `|ε.t|` is the distance between where the estimate and the truth put the robot at `t2`,
/// both seen from the robot at `t1`. (Composing the other way round, `δ * inverse(δ*)`, gives
/// the same angle but a translation that also swings with the rotation error.)
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RelationResidual {
    /// Index of the relation in the list that was evaluated.
    pub relation_index: usize,
    /// First timestamp of the relation, seconds.
    pub t1_s: f64,
    /// Second timestamp of the relation, seconds.
    pub t2_s: f64,
    /// Translational error `|ε.t|`, metres.
    pub translation_m: f64,
    /// Rotational error `|ε.θ|` with `ε.θ` wrapped into `(-π, π]`, radians.
    pub rotation_rad: f64,
}

impl RelationResidual {
    /// The error of the motion `estimated_from1_to2` against `true_from1_to2`, for the
    /// relation numbered `relation_index` between `t1_s` and `t2_s`.
    pub fn new(
        relation_index: usize,
        t1_s: f64,
        t2_s: f64,
        true_from1_to2: Pose2,
        estimated_from1_to2: Pose2,
    ) -> Self {
        let [translation_m, rotation_rad] = motion_error(true_from1_to2, estimated_from1_to2);
        RelationResidual {
            relation_index,
            t1_s,
            t2_s,
            translation_m,
            rotation_rad,
        }
    }
}

/// The error of the motion `estimated_from1_to2` against `true_from1_to2`, as
/// [`RelationResidual`] measures it: `[|ε.t|` in metres, `|ε.θ|` in radians`]` of the error
/// pose `ε = inverse(true_from1_to2) * estimated_from1_to2`.
pub fn motion_error(true_from1_to2: Pose2, estimated_from1_to2: Pose2) -> [f64; 2] {
    let error = true_from1_to2.inverse() * estimated_from1_to2;
    [
        error.x_m.hypot(error.y_m),
        // Composition wraps the angle; wrapping once more keeps a hand-built `Pose2` with
        // an unwrapped angle from leaking into the result.
        Pose2::new(0.0, 0.0, error.theta_rad).theta_rad.abs(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn test_known_offset() {
        // The estimate overshoots a 1 m forward motion by 0.3 m and 0.4 m to the left, and
        // turns 0.1 rad too far.
        let truth = Pose2::new(1.0, 0.0, 0.0);
        let estimate = Pose2::new(1.3, 0.4, 0.1);
        let residual = RelationResidual::new(0, 0.0, 1.0, truth, estimate);
        assert!((residual.translation_m - 0.5).abs() < 1e-12, "{residual:?}");
        assert!((residual.rotation_rad - 0.1).abs() < 1e-12, "{residual:?}");
    }

    #[test]
    fn test_error_translation_is_in_the_true_frame() {
        // The true motion turns by 90°; an estimate with the right angle but 1 m too far along
        // map x is 1 m off, whatever frame it is measured in.
        let truth = Pose2::new(2.0, 0.0, PI / 2.0);
        let estimate = Pose2::new(3.0, 0.0, PI / 2.0);
        let residual = RelationResidual::new(0, 0.0, 1.0, truth, estimate);
        assert!((residual.translation_m - 1.0).abs() < 1e-12);
        assert!(residual.rotation_rad < 1e-12);
    }

    #[test]
    fn test_rotation_wraps() {
        // 179° against -179° is 2° apart, not 358°.
        let truth = Pose2::new(0.0, 0.0, 179f64.to_radians());
        let estimate = Pose2::new(0.0, 0.0, -179f64.to_radians());
        let residual = RelationResidual::new(0, 0.0, 1.0, truth, estimate);
        assert!((residual.rotation_rad - 2f64.to_radians()).abs() < 1e-12);
        // An unwrapped hand-built angle is wrapped too.
        let unwrapped = Pose2 {
            theta_rad: 4.0 * PI + 0.25,
            ..Pose2::IDENTITY
        };
        let residual = RelationResidual::new(0, 0.0, 1.0, Pose2::IDENTITY, unwrapped);
        assert!((residual.rotation_rad - 0.25).abs() < 1e-12);
    }
}
