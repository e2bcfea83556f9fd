//! Trajectory accuracy by relative poses: the error measure of R. Kümmerle, B. Steder,
//! C. Dornhege, M. Ruhnke, G. Grisetti, C. Stachniss and A. Kleiner, "On measuring the accuracy
//! of SLAM algorithms", Autonomous Robots 27:397–407, 2009.
//!
//! Instead of comparing every pose with a global ground truth (which needs one, and punishes an
//! early rotation error along the whole rest of the path), the measure compares *relations*:
//! the true motion `δ*` between the poses at two timestamps with the motion `δ` the estimated
//! trajectory shows between the same two timestamps. For each relation the error pose is
//! `ε = inverse(δ*) * δ`; its translation length and its wrapped angle are the relation's
//! translational and rotational errors, which are then averaged.
//!
//! * [`Relation`]: two timestamps and the true pose at the second seen from the first.
//! * [`Trajectory`] of [`StampedPose`]s: the estimate (or a reference), looked up by nearest
//!   timestamp.
//! * [`evaluate_relations`] with [`PairingOptions`]: pairs relations with trajectory poses and
//!   returns a [`RelationEvaluation`]: what was covered, one [`RelationResidual`] per covered
//!   relation and their [`ErrorSummary`].
//! * [`ReferenceRelations`] with [`ReferenceRelationOptions`]: relations built from a reference
//!   trajectory (consecutive scans and revisits), for logs without published relations.
//! * [`error_to_gps`] and [`receiver_jumps`]: a trajectory against GPS fixes where no ground
//!   truth exists, with and without the receiver's own jumps.
//! * [`pose_nees`] and [`chi_square_bounds`]: a filter's consistency (NEES) over Monte-Carlo
//!   runs.
//! * [`AgreementReport`]: which relations the log's own scans dispute (they line up far worse
//!   at the true relative pose than at the estimate), and the error without them.

mod error_summary;
mod gps_error;
mod nees;
mod reference_relations;
mod relation;
mod relation_evaluation;
mod relation_residual;
mod scan_agreement;
mod trajectory;

pub use error_summary::ErrorSummary;
pub use gps_error::{GpsError, TimedPosition, error_to_gps, receiver_jumps};
pub use nees::{chi_square_bounds, pose_nees};
pub use reference_relations::{ReferenceRelationOptions, ReferenceRelations};
pub use relation::Relation;
pub use relation_evaluation::{PairingOptions, RelationEvaluation, evaluate_relations};
pub use relation_residual::{RelationResidual, motion_error};
pub use scan_agreement::{
    AGREEMENT_DISTANCE_M, AgreementReport, DISPUTE_MARGIN, RelationAgreement, ScanAgreement,
};
pub use trajectory::{StampedPose, Trajectory};
