//! Occupancy grids for 2D laser SLAM: building them from scans, and exporting them as maps.
//!
//! The layout follows Cartographer's `mapping/2d`, one concept per file:
//!
//! * [`MapLimits`]: where a grid of square cells sits in its frame, and point ↔ cell indexing.
//! * [`ProbabilityGrid`]: clamped occupancy log-odds per cell, unknown cells kept apart; grows
//!   as scans reach beyond it. [`ProbabilityGrid::from_scans`] draws the global map from the
//!   optimised trajectory.
//! * [`RangeInserter`]: one scan into a grid by ray casting, hits at beam ends, misses on the way.
//! * [`Submap`]: a grid in its own frame, placed in the map, built from consecutive scans.
//! * [`LazyGrid`]: a submap's grid never drawn, each cell worked out from its scans when read.
//! * [`MapExport`]: a grid as a ROS `map_server` map (PGM or PNG image and YAML metadata).
//!
//! Frames: a grid's coordinates are in its *grid frame*, the submap frame for a submap and the
//! map frame for the global map. Poses follow [`crate::geometry::Pose2`]: `grid_from_robot`
//! maps points of the robot frame into the grid frame.

mod lazy_grid;
mod map_export;
mod map_limits;
mod probability_grid;
mod range_inserter;
mod submap;

pub use lazy_grid::{LazyGrid, Occupancy};
pub use map_export::{FREE_PIXEL, MapExport, MapExportOptions, OCCUPIED_PIXEL, UNKNOWN_PIXEL};
pub use map_limits::{CellIndex, LineIndices, MapLimits};
pub use probability_grid::{MAX_SIDE_CELLS, ProbabilityGrid, ProbabilityGridOptions};
pub use range_inserter::{RangeInserter, RangeInserterOptions};
pub use submap::{Submap, SubmapFinishedError, SubmapOptions};
