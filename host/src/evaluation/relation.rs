//! One ground-truth relation: the true motion between the robot's poses at two timestamps.
//!
//! In the files of Kümmerle et al. 2009 (`*.relations`, `t1 t2 x y z roll pitch yaw`) the pose
//! `(x, y, yaw)` is the robot's pose at `t2` expressed in the robot frame at `t1`; in the
//! naming of [`Pose2`] that is `robot1_from_robot2`, here `true_from1_to2`.

use crate::geometry::Pose2;

use super::relation_residual::RelationResidual;

/// The true pose at `t2_s` seen from the pose at `t1_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relation {
    /// First timestamp, seconds.
    pub t1_s: f64,
    /// Second timestamp, seconds.
    pub t2_s: f64,
    /// The robot frame at `t2_s` expressed in the robot frame at `t1_s` (`robot1_from_robot2`).
    pub true_from1_to2: Pose2,
}

impl Relation {
    /// A relation between `t1_s` and `t2_s` whose true motion is `true_from1_to2`.
    pub fn new(t1_s: f64, t2_s: f64, true_from1_to2: Pose2) -> Self {
        Relation {
            t1_s,
            t2_s,
            true_from1_to2,
        }
    }

    /// The error of this relation for an estimate that puts the robot at `pose1_in_map` at
    /// `t1_s` and at `pose2_in_map` at `t2_s`: the estimated motion is
    /// `δ = inverse(pose1_in_map) * pose2_in_map`, and the error pose
    /// `ε = inverse(true_from1_to2) * δ`. `relation_index` is stored in the result to name
    /// this relation.
    pub fn residual(
        &self,
        relation_index: usize,
        pose1_in_map: Pose2,
        pose2_in_map: Pose2,
    ) -> RelationResidual {
        let estimated_from1_to2 = pose1_in_map.inverse() * pose2_in_map;
        RelationResidual::new(
            relation_index,
            self.t1_s,
            self.t2_s,
            self.true_from1_to2,
            estimated_from1_to2,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_exact_estimate_has_no_error() {
        let pose1_in_map = Pose2::new(3.0, -1.0, 2.5);
        let true_from1_to2 = Pose2::new(0.4, 0.1, -0.2);
        let relation = Relation::new(1.0, 2.0, true_from1_to2);
        let residual = relation.residual(7, pose1_in_map, pose1_in_map * true_from1_to2);
        assert_eq!(residual.relation_index, 7);
        assert_eq!((residual.t1_s, residual.t2_s), (1.0, 2.0));
        assert!(residual.translation_m < 1e-12, "{residual:?}");
        assert!(residual.rotation_rad < 1e-12, "{residual:?}");
    }

    #[test]
    fn test_error_does_not_depend_on_the_map_frame() {
        // The same estimated motion, started from two different poses in the map, has the
        // same error: the measure only sees relative motion.
        let relation = Relation::new(0.0, 1.0, Pose2::new(1.0, 0.0, 0.0));
        let estimated_from1_to2 = Pose2::new(1.2, 0.1, 0.05);
        let a = Pose2::new(0.0, 0.0, 0.0);
        let b = Pose2::new(-7.0, 4.0, -2.0);
        let at_a = relation.residual(0, a, a * estimated_from1_to2);
        let at_b = relation.residual(0, b, b * estimated_from1_to2);
        assert!((at_a.translation_m - at_b.translation_m).abs() < 1e-12);
        assert!((at_a.rotation_rad - at_b.rotation_rad).abs() < 1e-12);
        assert!((at_a.translation_m - 0.2_f64.hypot(0.1)).abs() < 1e-12);
        assert!((at_a.rotation_rad - 0.05).abs() < 1e-12);
    }
}
