//! Laser scan matching by raster overlap.
//!
//! A new scan is aligned with a reference scan by trying every transform of a table of
//! translations × rotations around a guess: both scans are drawn as polylines into a small
//! raster and the transform whose drawing covers the fewest pixels (the best overlap) wins. The
//! method was first run on graphics hardware (draw both scans, count the pixels); here it runs in
//! software.
//!
//! * [`search`]: the shared contract: raster, candidate table and its pixel quantisation,
//!   drawing rules, score, tie-break, [`MatchResult`] and the [`ScanMatcher`] trait.
//! * [`ReferenceMatcher`]: the method as stated, one raster per candidate. It defines the answer.
//! * [`FastMatcher`]: exactly the same answer by branch and bound over bit-packed, max-pooled
//!   rasters.
//! * [`PoseRegion`]: a part of the table a search is restricted to.
//! * [`Scan`]: the input, end points in the robot frame (x forward, y left); poses are
//!   [`crate::geometry::Pose2`].
//! * [`synthetic`]: scans cast in a world of walls, for tests and benchmarks.

mod bit_grid;
mod bresenham;
mod fast_matcher;
mod pose_region;
mod precomputation_grid;
mod reference_matcher;
mod rotated_scan;
mod scan;
pub mod search;
mod simd;
pub mod synthetic;

pub use bresenham::BresenhamLine;
pub use fast_matcher::{Excluded, FastMatcher, MAX_BRANCH_AND_BOUND_DEPTH, PreparedReference};
pub use pose_region::PoseRegion;
pub use reference_matcher::ReferenceMatcher;
pub use scan::Scan;
pub use search::{Candidate, MatchResult, RasterOptions, ScanMatchError, ScanMatcher, SearchTable};
