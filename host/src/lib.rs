//! The robot computer's algorithms: the board link's sensor stream, both localisation methods,
//! geo-referencing, recording and evaluation. No threads, HTTP or command line here: the
//! `robot-host` daemon (`host/daemon`) and `hil-sim` read inputs, drive these types and write
//! outputs.
//!
//! * [`geometry`]: the one pose type, [`geometry::Pose2`], and the frames' conventions.
//! * [`link`]: the board's frames decoded into time-synced [`link::SensorEvent`]s in SI units
//!   ([`link::LinkSession`]), every lost frame counted, board time mapped to host time.
//! * Method 2, indoors: [`scan_match`] (raster scan matching, a reference and a fast exact
//!   matcher), [`grid`] (occupancy grids, ray insertion, map export), [`pose_graph`] (sparse
//!   Levenberg–Marquardt with robust kernels) and [`slam`] (the method,
//!   [`slam::GridPipeline`]).
//! * Method 1, outdoors: [`landmarks`] (trees and corners from raw scans) and [`ekf_slam`]
//!   (EKF local maps, map joining, history memory, GPS; the method, [`ekf_slam::LandmarkSlam`],
//!   and its board-link adapter [`ekf_slam::EkfPipeline`]).
//! * [`camera`]: Method 1 on a single camera (MonoSLAM-style EKF, inverse-depth features;
//!   the method, [`camera::MonoSlam`]).
//! * [`georef`]: GPS in a local metric frame, the map aligned to it, WGS84 exports;
//!   [`geoimage`]: geo-referenced images.
//! * [`recording`]: every read from the board and every decoded message to MCAP, for
//!   Foxglove and for replay.
//! * [`evaluation`]: accuracy on relations (Kümmerle et al. 2009), error to GPS, NEES.

pub mod camera;
pub mod ekf_slam;
pub mod evaluation;
mod floor;
pub mod geoimage;
pub mod geometry;
pub mod georef;
pub mod grid;
pub mod landmarks;
pub mod link;
pub mod pose_graph;
mod pose_view;
pub mod recording;
pub mod scan_match;
pub mod slam;

pub use pose_view::PoseView;
