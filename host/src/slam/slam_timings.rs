//! Where a SLAM run's time went, part by part: wall time on the machine that ran it, to see
//! which part grows with the map. Kept apart from [`super::SlamStats`], which is the same on
//! every run of the same input.

use std::time::Instant;

use serde::Serialize;

/// Wall time spent in each part of [`super::GraphSlam`], seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SlamTimings {
    /// Local tracking: each scan placed against the active submaps and inserted, and the
    /// matcher's reference of each submap that finished.
    pub tracking_s: f64,
    /// Choosing loop-closure candidates: the covariances of the pose relative to every node
    /// (a search of the graph from the scan's node). The same search for a closure the
    /// robust kernel would weaken, whether it lies within the uncertainty, counts with the
    /// searches.
    pub closure_candidates_s: f64,
    /// Loop-closure searches: in finished submaps, in chains of earlier scans and around a
    /// guess for an uncertain pose, with their acceptance and confirmation.
    pub closure_searches_s: f64,
    /// Optimisations of the graph's free nodes during the run.
    pub optimization_s: f64,
    /// Settling places during the run ([`super::settled_submaps`]): testing which submaps
    /// settled, and fixing their nodes.
    pub settling_s: f64,
    /// The final refinement's alignments made during the run, as places settle
    /// ([`super::final_refinement`]).
    pub refining_ahead_s: f64,
    /// The end of the run: the last optimisation, with every node free, and the final
    /// refinement of the nodes not aligned during the run.
    pub finish_s: f64,
}

impl SlamTimings {
    /// The time spent since `earlier`, a snapshot of the same run: part by part, what
    /// `self` adds to it.
    pub fn since(&self, earlier: &SlamTimings) -> SlamTimings {
        SlamTimings {
            tracking_s: self.tracking_s - earlier.tracking_s,
            closure_candidates_s: self.closure_candidates_s - earlier.closure_candidates_s,
            closure_searches_s: self.closure_searches_s - earlier.closure_searches_s,
            optimization_s: self.optimization_s - earlier.optimization_s,
            settling_s: self.settling_s - earlier.settling_s,
            refining_ahead_s: self.refining_ahead_s - earlier.refining_ahead_s,
            finish_s: self.finish_s - earlier.finish_s,
        }
    }
}

/// Seconds since `start`.
pub(super) fn seconds_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64()
}
