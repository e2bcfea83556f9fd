//! Whether the scans of a log bear a relation out: how many of the second scan's end points
//! land on the first scan's when the second is placed at a given relative pose.
//!
//! Computed at the estimated and at the true relative pose of a relation, the share tells two
//! cases apart that the error alone does not:
//!
//! * the true pose lines the two scans up as well as the estimate or better: the estimate is
//!   wrong by its error;
//! * the true pose lines them up far worse: the log's own scans dispute the relation (a
//!   relation written for other timestamps, a hand-verified alignment that slipped), and its
//!   error measures the relation as much as the estimate.
//!
//! The error measure itself is left as Kümmerle et al. define it; this only says which of its
//! relations the scans dispute ([`RelationAgreement::is_disputed`]).

use serde::{Deserialize, Serialize};

use super::error_summary::ErrorSummary;
use super::relation::Relation;
use super::relation_evaluation::{PairingOptions, RelationEvaluation};
use super::trajectory::Trajectory;
use crate::geometry::Pose2;
use crate::scan_match::Scan;
use crate::slam::point_grid::PointGrid;

/// End points within this distance of the other scan's count as agreeing, metres: a few
/// beam-range noises, well under the spacing of the beams at a few metres.
pub const AGREEMENT_DISTANCE_M: f64 = 0.05;

/// A relation is disputed when its true pose leaves a share of the second scan on the first
/// that is lower by more than this than the share the estimate leaves.
pub const DISPUTE_MARGIN: f64 = 0.2;

/// Two scans, the first's end points indexed, to place the second on it at several poses.
#[derive(Clone, Debug)]
pub struct ScanAgreement {
    /// The first scan's end points, robot frame.
    grid: PointGrid,
    /// The second scan's end points, robot frame.
    points2: Vec<[f64; 2]>,
    within_m: f64,
}

impl ScanAgreement {
    /// `scan1` and `scan2`, end points within `within_m` counting as agreeing. `None` when
    /// either scan has no end point.
    pub fn new(scan1: &Scan, scan2: &Scan, within_m: f64) -> Option<Self> {
        let mut grid = PointGrid::new(within_m);
        for point in scan1.points_in_robot().iter().flatten() {
            grid.push(*point);
        }
        let points2: Vec<[f64; 2]> = scan2.points_in_robot().iter().flatten().copied().collect();
        (!grid.points().is_empty() && !points2.is_empty()).then_some(ScanAgreement {
            grid,
            points2,
            within_m,
        })
    }

    /// The share of the second scan's end points within the distance of an end point of the
    /// first, with the second placed at `robot1_from_robot2` in the first's robot frame.
    pub fn share_at(&self, robot1_from_robot2: Pose2) -> f64 {
        let agreeing = self
            .points2
            .iter()
            .filter(|&&p| {
                let moved = robot1_from_robot2.transform_point(p);
                self.grid.any_within(moved, self.within_m)
            })
            .count();
        agreeing as f64 / self.points2.len() as f64
    }
}

/// How well the scans at a relation's two timestamps line up at the estimated and at the true
/// relative pose ([`ScanAgreement`] within [`AGREEMENT_DISTANCE_M`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RelationAgreement {
    /// The relation's index in the list that was evaluated.
    pub relation_index: usize,
    /// First timestamp, seconds.
    pub t1_s: f64,
    /// Second timestamp, seconds.
    pub t2_s: f64,
    /// Share of the second scan's end points on the first's at the estimated relative pose.
    pub estimated_share: f64,
    /// The same at the true relative pose.
    pub true_share: f64,
}

impl RelationAgreement {
    /// Whether the scans line up worse at the true pose than at the estimate by more than
    /// [`DISPUTE_MARGIN`].
    pub fn is_disputed(&self) -> bool {
        self.true_share < self.estimated_share - DISPUTE_MARGIN
    }
}

/// Which relations of an evaluation the log's scans dispute, and the error without them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AgreementReport {
    /// Relations whose two scans were found (each with an end point).
    pub checked: usize,
    /// The disputed ones ([`RelationAgreement::is_disputed`]), in the order evaluated.
    pub disputed: Vec<RelationAgreement>,
    /// The error over the checked relations that are not disputed. The measure remains the
    /// one over every covered relation; this says how much of it the disputed ones make.
    pub undisputed_summary: ErrorSummary,
}

impl AgreementReport {
    /// Checks each relation `evaluation` covered (an evaluation of `trajectory` on
    /// `relations`, paired by `pairing`) on the scans `scan_at` finds for its two timestamps.
    pub fn new<'a>(
        relations: &[Relation],
        evaluation: &RelationEvaluation,
        trajectory: &Trajectory,
        pairing: &PairingOptions,
        scan_at: impl Fn(f64) -> Option<&'a Scan>,
    ) -> Self {
        let tolerance_s = pairing.timestamp_tolerance_s;
        let mut undisputed = Vec::new();
        let mut disputed = Vec::new();
        for residual in &evaluation.residuals {
            let (Some(relation), Some(pose1), Some(pose2), Some(scan1), Some(scan2)) = (
                relations.get(residual.relation_index),
                trajectory.pose_near(residual.t1_s, tolerance_s),
                trajectory.pose_near(residual.t2_s, tolerance_s),
                scan_at(residual.t1_s),
                scan_at(residual.t2_s),
            ) else {
                continue;
            };
            let Some(scans) = ScanAgreement::new(scan1, scan2, AGREEMENT_DISTANCE_M) else {
                continue;
            };
            let estimated = pose1.pose_in_map.inverse() * pose2.pose_in_map;
            let agreement = RelationAgreement {
                relation_index: residual.relation_index,
                t1_s: residual.t1_s,
                t2_s: residual.t2_s,
                estimated_share: scans.share_at(estimated),
                true_share: scans.share_at(relation.true_from1_to2),
            };
            if agreement.is_disputed() {
                disputed.push(agreement);
            } else {
                undisputed.push(*residual);
            }
        }
        AgreementReport {
            checked: undisputed.len() + disputed.len(),
            undisputed_summary: ErrorSummary::from_residuals(&undisputed),
            disputed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluation::{StampedPose, evaluate_relations};
    use crate::scan_match::synthetic::{cast_front_scan, irregular_room_walls};

    #[test]
    fn scans_agree_at_their_true_relative_pose_and_not_off_it() {
        let walls = irregular_room_walls();
        let pose1 = Pose2::new(0.2, -0.1, 0.1);
        let pose2 = Pose2::new(0.6, 0.1, 0.5);
        let (scan1, scan2) = (
            cast_front_scan(&walls, pose1),
            cast_front_scan(&walls, pose2),
        );
        let truth = pose1.inverse() * pose2;
        let scans = ScanAgreement::new(&scan1, &scan2, AGREEMENT_DISTANCE_M).unwrap();
        let at_truth = scans.share_at(truth);
        let turned = truth * Pose2::new(0.0, 0.0, 5f64.to_radians());
        let off = scans.share_at(turned);
        assert!(at_truth > 0.8, "{at_truth}");
        assert!(off < at_truth - DISPUTE_MARGIN, "{off} against {at_truth}");
    }

    #[test]
    fn an_empty_scan_has_no_share() {
        let scan = cast_front_scan(&irregular_room_walls(), Pose2::IDENTITY);
        let empty = Scan::from_points_in_robot(vec![None; 3]);
        assert!(ScanAgreement::new(&scan, &empty, 0.05).is_none());
        assert!(ScanAgreement::new(&empty, &scan, 0.05).is_none());
    }

    #[test]
    fn a_relation_is_disputed_when_its_truth_lines_the_scans_up_worse() {
        let walls = irregular_room_walls();
        let pose1 = Pose2::new(0.0, 0.0, 0.0);
        let pose2 = Pose2::new(0.5, 0.2, 0.3);
        let scans = [
            cast_front_scan(&walls, pose1),
            cast_front_scan(&walls, pose2),
        ];
        let trajectory = Trajectory::new(vec![
            StampedPose::new(1.0, pose1),
            StampedPose::new(2.0, pose2),
        ]);
        let scan_at = |t_s: f64| scans.get((t_s - 1.0).round() as usize);
        let pairing = PairingOptions::default();
        let estimate = pose1.inverse() * pose2;
        let wrong_truth = estimate * Pose2::new(0.0, 0.0, 5f64.to_radians());

        let relations = [
            Relation::new(1.0, 2.0, estimate),
            Relation::new(1.0, 2.0, wrong_truth),
            Relation::new(1.0, 3.0, estimate),
        ];
        let evaluation = evaluate_relations(&relations, &trajectory, &pairing);
        let report = AgreementReport::new(&relations, &evaluation, &trajectory, &pairing, scan_at);
        assert_eq!(report.checked, 2, "the third has no pose at 3 s");
        assert_eq!(report.disputed.len(), 1);
        assert_eq!(report.disputed[0].relation_index, 1);
        assert_eq!(report.undisputed_summary.count, 1);
        assert_eq!(report.undisputed_summary.mean_rotation_rad, 0.0);
    }
}
