//! Log readers and replay sources: recorded robot data turned back into the inputs of the
//! emulators, so the firmware and the host see recorded runs over the same serial bytes as
//! live ones. The recordings live in `shared/datasets/` (see its `SOURCES.md` for where each
//! file came from and how the derived ones were produced).
//!
//! Readers (typed [`LogError`]s naming file, line and field; nothing panics on bad input):
//!
//! * [`carmen`]: CARMEN logs (`FLASER`, `ROBOTLASER1`, `ODOM`; gzip too), and
//!   [`no_return`]: which of their ranges mean "no return".
//! * [`reference`](mod@reference): reference trajectories (`*.reference.tsv`).
//! * [`relations`]: Kümmerle et al. ground-truth relations (`*.relations`).
//! * [`victoria`]: the Victoria Park ASCII export (drive inputs, GPS, tree detections).
//! * [`capture`]: raw serial captures, replayed at a baud rate.
//!
//! Replay sources:
//!
//! * [`carmen_scans`]: CARMEN laser records as recorded scans for
//!   [`Lms2xx::replay`](crate::emulators::Lms2xx::replay).
//! * [`tree_scans`](mod@tree_scans): stand-in scans rebuilt from Victoria Park tree detections (its raw laser
//!   is missing).
//! * [`gps_replay`]: recorded positions fed to the
//!   [`GpsEmulator`](crate::emulators::GpsEmulator).

pub mod capture;
pub mod carmen;
pub mod carmen_scans;
pub mod error;
mod fields;
pub mod gps_replay;
pub mod no_return;
pub mod reference;
pub mod relations;
pub mod tree_scans;
pub mod victoria;

pub use capture::{CaptureReplay, TimedRun, capture_scans};
pub use carmen::{
    CarmenCounts, CarmenLog, CarmenReader, CarmenRecord, LaserMessage, LaserRecord, LoggedPose,
    OdomRecord, flaser_resolution_rad,
};
pub use carmen_scans::recorded_scans;
pub use error::{FieldProblem, LogError};
pub use gps_replay::{GpsReplay, GpsReplayOptions};
pub use no_return::{detect_no_return_from_m, saturation_from_m};
pub use reference::{ReferencePose, parse_reference, read_reference};
pub use relations::{Relation, parse_relations, read_relations};
pub use tree_scans::{TreeScanOptions, synthesize_tree_scan, tree_scans};
pub use victoria::{
    CarGeometry, DriveInput, LocalGpsFix, TreeDetection, TreeScan, VictoriaPark, read_gps,
    read_inputs, read_tree_scans,
};
