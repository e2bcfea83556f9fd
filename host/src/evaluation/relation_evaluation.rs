//! Scoring a trajectory on a set of relations: pair each relation's two timestamps with poses
//! of the trajectory, compute each covered relation's error, and summarise.
//!
//! A relation is covered when both of its timestamps have a trajectory pose within
//! [`PairingOptions::timestamp_tolerance_s`]; the others are skipped and counted, never
//! guessed. The summary is only meaningful together with the coverage: compare two
//! trajectories on the same covered set.

use serde::{Deserialize, Serialize};

use super::error_summary::ErrorSummary;
use super::relation::Relation;
use super::relation_residual::RelationResidual;
use super::trajectory::Trajectory;

/// How relation timestamps are paired with trajectory poses.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairingOptions {
    /// A relation timestamp pairs with the nearest trajectory pose at most this far away in
    /// time, seconds. The default, 1 ms, absorbs timestamps printed with fewer digits than the
    /// log's and is far below the time between two laser scans.
    pub timestamp_tolerance_s: f64,
}

impl Default for PairingOptions {
    /// A 1 ms tolerance.
    fn default() -> Self {
        PairingOptions {
            timestamp_tolerance_s: 1e-3,
        }
    }
}

/// The outcome of [`evaluate_relations`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RelationEvaluation {
    /// Number of relations given.
    pub given: usize,
    /// Relations with a trajectory pose for both timestamps.
    pub covered: usize,
    /// Relations without a trajectory pose for at least one timestamp (`given - covered`).
    pub skipped: usize,
    /// The error of each covered relation, in the order the relations were given.
    pub residuals: Vec<RelationResidual>,
    /// Statistics of `residuals`.
    pub summary: ErrorSummary,
}

/// Scores `trajectory` on `relations`: each relation whose two timestamps both pair with a pose
/// of `trajectory` (see [`PairingOptions`]) gets a [`RelationResidual`] from those two poses
/// (see [`Relation::residual`]); the others are counted as skipped.
pub fn evaluate_relations(
    relations: &[Relation],
    trajectory: &Trajectory,
    options: &PairingOptions,
) -> RelationEvaluation {
    let tolerance_s = options.timestamp_tolerance_s;
    let residuals: Vec<RelationResidual> = relations
        .iter()
        .enumerate()
        .filter_map(|(index, relation)| {
            let pose1 = trajectory.pose_near(relation.t1_s, tolerance_s)?;
            let pose2 = trajectory.pose_near(relation.t2_s, tolerance_s)?;
            Some(relation.residual(index, pose1.pose_in_map, pose2.pose_in_map))
        })
        .collect();
    RelationEvaluation {
        given: relations.len(),
        covered: residuals.len(),
        skipped: relations.len() - residuals.len(),
        summary: ErrorSummary::from_residuals(&residuals),
        residuals,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluation::StampedPose;
    use crate::geometry::Pose2;

    /// A robot driving a square of side 2 m, one pose a second, turning 90° at each corner.
    fn square() -> Vec<StampedPose> {
        let corners = [
            Pose2::new(0.0, 0.0, 0.0),
            Pose2::new(2.0, 0.0, std::f64::consts::FRAC_PI_2),
            Pose2::new(2.0, 2.0, std::f64::consts::PI),
            Pose2::new(0.0, 2.0, -std::f64::consts::FRAC_PI_2),
        ];
        corners
            .iter()
            .enumerate()
            .map(|(i, &pose)| StampedPose::new(100.0 + i as f64, pose))
            .collect()
    }

    /// The true relations between consecutive corners and one across the square.
    fn relations(poses: &[StampedPose]) -> Vec<Relation> {
        [(0, 1), (1, 2), (2, 3), (0, 2)]
            .iter()
            .map(|&(i, j)| {
                Relation::new(
                    poses[i].timestamp_s,
                    poses[j].timestamp_s,
                    poses[i].pose_in_map.inverse() * poses[j].pose_in_map,
                )
            })
            .collect()
    }

    #[test]
    fn test_true_trajectory_has_zero_error() {
        let poses = square();
        let evaluation = evaluate_relations(
            &relations(&poses),
            &Trajectory::new(poses),
            &PairingOptions::default(),
        );
        assert_eq!(
            (evaluation.given, evaluation.covered, evaluation.skipped),
            (4, 4, 0)
        );
        assert!(evaluation.summary.max_translation_m < 1e-12);
        assert!(evaluation.summary.max_rotation_rad < 1e-12);
    }

    #[test]
    fn test_whole_trajectory_moved_has_zero_error() {
        // Relative poses do not see where the trajectory sits in the map.
        let poses = square();
        let map_from_other = Pose2::new(5.0, -3.0, 1.0);
        let moved: Trajectory = poses
            .iter()
            .map(|p| StampedPose::new(p.timestamp_s, map_from_other * p.pose_in_map))
            .collect();
        let evaluation = evaluate_relations(&relations(&poses), &moved, &PairingOptions::default());
        assert_eq!(evaluation.covered, 4);
        assert!(evaluation.summary.max_translation_m < 1e-12);
        assert!(evaluation.summary.max_rotation_rad < 1e-12);
    }

    /// (relation index, translational error, rotational error) of each covered relation when
    /// the third corner of the square is estimated at `third_corner_in_map`.
    fn errors_with_third_corner_at(third_corner_in_map: Pose2) -> Vec<(usize, f64, f64)> {
        let poses = square();
        let mut estimate = poses.clone();
        estimate[2].pose_in_map = third_corner_in_map;
        let evaluation = evaluate_relations(
            &relations(&poses),
            &Trajectory::new(estimate),
            &PairingOptions::default(),
        );
        assert_eq!(evaluation.summary.count, 4);
        evaluation
            .residuals
            .iter()
            .map(|r| (r.relation_index, r.translation_m, r.rotation_rad))
            .collect()
    }

    fn assert_errors(actual: (usize, f64, f64), translation_m: f64, rotation_rad: f64) {
        assert!(
            (actual.1 - translation_m).abs() < 1e-12 && (actual.2 - rotation_rad).abs() < 1e-12,
            "relation {}: got {actual:?}, expected ({translation_m}, {rotation_rad})",
            actual.0
        );
    }

    #[test]
    fn test_one_shifted_pose() {
        // The third corner (2, 2) is estimated 0.3 m too far along map x. Relations (1, 2) and
        // (0, 2) end there and (2, 3) starts there; each is 0.3 m off, without rotation error.
        let errors = errors_with_third_corner_at(Pose2::new(2.3, 2.0, std::f64::consts::PI));
        assert_errors(errors[0], 0.0, 0.0);
        assert_errors(errors[1], 0.3, 0.0);
        assert_errors(errors[2], 0.3, 0.0);
        assert_errors(errors[3], 0.3, 0.0);
    }

    #[test]
    fn test_one_turned_pose() {
        // The third corner is estimated turned 0.1 rad too far. Relations ending there are off
        // by the turn only; the 2 m leg starting there swings its end by the chord 4 sin(0.05).
        let errors = errors_with_third_corner_at(Pose2::new(2.0, 2.0, std::f64::consts::PI + 0.1));
        assert_errors(errors[0], 0.0, 0.0);
        assert_errors(errors[1], 0.0, 0.1);
        assert_errors(errors[2], 4.0 * 0.05_f64.sin(), 0.1);
        assert_errors(errors[3], 0.0, 0.1);
    }

    #[test]
    fn test_pairing_tolerance() {
        let poses = square();
        let mut relations = relations(&poses);
        // Printed with fewer digits: 0.4 ms off, within the default 1 ms.
        relations[0].t1_s += 0.0004;
        // 5 ms off: skipped by default.
        relations[1].t2_s -= 0.005;
        let trajectory = Trajectory::new(poses);
        let evaluation = evaluate_relations(&relations, &trajectory, &PairingOptions::default());
        assert_eq!(
            (evaluation.given, evaluation.covered, evaluation.skipped),
            (4, 3, 1)
        );
        let indices: Vec<usize> = evaluation
            .residuals
            .iter()
            .map(|r| r.relation_index)
            .collect();
        assert_eq!(indices, [0, 2, 3]);
        // Exact pairing drops the 0.4 ms one too; a 10 ms tolerance keeps all four.
        let exact = PairingOptions {
            timestamp_tolerance_s: 0.0,
        };
        assert_eq!(
            evaluate_relations(&relations, &trajectory, &exact).covered,
            2
        );
        let loose = PairingOptions {
            timestamp_tolerance_s: 0.01,
        };
        assert_eq!(
            evaluate_relations(&relations, &trajectory, &loose).covered,
            4
        );
    }

    #[test]
    fn test_no_relations() {
        let evaluation =
            evaluate_relations(&[], &Trajectory::new(square()), &PairingOptions::default());
        assert_eq!(evaluation, RelationEvaluation::default());
    }
}
