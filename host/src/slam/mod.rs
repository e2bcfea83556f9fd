//! Method 2: occupancy-grid SLAM on laser scans, built on the raster scan matchers.
//!
//! The pipeline (after Hess et al. 2016, "Real-Time Loop Closure in 2D LIDAR SLAM"):
//!
//! * **Local tracking** ([`LocalTracker`]): each scan is placed in a drift-prone `local` frame
//!   by matching it against the active occupancy-grid submap. The pose is predicted from the
//!   odometry when the log has it, else from the last motion; point-to-line ICP ([`icp`])
//!   aligns the scan's end points on the submap's points ([`PointMap`]), and when too little
//!   of the scanned surface fits, a wide search with the exact
//!   [`FastMatcher`](crate::scan_match::FastMatcher) against the last scans finds the pose
//!   first. Scans go into two overlapping submaps with log-odds ray insertion; a submap is
//!   finished once its successor holds [`SlamOptions::scans_per_submap`] scans. With the
//!   [`MotionFilter`] on (the default), only the scans after which the robot moved or turned
//!   enough are inserted and become nodes; the others are placed relative to the last node.
//! * **Loop closure** ([`LoopCloser`]): scans are searched in finished submaps near their
//!   estimated pose (a few a scan, each near submap in turn) with the fast matcher over a wide window (metres and tens of degrees),
//!   then aligned on the submap's points; a match good enough becomes a constraint. Which
//!   submaps are near, and how wide the window must be, follows from how uncertain the scan's
//!   pose is relative to each submap, compounded along the pose graph
//!   ([`crate::pose_graph::relative_covariances`]); where that reaches beyond the window, a
//!   few submaps per scan are searched over a far wider one ([`UncertainClosureOptions`]), and
//!   every scan is searched in the nearest of them for weak matches, fewer of whose end points
//!   lie on the submap's surfaces, taken where they lie within that uncertainty, the place is
//!   distinctive across it and two more agree ([`WeakClosureOptions`]). After a stretch
//!   local tracking could not place, a scan whose heading is that uncertain is searched in
//!   the submaps near it over every heading ([`RelocalisationOptions`]). A scan
//!   no submap took is searched once more, over ±10 m, in a chain of the earlier scans
//!   around the one nearest to it ([`ChainClosureOptions`]): a long loop drifts further than
//!   the submaps' window, and a stretch that local tracking got wrong blurs a whole submap.
//! * **Pose graph** ([`crate::pose_graph`]): one node per inserted scan, an edge per consecutive pair
//!   from local tracking (left almost free along a corridor's axis, [`degeneracy`]), an edge
//!   per loop closure (robust kernel) from the submap's first
//!   scan; solved with a sparse Cholesky factorisation once the closures added since the last
//!   solve disagree with the graph ([`SlamOptions::solve_above_chi2`]), and at the end.
//! * **Settled places** ([`settled_submaps`]): a finished submap that later passes closed on,
//!   and that the graph agrees with, settles; once all of a node's submaps settled the node
//!   is fixed, and during the run the solves and the relative covariances work on
//!   the free part of the graph only, which follows the places not yet settled rather than
//!   the time spent. The last solve releases them.
//! * **Final refinement** ([`final_refinement`]): every scan is aligned on the finished
//!   submaps near it, as its place settles or at the end of the run, and the alignments that
//!   fit become constraints for the end's last solve.
//!
//! [`GraphSlam`] runs the whole, [`GraphSlam::finish`] refines and returns the optimised poses and
//! [`SlamResult::global_grid`] draws the global map from them. [`GridPipeline`] is the method as
//! every adapter runs it: time-stamped scans in, poses, trajectory and the global grid out.

mod chain_closer;
pub mod closure_confirmation;
pub mod closure_gain;
pub mod degeneracy;
pub mod final_refinement;
mod graph_slam;
mod grid_pipeline;
pub mod icp;
mod local_tracker;
mod loop_closer;
pub mod motion_filter;
pub mod motion_prior;
mod node_index;
mod options;
pub mod point_grid;
pub mod point_map;
mod recent_scans;
pub mod settled_submaps;
mod slam_submap;
mod slam_timings;
mod tracking_check;
mod window_matcher;

pub use graph_slam::{ClosureConstraint, GraphSlam, SlamResult, SlamStats};
pub use grid_pipeline::{GridPipeline, GridPipelineOptions};
pub use local_tracker::{LocalTracker, TrackedScan};
pub use loop_closer::{AlignedCandidate, LoopCloser, LoopClosure};
pub use motion_filter::{MotionFilter, MotionFilterOptions};
pub use motion_prior::{MotionPrior, MotionPriorOptions};
pub use options::{
    ChainClosureOptions, LocalTrackingOptions, LoopClosureOptions, RefinementOptions,
    RelocalisationOptions, SlamOptions, UncertainClosureOptions, WeakClosureOptions,
};
pub use point_map::{PointMap, PointMapOptions};
pub use recent_scans::RecentScans;
pub use settled_submaps::SettleOptions;
pub use slam_submap::{SlamSubmap, SubmapFit};
pub use slam_timings::SlamTimings;
pub use tracking_check::{TrackingCheck, TrackingVerdict};
