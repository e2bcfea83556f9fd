//! Host software for the robot computer: the board link and its time base.
//!
//! * [`evaluation`]: trajectory accuracy on ground-truth relations (Kümmerle et al. 2009).
//! * [`geoimage`]: geo-referenced images (GeoTIFF, PNG/JPEG + world file) and their WGS84
//!   corners; a GeoTIFF writer for the simulator's aerial image.
//! * [`grid`]: occupancy-grid submaps, ray insertion, sub-cell scan refinement and map export.
//! * [`link`]: reading the board's frames from a serial port, counting every lost frame,
//!   and mapping board time to host time.
//! * [`pose_graph`]: a 2D pose graph optimised by sparse Levenberg–Marquardt, with robust
//!   kernels for loop closures.
//! * [`recording`]: every read from the board and every decoded message to MCAP, for
//!   Foxglove and for replay.
//! * [`scan_match`]: aligning laser scans by raster overlap, a reference and a fast exact matcher.

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
