//! The loop closures that entered the pose graph, against a reference trajectory: which of
//! them the reference agrees with.
//!
//! A loop closure measures one scan's pose in the frame of an earlier one. Where a reference
//! trajectory gives both scans a pose, it gives that relative pose too, and a closure far
//! from it is either wrong (a place that merely looked alike) or right where the reference
//! is not (the references are corrected trajectories, not surveyed truth). The count tells
//! whether the closure test lets wrong matches through (one wrong constraint can bend a
//! building) or whether a map that is off lacks right closures instead.

use host::evaluation::motion_error;
use host::geometry::Pose2;
use host::slam::ClosureConstraint;
use serde::Serialize;

/// A closure this far from the reference's relative pose, or farther, is named: translation
/// (m), rotation (rad). Right closures lie centimetres from it where the reference is good.
pub const OFF_REFERENCE_FROM: [f64; 2] = [1.0, 5.0 * std::f64::consts::PI / 180.0];

/// A closure far from the reference's relative pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ClosureOffReference {
    /// The scan whose pose is the closure's frame, by its number in the log.
    pub from_scan: usize,
    /// The scan that was found there.
    pub to_scan: usize,
    /// How far the measured pose lies from the reference's, m.
    pub error_m: f64,
    /// And in heading, degrees.
    pub error_deg: f64,
    /// Whether the final refinement added it.
    pub refinement: bool,
}

/// What the reference says of the closures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClosureCheck {
    /// Constraints whose two scans both have a reference pose.
    pub checked: usize,
    /// Of those, the loop closures made during the run (the rest came from the final
    /// refinement).
    pub checked_during_run: usize,
    /// The largest translational error among the checked ones, m (0 when none were).
    pub max_error_m: f64,
    /// Those at least [`OFF_REFERENCE_FROM`] from the reference's relative pose.
    pub off_reference: Vec<ClosureOffReference>,
}

impl ClosureCheck {
    /// Checks `closures` against `reference_pose(scan)`, the reference's pose of a scan by its
    /// number (`None` where the reference has none).
    pub fn of(
        closures: &[ClosureConstraint],
        reference_pose: impl Fn(usize) -> Option<Pose2>,
    ) -> Self {
        let mut check = ClosureCheck {
            checked: 0,
            checked_during_run: 0,
            max_error_m: 0.0,
            off_reference: Vec::new(),
        };
        for closure in closures {
            let (Some(from), Some(to)) = (
                reference_pose(closure.from_scan),
                reference_pose(closure.to_scan),
            ) else {
                continue;
            };
            let [error_m, error_rad] = motion_error(from.inverse() * to, closure.to_in_from);
            check.checked += 1;
            check.checked_during_run += usize::from(!closure.refinement);
            check.max_error_m = check.max_error_m.max(error_m);
            if error_m >= OFF_REFERENCE_FROM[0] || error_rad >= OFF_REFERENCE_FROM[1] {
                check.off_reference.push(ClosureOffReference {
                    from_scan: closure.from_scan,
                    to_scan: closure.to_scan,
                    error_m,
                    error_deg: error_rad.to_degrees(),
                    refinement: closure.refinement,
                });
            }
        }
        check
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn closure(from_scan: usize, to_scan: usize, to_in_from: Pose2) -> ClosureConstraint {
        ClosureConstraint {
            from_scan,
            to_scan,
            to_in_from,
            refinement: false,
        }
    }

    #[test]
    fn a_closure_at_a_look_alike_place_is_named_and_a_right_one_is_not() {
        // Scan 0 at the origin facing +x, scan 5 four metres ahead turned 90°.
        let reference = |scan: usize| match scan {
            0 => Some(Pose2::new(1.0, 2.0, 0.5)),
            5 => Some(Pose2::new(1.0, 2.0, 0.5) * Pose2::new(4.0, 0.0, 1.5)),
            _ => None,
        };
        let right = closure(0, 5, Pose2::new(4.03, -0.02, 1.51));
        let shifted = closure(0, 5, Pose2::new(6.0, 0.0, 1.5));
        let turned = closure(0, 5, Pose2::new(4.0, 0.0, 1.7));
        let unknown = closure(0, 7, Pose2::new(4.0, 0.0, 1.5));
        let check = ClosureCheck::of(&[right, shifted, turned, unknown], reference);
        assert_eq!(check.checked, 3);
        assert_eq!(check.checked_during_run, 3);
        assert_eq!(check.off_reference.len(), 2, "{check:?}");
        assert!(
            (check.off_reference[0].error_m - 2.0).abs() < 1e-9,
            "{check:?}"
        );
        assert!((check.off_reference[1].error_deg - 0.2f64.to_degrees()).abs() < 1e-9);
        assert!((check.max_error_m - 2.0).abs() < 1e-9);
    }
}
