//! The whole pipeline: local tracking, loop closure and the pose graph, one scan at a time.

use std::time::Instant;

use nalgebra::Matrix3;
use serde::Serialize;

use super::chain_closer::{ChainCloser, ChainContext};
use super::closure_confirmation::{ClosureConfirmation, FoundClosure};
use super::closure_gain::closure_gain_nats;
use super::degeneracy::{closure_information, consecutive_information};
use super::final_refinement::{RefinedAhead, refinement_closures};
use super::local_tracker::LocalTracker;
use super::loop_closer::{LoopCloser, LoopClosure};
use super::node_index::NodeIndex;
use super::options::{LoopClosureOptions, SlamOptions};
use super::settled_submaps::SettledSubmaps;
use super::slam_submap::SlamSubmap;
use super::slam_timings::{SlamTimings, seconds_since};
use super::tracking_check::TrackingCheck;
use crate::geometry::Pose2;
use crate::grid::{ProbabilityGrid, RangeInserterOptions};
use crate::pose_graph::{
    Edge, EdgeId, NodeId, PoseGraph, RelativeCovariances, relative_covariance, relative_covariances,
};
use crate::scan_match::{PoseRegion, PreparedReference, Scan, ScanMatchError};

/// What happened over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SlamStats {
    /// Scans added.
    pub scans: usize,
    /// Of those, the scans the motion filter inserted: the nodes of the pose graph.
    pub nodes: usize,
    /// Scans whose local tracking needed the wide search.
    pub wide_searches: usize,
    /// Scans whose wide search ran once more over every heading.
    pub every_heading_searches: usize,
    /// Scans whose local tracking searched the far window (scans metres apart).
    pub far_searches: usize,
    /// Scans local tracking could not place (their pose is the prediction).
    pub lost_scans: usize,
    /// Submaps built.
    pub submaps: usize,
    /// Scan-in-submap searches for loop closure.
    pub loop_closure_searches: usize,
    /// Of those, the searches over the wide window of a pose too uncertain for the usual one
    /// ([`super::UncertainClosureOptions`]).
    pub uncertain_closure_searches: usize,
    /// Of those, the searches for weak matches ([`super::WeakClosureOptions`]).
    pub weak_closure_searches: usize,
    /// Weak matches that entered the graph (counted in `loop_closures` too).
    pub weak_closures: usize,
    /// Of the loop-closure searches, those over every heading after tracking lost its way
    /// ([`super::RelocalisationOptions`]).
    pub relocalisation_searches: usize,
    /// Their matches that entered the graph, confirmed (counted in `loop_closures` too).
    pub relocalisations: usize,
    /// Loop-closure constraints added (chain closures included).
    pub loop_closures: usize,
    /// Loop closures found and rejected: no second one agreed with them on the motion local
    /// tracking measured between them (chain closures and weak matches included; those still
    /// waiting count).
    pub rejected_closures: usize,
    /// Constraints in the graph (loop closures and refinement) that its robust kernel all but
    /// switched off at the last optimisation: weighted below one quarter, as they disagree
    /// with the rest of the graph ([`SlamOptions::loop_closure_kernel`]).
    pub switched_off_closures: usize,
    /// Scan-in-chain searches, for scans no submap took.
    pub chain_closure_searches: usize,
    /// Of the loop-closure constraints, those found in a chain of earlier scans.
    pub chain_closures: usize,
    /// Loop-closure searches not run because a closure would have told the graph too little
    /// ([`SlamOptions::min_closure_gain_nats`]): each submap within the search distance of a
    /// searched scan, and each chain, skipped (the budget then goes to the others).
    pub closure_searches_skipped: usize,
    /// Loop closures that the graph held far from where they put the scan, yet within the
    /// uncertainty of the scan's pose relative to the submap: each was solved once without
    /// the robust kernel, which would have switched it off before it could pull
    /// ([`GraphSlam`]'s `add_constraint`).
    pub closures_within_uncertainty: usize,
    /// Constraints added by the final refinement.
    pub refinement_constraints: usize,
    /// Nodes the final refinement aligned during the run, as their places settled, rather
    /// than at its end ([`super::final_refinement`]).
    pub nodes_refined_ahead: usize,
    /// Pose-graph optimisations run.
    pub optimizations: usize,
    /// Optimisations that failed (the poses were kept as they were).
    pub failed_optimizations: usize,
    /// Finished submaps settled: later passes closed on them and the graph agrees
    /// ([`super::settled_submaps`]).
    pub settled_submaps: usize,
    /// Nodes fixed during the run because every submap they went into settled (the end of
    /// the run releases them for its last solve).
    pub fixed_nodes: usize,
}

/// A constraint a loop closure or the final refinement put into the pose graph: the pose of
/// one scan measured in the frame of another (the first scan of the submap or chain it was
/// found in). Compared with a reference trajectory, it tells a right closure from a wrong one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosureConstraint {
    /// The scan whose pose is the frame, by its number in the order scans were added.
    pub from_scan: usize,
    /// The scan that was found, likewise.
    pub to_scan: usize,
    /// `from_from_to`, as the alignment measured it.
    pub to_in_from: Pose2,
    /// Whether the final refinement added it (else a loop closure during the run).
    pub refinement: bool,
}

/// The poses of every scan, optimised, and what it took.
#[derive(Clone, Debug)]
pub struct SlamResult {
    /// `map_from_robot` of every scan, in the order they were added.
    pub poses_in_map: Vec<Pose2>,
    /// For every scan, whether local tracking could not place it.
    pub lost: Vec<bool>,
    /// What happened.
    pub stats: SlamStats,
    /// `map_from_robot` of every node: the scans the motion filter inserted, in order.
    pub node_poses_in_map: Vec<Pose2>,
    /// The scans of the nodes (the beams the SLAM trusts), in order.
    pub node_scans: Vec<Scan>,
    /// Where the time went (wall time on this machine).
    pub timings: SlamTimings,
    /// Every loop closure and refinement constraint that entered the graph, in order.
    pub closures: Vec<ClosureConstraint>,
}

impl SlamResult {
    /// The scans the map is made of (the nodes), each at its optimised pose.
    pub fn map_scans(&self) -> impl Iterator<Item = (Pose2, &Scan)> {
        self.node_poses_in_map
            .iter()
            .copied()
            .zip(self.node_scans.iter())
    }

    /// The global occupancy grid: every node's scan inserted at its optimised pose, with
    /// cells of `resolution_m`.
    pub fn global_grid(&self, resolution_m: f64) -> ProbabilityGrid {
        ProbabilityGrid::from_scans(
            self.map_scans(),
            resolution_m,
            Default::default(),
            RangeInserterOptions::default(),
        )
    }
}

/// Graph SLAM over occupancy-grid submaps. See the [module documentation](super).
#[derive(Debug)]
pub struct GraphSlam {
    options: SlamOptions,
    tracker: LocalTracker,
    closer: LoopCloser,
    graph: PoseGraph,
    /// `local_from_robot` of every node (every scan the motion filter inserted).
    poses_in_local: Vec<Pose2>,
    /// For every scan, whether local tracking could not place it.
    lost: Vec<bool>,
    /// For every scan, the node it is placed by and its pose in that node's frame (the
    /// identity for a node's own scan).
    scan_in_node: Vec<(usize, Pose2)>,
    /// For every node, the scan that created it.
    scan_of_node: Vec<usize>,
    /// Finished submaps with their matcher references.
    finished: Vec<(SlamSubmap, PreparedReference)>,
    /// Searches a submap over the wide window of an uncertain pose.
    uncertain_closer: LoopCloser,
    /// Searches a submap over every heading after tracking lost its way
    /// ([`super::RelocalisationOptions`]).
    relocaliser: LoopCloser,
    /// The same over [`super::RelocalisationOptions::narrow_turn_rad`], where the ring of
    /// places the robot can be on gives the heading.
    narrow_relocaliser: LoopCloser,
    /// The closures `uncertain_closer` and `relocaliser` found: while one waits for its confirmation, the scans
    /// after it are searched where it predicts them.
    followed_closures: Vec<FollowedClosure>,
    /// The last stretch of lost scans (its last node is the last one local tracking could
    /// not place, where it started afresh), and whether its heading was found again.
    lost_heading: Option<LostHeading>,
    /// For every finished submap, the node last searched in it by `closer`.
    last_search: Vec<usize>,
    /// For every finished submap, the node last searched in it by `uncertain_closer`.
    last_uncertain_search: Vec<usize>,
    /// For every finished submap, the node last searched in it by the relocalisers.
    last_relocalisation_search: Vec<usize>,
    /// How often each finished submap was searched by the relocalisation.
    relocalisation_visits: Vec<usize>,
    /// Searches a submap for a weak match ([`super::WeakClosureOptions`]).
    weak_closer: LoopCloser,
    /// Weak matches waiting for those that agree with them.
    weak_confirmation: ClosureConfirmation,
    /// The finished submaps near the last searched scan whose relative pose was uncertain
    /// beyond the usual window: searched for weak matches until the next searched scan.
    weak_targets: Vec<usize>,
    /// `map_from_local` as of the last optimisation.
    map_from_local: Pose2,
    /// Constraints added since the last solve: the end of a run solves for them.
    closures_since_optimization: usize,
    /// The χ² of those constraints at the poses they were added to, weighted by their robust
    /// kernel, in sum (the unrobust ones infinite: they are added to pull).
    chi2_since_optimization: f64,
    confirmation: ClosureConfirmation,
    /// Searches chains of earlier scans.
    chains: ChainCloser,
    /// The scan of every node (trusted beams): for the chains, the final refinement and the
    /// map.
    scans: Vec<Scan>,
    /// The loop-closure and refinement constraints in the graph.
    closure_edges: Vec<EdgeId>,
    /// Constraints added without their robust kernel, which they receive after the next
    /// optimisation.
    unrobust_edges: Vec<EdgeId>,
    /// Which submaps settled.
    settled: SettledSubmaps,
    /// The nodes fixed during the run, in the order they were fixed.
    settled_nodes: Vec<usize>,
    /// The final refinement of the nodes fixed during the run, made as they were fixed.
    refined_ahead: RefinedAhead,
    /// Where the nodes lie, for the chain search's nearest node.
    node_index: NodeIndex,
    stats: SlamStats,
    timings: SlamTimings,
    /// The last scan's [`TrackedScan::check`](super::TrackedScan::check).
    last_check: Option<TrackingCheck>,
}

impl GraphSlam {
    /// A pipeline with `options`.
    ///
    /// # Errors
    /// When the matcher options are invalid.
    pub fn new(options: SlamOptions) -> Result<Self, ScanMatchError> {
        Ok(GraphSlam {
            tracker: LocalTracker::new(options.clone())?,
            closer: LoopCloser::new(options.loop_closure.clone())?,
            graph: PoseGraph::new(),
            poses_in_local: Vec::new(),
            lost: Vec::new(),
            scan_in_node: Vec::new(),
            scan_of_node: Vec::new(),
            finished: Vec::new(),
            uncertain_closer: LoopCloser::new(options.uncertain_closure.search.clone())?,
            relocaliser: LoopCloser::new(options.relocalisation.search.clone())?,
            narrow_relocaliser: LoopCloser::new(LoopClosureOptions {
                search_window_rad: options.relocalisation.narrow_turn_rad,
                ..options.relocalisation.search.clone()
            })?,
            followed_closures: Vec::new(),
            last_search: Vec::new(),
            last_uncertain_search: Vec::new(),
            last_relocalisation_search: Vec::new(),
            relocalisation_visits: Vec::new(),
            lost_heading: None,
            weak_closer: LoopCloser::new(options.weak_closure.search.clone())?,
            weak_confirmation: ClosureConfirmation::new(options.weak_closure.confirmation),
            weak_targets: Vec::new(),
            map_from_local: Pose2::IDENTITY,
            closures_since_optimization: 0,
            chi2_since_optimization: 0.0,
            confirmation: ClosureConfirmation::new(options.loop_closure.confirmation),
            chains: ChainCloser::new(&options)?,
            scans: Vec::new(),
            closure_edges: Vec::new(),
            unrobust_edges: Vec::new(),
            settled: SettledSubmaps::new(options.settle.clone()),
            settled_nodes: Vec::new(),
            refined_ahead: RefinedAhead::default(),
            node_index: NodeIndex::new(options.chain_closure.search.max_distance_m.max(1.0)),
            stats: SlamStats::default(),
            timings: SlamTimings::default(),
            last_check: None,
            options,
        })
    }

    /// Has the next scan's tracking score `motion_from_last_scan` beside its candidates
    /// ([`LocalTracker::check_next_motion`]); the result is [`Self::last_check`] after
    /// [`Self::add_scan`].
    pub fn check_next_motion(&mut self, motion_from_last_scan: Pose2) {
        self.tracker.check_next_motion(motion_from_last_scan);
    }

    /// The check the last scan's tracking made, if one was asked for it
    /// ([`Self::check_next_motion`]).
    pub fn last_check(&self) -> Option<&TrackingCheck> {
        self.last_check.as_ref()
    }

    /// Adds `scan` (end points in the robot frame) taken at `time_s`, with the odometry pose
    /// at the scan when the log has one; returns the scan's current pose in the map.
    pub fn add_scan(&mut self, time_s: f64, scan: &Scan, odometry: Option<Pose2>) -> Pose2 {
        let started = Instant::now();
        let scan = self.options.trusted_beams(scan);
        let tracked = self.tracker.track(time_s, &scan, odometry);
        self.last_check = tracked.check;
        self.stats.scans += 1;
        self.stats.wide_searches += usize::from(tracked.searched);
        self.stats.every_heading_searches += usize::from(tracked.searched_every_heading);
        self.stats.far_searches += usize::from(tracked.searched_far);
        self.stats.lost_scans += usize::from(tracked.lost);
        self.lost.push(tracked.lost);
        let pose_in_map = self.map_from_local * tracked.pose_in_local;
        let Some(node) = tracked.node else {
            self.timings.tracking_s += seconds_since(started);
            // Not inserted (never the first scan): placed relative to the last node, and moved
            // with it.
            if let Some(&anchor_in_local) = self.poses_in_local.last() {
                let last = self.poses_in_local.len() - 1;
                let in_node = anchor_in_local.inverse() * tracked.pose_in_local;
                self.scan_in_node.push((last, in_node));
                return self
                    .node_pose_in_map(last)
                    .map_or(pose_in_map, |p| p * in_node);
            }
            self.scan_in_node.push((0, Pose2::IDENTITY));
            return pose_in_map;
        };
        self.scan_of_node.push(self.scan_in_node.len());
        self.scan_in_node.push((node, Pose2::IDENTITY));
        // Node numbers follow scan order, so the graph's ids equal `node`; adding can only
        // fail on non-finite poses, which tracking does not produce.
        if self.graph.add_node(pose_in_map).is_ok() && node == 0 {
            let _ = self.graph.set_fixed(NodeId(0), true);
        }
        self.node_index.add(node);
        if let Some(&previous) = self.poses_in_local.last() {
            // A lost scan's pose is the prediction, as uncertain as the motion prior says.
            let information = if tracked.lost {
                let [sigma_m, sigma_rad] = tracked.prior_sigma;
                Edge::information_from_std_devs(sigma_m, sigma_m, sigma_rad)
            } else {
                let information = consecutive_information(
                    &self.options,
                    tracked.information_in_robot.as_ref(),
                    tracked.unmeasured_sigma_m,
                );
                // The candidates that came close widen the constraint to cover them.
                information
                    .try_inverse()
                    .and_then(|covariance| (covariance + tracked.ambiguity_in_robot).try_inverse())
                    .unwrap_or(information)
            };
            let edge = Edge::new(
                NodeId(node - 1),
                NodeId(node),
                previous.inverse() * tracked.pose_in_local,
                information,
            );
            let _ = self.graph.add_edge(edge);
        }
        self.poses_in_local.push(tracked.pose_in_local);
        if tracked.lost {
            let [sigma_m, _] = tracked.prior_sigma;
            let gap = self.options.relocalisation.stretch_gap_nodes;
            match &mut self.lost_heading {
                Some(lost) if !lost.found && lost.last_lost + gap >= node => {
                    lost.last_lost = node;
                    lost.variance_m2 += sigma_m * sigma_m;
                }
                _ => {
                    self.lost_heading = Some(LostHeading {
                        anchor: node.saturating_sub(1),
                        last_lost: node,
                        variance_m2: sigma_m * sigma_m,
                        found: false,
                    });
                }
            }
        }
        for mut submap in tracked.finished_submaps {
            self.stats.submaps += 1;
            let reference_scan = submap
                .reference_scan()
                .unwrap_or_else(|| submap.reference_scan_from(|n| self.node_scan(n, &scan)));
            let reference = self.closer.prepare(&reference_scan);
            // The end points are the node scans again: drawn from those when searched around
            // a guess.
            submap.forget_end_points();
            self.settled
                .finished(submap.first_node()..=submap.last_node());
            self.finished.push((submap, reference));
            self.last_search.push(0);
            self.last_uncertain_search.push(0);
            self.last_relocalisation_search.push(0);
            self.relocalisation_visits.push(0);
        }
        self.timings.tracking_s += seconds_since(started);
        let started = Instant::now();
        let before = self.timings;
        let every = self.options.loop_closure.every_n_scans.max(1);
        if self.options.loop_closure.enabled {
            let searched = node.is_multiple_of(every);
            // How uncertain the scan's pose is relative to every node: what a closure there
            // would tell, and how far the wide search must reach.
            let started = Instant::now();
            let needed =
                self.options.min_closure_gain_nats > 0.0 || self.options.uncertain_closure.enabled;
            let covariances = if searched && needed {
                relative_covariances(&self.graph, NodeId(node))
            } else {
                RelativeCovariances::default()
            };
            self.timings.closure_candidates_s += seconds_since(started);
            let (taken, beyond_window) = if searched {
                self.close_loops(node, &scan, pose_in_map, &covariances)
            } else {
                (false, Vec::new())
            };
            // Every scan is searched while a chain closure waits for its confirmation,
            // whatever it would tell.
            let awaited = self.chains.awaits_confirmation(node);
            if self.options.chain_closure.enabled && (searched || awaited) && !taken {
                let covariances = (!awaited).then_some(&covariances);
                self.close_loops_in_chain(node, &scan, pose_in_map, covariances);
            }
            if self.options.uncertain_closure.enabled && !taken {
                self.close_loops_beyond_window(node, &scan, beyond_window);
            }
            if self.options.weak_closure.enabled && !taken {
                self.close_loops_weakly(node, &scan, pose_in_map);
            }
            self.follow_waiting_closures(node, &scan);
        }
        // Less what the parts timed apart took meanwhile.
        let apart_s = (self.timings.closure_candidates_s - before.closure_candidates_s)
            + (self.timings.optimization_s - before.optimization_s);
        self.timings.closure_searches_s += (seconds_since(started) - apart_s).max(0.0);
        self.scans.push(scan);
        let chi2 = self.chi2_since_optimization;
        let optimizations = self.stats.optimizations;
        if chi2.is_nan() || chi2 > self.options.solve_above_chi2 {
            self.optimize();
        }
        self.settle(node, self.stats.optimizations > optimizations);
        self.refine_ahead();
        self.node_pose_in_map(node).unwrap_or(pose_in_map)
    }

    /// Ends the run: every settled node released and a last optimisation if any were or if
    /// loops were found since the previous one, the final refinement
    /// ([`super::final_refinement`], when enabled) and the poses of every scan.
    pub fn finish(mut self) -> SlamResult {
        let started = Instant::now();
        let optimization_s = self.timings.optimization_s;
        let active = self.tracker.finish();
        self.stats.submaps += active.len();
        // The last solve and the refinement move the settled nodes again with the rest, as
        // every later pass tells.
        for &settled in &self.settled_nodes {
            let _ = self.graph.set_fixed(NodeId(settled), false);
        }
        let released = !self.settled_nodes.is_empty();
        if self.closures_since_optimization > 0 || released {
            self.optimize();
        }
        let closures_in_run = self.closure_edges.len();
        if self.options.refinement.enabled {
            self.refine(&active);
        }
        let closures = self.closure_constraints(closures_in_run);
        // The last optimisations belong to the end of the run.
        self.timings.optimization_s = optimization_s;
        self.timings.finish_s += seconds_since(started);
        SlamResult {
            poses_in_map: self.poses_in_map(),
            stats: self.stats(),
            node_poses_in_map: self.node_poses_in_map(),
            lost: self.lost,
            node_scans: self.scans,
            timings: self.timings,
            closures,
        }
    }

    /// The constraints of `closure_edges` with their nodes as scan numbers; those from
    /// `first_refinement` on came from the final refinement.
    fn closure_constraints(&self, first_refinement: usize) -> Vec<ClosureConstraint> {
        let node_scan = &self.scan_of_node;
        let edges = self.graph.edges();
        self.closure_edges
            .iter()
            .enumerate()
            .filter_map(|(index, id)| {
                let edge = edges.get(id.0)?;
                Some(ClosureConstraint {
                    from_scan: *node_scan.get(edge.from.0)?,
                    to_scan: *node_scan.get(edge.to.0)?,
                    to_in_from: edge.to_in_from,
                    refinement: index >= first_refinement,
                })
            })
            .collect()
    }

    /// Where the time went so far (wall time on this machine).
    pub fn timings(&self) -> SlamTimings {
        self.timings
    }

    /// What happened so far.
    pub fn stats(&self) -> SlamStats {
        SlamStats {
            nodes: self.poses_in_local.len(),
            rejected_closures: self.confirmation.rejected_at_end()
                + self.weak_confirmation.rejected_at_end()
                + self.chains.rejected(),
            settled_submaps: self.settled.settled_submaps(),
            fixed_nodes: self.settled_nodes.len(),
            ..self.stats
        }
    }

    /// Whether local tracking could not place the last scan added.
    pub fn is_lost(&self) -> bool {
        self.lost.last().copied().unwrap_or(false)
    }

    /// For every scan added, whether local tracking could not place it.
    pub fn lost(&self) -> &[bool] {
        &self.lost
    }

    /// Every scan's pose in the map frame as the graph holds it now: solved for the loop
    /// closures up to the last solve; those that agreed with the graph since wait for the next
    /// one ([`SlamOptions::solve_above_chi2`]).
    pub fn poses_in_map(&self) -> Vec<Pose2> {
        let nodes = self.node_poses_in_map();
        self.scan_in_node
            .iter()
            .map(|&(node, in_node)| nodes.get(node).map_or(in_node, |&p| p * in_node))
            .collect()
    }

    /// The pose in the map frame of the `index`-th scan added, as the graph holds it now.
    pub fn pose_in_map(&self, index: usize) -> Option<Pose2> {
        let &(node, in_node) = self.scan_in_node.get(index)?;
        Some(self.node_pose_in_map(node)? * in_node)
    }

    /// The scans the map is made of (the nodes), each at its pose in the map frame now.
    pub fn map_scans(&self) -> impl Iterator<Item = (Pose2, &Scan)> {
        self.graph
            .nodes()
            .iter()
            .map(|n| n.pose_in_map)
            .zip(self.scans.iter())
    }

    /// Every node's pose in the map frame as the graph holds it now.
    fn node_poses_in_map(&self) -> Vec<Pose2> {
        self.graph.nodes().iter().map(|n| n.pose_in_map).collect()
    }

    /// The scan of `node`: a kept one, or `current`, the scan of the node being added (kept
    /// once it is added).
    fn node_scan<'a>(&'a self, node: usize, current: &'a Scan) -> Option<&'a Scan> {
        self.scans
            .get(node)
            .or((node == self.scans.len()).then_some(current))
    }

    /// The pose in the map frame of `node`, as the graph holds it now.
    fn node_pose_in_map(&self, node: usize) -> Option<Pose2> {
        self.graph.node(NodeId(node)).map(|n| n.pose_in_map)
    }

    /// Searches the finished submaps near `pose_in_map` for the scan of `node`; whether a
    /// submap took it (confirmed or not), and the submaps to search over a wider window
    /// ([`Self::close_loops_beyond_window`]) if none did.
    ///
    /// A submap is searched as usual when its frame lies within
    /// [`LoopClosureOptions::max_distance_m`], at most
    /// [`LoopClosureOptions::max_searches_per_scan`] of them: those searched longest ago, so
    /// that every near submap is searched in turn however many there are. Where the reach
    /// ([`LoopClosureOptions::gate_sigmas`] standard deviations) of the scan's pose relative
    /// to a submap goes beyond the usual window, the submap is one to search wider if its
    /// frame lies within that distance plus the reach.
    ///
    /// [`LoopClosureOptions::max_distance_m`]: super::LoopClosureOptions::max_distance_m
    /// [`LoopClosureOptions::max_searches_per_scan`]: super::LoopClosureOptions::max_searches_per_scan
    /// [`LoopClosureOptions::gate_sigmas`]: super::LoopClosureOptions::gate_sigmas
    fn close_loops(
        &mut self,
        node: usize,
        scan: &Scan,
        pose_in_map: Pose2,
        covariances: &RelativeCovariances,
    ) -> (bool, Vec<SubmapGuess>) {
        let options = self.closer.options().clone();
        self.weak_targets.clear();
        let mut near: Vec<SubmapGuess> = Vec::new();
        let mut beyond_window: Vec<SubmapGuess> = Vec::new();
        for (index, (submap, _)) in self.finished.iter().enumerate() {
            // A submap tracking still tied the scan to is not searched, unless tracking lost
            // its way since the submap's last scan and started afresh.
            let restarted_since = self
                .lost_heading
                .is_some_and(|lost| lost.last_lost > submap.last_node());
            if submap.last_node() + options.min_scans_apart > node && !restarted_since {
                continue;
            }
            let Some(submap_in_map) = self.node_pose_in_map(submap.first_node()) else {
                continue;
            };
            let guess_in_submap = submap_in_map.inverse() * pose_in_map;
            let distance_m = guess_in_submap.x_m.hypot(guess_in_submap.y_m);
            let covariance = covariances.get(&self.graph, NodeId(submap.first_node()));
            // Only the wide search reads how far the pose's uncertainty reaches.
            let [reach_m, reach_rad] = covariance
                .filter(|_| self.options.uncertain_closure.enabled)
                .map_or([0.0; 2], |covariance| {
                    reach(&covariance, options.gate_sigmas)
                });
            let guess = SubmapGuess {
                distance_m,
                submap: index,
                guess_in_submap,
                reach_m,
                reach_rad,
                covariance,
            };
            let fits_window =
                reach_m <= options.search_window_m && reach_rad <= options.search_window_rad;
            if distance_m <= options.max_distance_m {
                // A pose uncertain beyond the window is searched whatever the gain says (one
                // uncertain direction weighs little in a determinant).
                if fits_window && !self.is_informative(covariance.as_ref()) {
                    self.stats.closure_searches_skipped += 1;
                } else {
                    near.push(guess);
                }
            }
            if !fits_window && distance_m <= options.max_distance_m {
                self.weak_targets.push(index);
            }
            if !fits_window && distance_m <= options.max_distance_m + reach_m {
                beyond_window.push(guess);
            }
        }
        // Those searched longest ago first (never, before any), then the most uncertain, then
        // (all as uncertain when the reach is not computed) the nearest.
        near.sort_by(|a, b| {
            let last = |guess: &SubmapGuess| self.last_search[guess.submap];
            last(a)
                .cmp(&last(b))
                .then(b.reach_m.total_cmp(&a.reach_m))
                .then(a.distance_m.total_cmp(&b.distance_m))
        });
        let mut taken = false;
        for guess in near.into_iter().take(options.max_searches_per_scan) {
            self.last_search[guess.submap] = node;
            let (submap, reference) = &self.finished[guess.submap];
            self.stats.loop_closure_searches += 1;
            let closure = self
                .closer
                .search(submap, reference, scan, guess.guess_in_submap);
            taken |= self.offer_closure(node, guess.submap, closure).is_some();
        }
        (taken, beyond_window)
    }

    /// Searches the scan of `node` for weak matches in the nearest of the submaps whose
    /// relative pose was uncertain beyond the window at the last searched scan, and adds what
    /// is distinctive, within the graph's uncertainty and confirmed
    /// ([`super::WeakClosureOptions`]).
    fn close_loops_weakly(&mut self, node: usize, scan: &Scan, pose_in_map: Pose2) {
        let budget = self.options.weak_closure.max_searches_per_scan;
        let mut guesses: Vec<(f64, usize, Pose2)> = self
            .weak_targets
            .iter()
            .filter_map(|&index| {
                let submap_in_map = self.node_pose_in_map(self.finished[index].0.first_node())?;
                let guess = submap_in_map.inverse() * pose_in_map;
                Some((guess.x_m.hypot(guess.y_m), index, guess))
            })
            .collect();
        guesses.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (_, index, guess) in guesses.into_iter().take(budget) {
            let (submap, reference) = &self.finished[index];
            self.stats.loop_closure_searches += 1;
            self.stats.weak_closure_searches += 1;
            let Some(closure) = self.weak_closer.search(submap, reference, scan, guess) else {
                continue;
            };
            let found = found_closure(node, submap.first_node(), &closure);
            if !self.is_consistent_with_graph(&found) {
                continue;
            }
            // Distinctive over as wide a window as the pose is uncertain: a look-alike that
            // fits best only in the usual window around a wrong estimate is refused.
            let reference_scan = submap.reference_scan_from(|n| self.node_scan(n, scan));
            let ambiguity = self.uncertain_closer.ambiguity_around(
                &reference_scan,
                scan,
                closure.pose_in_submap,
            );
            if ambiguity > self.options.weak_closure.max_ambiguity {
                continue;
            }
            for confirmed in self.weak_confirmation.offer(found, &self.poses_in_local) {
                self.stats.weak_closures += 1;
                self.add_closure(confirmed);
            }
        }
    }

    /// Whether `closure` lies within the uncertainty of its scan's pose relative to its
    /// submap's frame, as the graph holds them now (its χ² against the sum of both
    /// covariances within [`LoopClosureOptions::max_consistent_chi2`]).
    ///
    /// [`LoopClosureOptions::max_consistent_chi2`]: super::LoopClosureOptions::max_consistent_chi2
    fn is_consistent_with_graph(&self, closure: &FoundClosure) -> bool {
        self.is_within_gate(&self.closure_edge(closure))
    }

    /// The constraint `closure` makes, without its robust kernel.
    fn closure_edge(&self, closure: &FoundClosure) -> Edge {
        let (from, to) = (NodeId(closure.submap_first_node), NodeId(closure.node));
        let information = closure_information(&self.options, closure.information_in_robot.as_ref());
        Edge::new(from, to, closure.pose_in_submap, information)
    }

    /// Whether `edge` (not yet in the graph), at the current poses, has a χ² against the sum
    /// of its own covariance and that of its end's pose relative to its start within
    /// [`LoopClosureOptions::max_consistent_chi2`](super::LoopClosureOptions::max_consistent_chi2).
    fn is_within_gate(&self, edge: &Edge) -> bool {
        let chi2 = || {
            let from = self.graph.node(edge.from)?;
            let to = self.graph.node(edge.to)?;
            let relative = relative_covariance(&self.graph, edge.to, edge.from)?;
            let combined = (relative + edge.information.try_inverse()?).try_inverse()?;
            let error = edge.error(from.pose_in_map, to.pose_in_map);
            Some(error.dot(&(combined * error)))
        };
        chi2().is_some_and(|chi2| chi2 <= self.options.loop_closure.max_consistent_chi2)
    }

    /// Searches the scan of `node` over the uncertain closer's wide window in a few of
    /// `beyond_window` (those searched that way longest ago first, then the nearest), and
    /// adds what is confirmed ([`super::UncertainClosureOptions`]); shortly after a lost
    /// scan, over every heading in those near it whose heading is as uncertain
    /// ([`Self::relocalise`]).
    fn close_loops_beyond_window(
        &mut self,
        node: usize,
        scan: &Scan,
        mut beyond_window: Vec<SubmapGuess>,
    ) {
        self.relocalise(node, scan, &beyond_window);
        beyond_window.sort_by(|a, b| {
            let last = |guess: &SubmapGuess| self.last_uncertain_search[guess.submap];
            last(a)
                .cmp(&last(b))
                .then(a.distance_m.total_cmp(&b.distance_m))
        });
        let budget = self.options.uncertain_closure.max_searches_per_scan;
        for guess in beyond_window.into_iter().take(budget) {
            self.last_uncertain_search[guess.submap] = node;
            self.stats.loop_closure_searches += 1;
            self.stats.uncertain_closure_searches += 1;
            let submap = &self.finished[guess.submap].0;
            let reference_scan = submap.reference_scan_from(|n| self.node_scan(n, scan));
            let window_m = self.options.uncertain_closure.search.search_window_m;
            let gate_sigmas = self.options.loop_closure.gate_sigmas;
            let guess_in_submap = guess
                .covariance
                .map_or(guess.guess_in_submap, |covariance| {
                    most_likely_overlap(
                        submap,
                        guess.guess_in_submap,
                        &covariance,
                        window_m,
                        gate_sigmas,
                    )
                });
            let closure = self.uncertain_closer.search_around_guess(
                submap,
                &reference_scan,
                scan,
                guess_in_submap,
            );
            if let Some(closure) = self.offer_closure(node, guess.submap, closure) {
                self.followed_closures.push(FollowedClosure {
                    closure,
                    found: Vec::new(),
                    relocalised: false,
                });
            }
        }
    }

    /// Relocalises the scan of `node` while the heading lost in the last stretch of lost
    /// scans ([`LostHeading`]) is not found again, for at most
    /// [`RelocalisationOptions::after_lost_nodes`] nodes after it: searches the scan over
    /// every heading in a few of the submaps of `beyond_window` whose heading relative to it
    /// is uncertain beyond the uncertain closer's turn and whose scans were taken near the
    /// ring the robot can be on (those searched longest ago first, then the nearest to the
    /// ring), and follows a match that lies on the ring and is distinctive across the window.
    /// Each search is centred on one of the places the ring is cut into
    /// ([`Ring::places`]) near the submap's scans, the next one at the submap's next search,
    /// so that searches of a submap the ring passes along cover all of that stretch of it.
    ///
    /// [`RelocalisationOptions::after_lost_nodes`]: super::RelocalisationOptions::after_lost_nodes
    fn relocalise(&mut self, node: usize, scan: &Scan, beyond_window: &[SubmapGuess]) {
        let options = &self.options.relocalisation;
        let Some(lost) = self.lost_heading.filter(|lost| {
            options.enabled && !lost.found && node <= lost.last_lost + options.after_lost_nodes
        }) else {
            return;
        };
        let (Some(anchor_in_map), Some(pose_in_map)) = (
            self.node_pose_in_map(lost.anchor),
            self.node_pose_in_map(node),
        ) else {
            return;
        };
        let ring = Ring {
            anchor_in_map,
            estimate_in_map: pose_in_map,
            slop_m: options.gate_sigmas * lost.variance_m2.sqrt()
                + options.drift_fraction * distance_m(anchor_in_map, pose_in_map),
            drift_rad: options.drift_rad,
        };
        let turn_rad = self.options.uncertain_closure.search.search_window_rad;
        let window_m = self.options.relocalisation.search.search_window_m;
        let places = ring.places(window_m);
        let mut candidates: Vec<(usize, f64, usize, Pose2)> = beyond_window
            .iter()
            .filter(|guess| guess.reach_rad > turn_rad)
            .filter_map(|guess| {
                let submap = &self.finished[guess.submap].0;
                let submap_in_map = self.node_pose_in_map(submap.first_node())?;
                // The places on the ring near the submap's scans.
                let scans_in_map: Vec<Pose2> = submap
                    .scan_poses_in_submap()
                    .map(|pose| submap_in_map * pose)
                    .collect();
                let near: Vec<(Pose2, f64)> = places
                    .iter()
                    .filter_map(|&place| {
                        let off_m = scans_in_map
                            .iter()
                            .map(|&pose| distance_m(pose, place))
                            .min_by(f64::total_cmp)?;
                        (off_m <= ring.slop_m + options.max_distance_m).then_some((place, off_m))
                    })
                    .collect();
                if near.is_empty() {
                    return None;
                }
                // Each search of the submap tries the next of them.
                let (place, off_m) = near[self.relocalisation_visits[guess.submap] % near.len()];
                Some((
                    self.last_relocalisation_search[guess.submap],
                    off_m,
                    guess.submap,
                    submap_in_map.inverse() * place,
                ))
            })
            .collect();
        if candidates.is_empty() {
            return;
        }
        candidates.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let budget = self.options.relocalisation.max_searches_per_scan;
        // Within the window the ring spans a turn of this much either way: where that is
        // within the narrow search's turn, the heading the ring gives is searched as far.
        let narrow = ring.turn_within_rad(window_m) <= self.options.relocalisation.narrow_turn_rad;
        for (_, _, index, centre_in_submap) in candidates.into_iter().take(budget) {
            self.last_relocalisation_search[index] = node;
            self.relocalisation_visits[index] += 1;
            self.stats.loop_closure_searches += 1;
            self.stats.relocalisation_searches += 1;
            let submap = &self.finished[index].0;
            let Some(submap_in_map) = self.node_pose_in_map(submap.first_node()) else {
                continue;
            };
            let reference_scan = submap.reference_scan_from(|n| self.node_scan(n, scan));
            let closer = if narrow {
                &self.narrow_relocaliser
            } else {
                &self.relocaliser
            };
            let on_ring =
                |closure: &LoopClosure| ring.holds(submap_in_map * closure.pose_in_submap);
            let closure = closer
                .search_distinct_around_guess(
                    submap,
                    &reference_scan,
                    scan,
                    centre_in_submap,
                    Some(&ring.in_frame(submap_in_map)),
                    on_ring,
                )
                .filter(|(_, ambiguity)| {
                    ambiguity.is_some_and(|a| a <= self.options.relocalisation.max_ambiguity)
                })
                .map(|(closure, _)| closure);
            if let Some(closure) = self.offer_closure(node, index, closure) {
                self.followed_closures.push(FollowedClosure {
                    closure,
                    found: Vec::new(),
                    relocalised: true,
                });
            }
        }
    }

    /// Searches the scan of `node` where each closure the uncertain closer found and that
    /// waits for its confirmation predicts it ([`ClosureConfirmation::predictions`]),
    /// aligning from that prediction alone; once [`FOLLOWED_MATCHES`] scans were found where
    /// it predicted them, they are offered to the confirmation, which adds them and the
    /// closure. Every scan is searched so while such a closure waits.
    fn follow_waiting_closures(&mut self, node: usize, scan: &Scan) {
        let window = self.options.loop_closure.confirmation.window_scans;
        self.followed_closures
            .retain(|followed| followed.closure.node + window >= node);
        let followed = &self.followed_closures;
        let predictions = self
            .confirmation
            .predictions(node, &self.poses_in_local, |c| {
                followed.iter().any(|f| f.closure == *c)
            });
        for (waiting, guess_in_submap) in predictions {
            let frame_node = waiting.submap_first_node;
            let Some(index) = self
                .finished
                .iter()
                .position(|(submap, _)| submap.first_node() == frame_node)
            else {
                continue;
            };
            let Some(position) = self
                .followed_closures
                .iter()
                .position(|f| f.closure == waiting)
            else {
                continue;
            };
            self.stats.loop_closure_searches += 1;
            let closer = if self.followed_closures[position].relocalised {
                &self.relocaliser
            } else {
                &self.closer
            };
            let Some(closure) = closer.search_from(&self.finished[index].0, scan, guess_in_submap)
            else {
                continue;
            };
            let followed = &mut self.followed_closures[position];
            followed
                .found
                .push(found_closure(node, frame_node, &closure));
            if followed.found.len() >= FOLLOWED_MATCHES {
                let relocalised = followed.relocalised;
                let found = std::mem::take(&mut followed.found);
                for found in found {
                    for confirmed in self.confirmation.offer(found, &self.poses_in_local) {
                        if relocalised && confirmed.submap_first_node == frame_node {
                            if confirmed == waiting {
                                self.stats.relocalisations += 1;
                                if let Some(lost) = &mut self.lost_heading {
                                    lost.found = true;
                                }
                            }
                            self.add_relocalisation(confirmed);
                        } else {
                            self.add_closure(confirmed);
                        }
                    }
                }
            }
        }
    }

    /// Offers what the search of the scan of `node` in finished submap `index` found to the
    /// confirmation, and adds what it confirms; what it offered, if the search found anything.
    fn offer_closure(
        &mut self,
        node: usize,
        index: usize,
        closure: Option<super::loop_closer::LoopClosure>,
    ) -> Option<FoundClosure> {
        let found = found_closure(node, self.finished[index].0.first_node(), &closure?);
        for confirmed in self.confirmation.offer(found, &self.poses_in_local) {
            self.add_closure(confirmed);
        }
        Some(found)
    }

    /// Whether a closure on a place the scan's pose is held relative to with `covariance`
    /// (`None`: not known) would tell the graph enough to search for it
    /// ([`SlamOptions::min_closure_gain_nats`](super::SlamOptions::min_closure_gain_nats)).
    fn is_informative(&self, covariance: Option<&Matrix3<f64>>) -> bool {
        let Some(relative) = covariance.filter(|_| self.options.min_closure_gain_nats > 0.0) else {
            return true;
        };
        let [sigma_m, sigma_rad] = self.options.loop_closure_sigma;
        let Some(closure) =
            Edge::information_from_std_devs(sigma_m, sigma_m, sigma_rad).try_inverse()
        else {
            return true;
        };
        closure_gain_nats(relative, &closure) >= self.options.min_closure_gain_nats
    }

    /// Searches the scan of `node` in a chain of earlier scans and adds what is confirmed;
    /// not when a closure on the chain's centre would tell the graph too little, by the
    /// scan's `covariances` relative to every node (`None`: the scan is searched because a
    /// closure waits for its confirmation).
    fn close_loops_in_chain(
        &mut self,
        node: usize,
        scan: &Scan,
        pose_in_map: Pose2,
        covariances: Option<&RelativeCovariances>,
    ) {
        let nearest_earlier = self.nearest_earlier_node(node, pose_in_map);
        if let Some(covariances) = covariances {
            let covariance = nearest_earlier.and_then(|n| covariances.get(&self.graph, NodeId(n)));
            if !self.is_informative(covariance.as_ref()) {
                self.stats.closure_searches_skipped += 1;
                return;
            }
        }
        let confirmed = self.chains.close(
            node,
            scan,
            pose_in_map,
            &ChainContext {
                nodes: self.graph.nodes(),
                nearest_earlier,
                poses_in_local: &self.poses_in_local,
                scans: &self.scans,
            },
            &mut self.stats.chain_closure_searches,
        );
        for confirmed in confirmed {
            let frame_node = confirmed.submap_first_node;
            if let Some(id) = self.add_constraint(confirmed, false) {
                self.settled.closure_on_node(frame_node, id);
                self.stats.loop_closures += 1;
                self.stats.chain_closures += 1;
            }
        }
    }

    /// The node nearest to `pose_in_map` that a chain search from `node` may centre on:
    /// within the chain search's distance, and at least its scans apart before `node`.
    fn nearest_earlier_node(&self, node: usize, pose_in_map: Pose2) -> Option<usize> {
        let search = &self.options.chain_closure.search;
        // Only nodes whose scans are kept: the scan of `node` is kept once it is added.
        let last = node
            .checked_sub(search.min_scans_apart)?
            .min(self.scans.len().checked_sub(1)?);
        self.node_index.nearest(
            [pose_in_map.x_m, pose_in_map.y_m],
            search.max_distance_m,
            last,
            |n| self.node_pose_in_map(n),
        )
    }

    /// Settles the submaps whose closures now agree with the graph (`graph_moved`: it was
    /// solved for this scan, `node`) and fixes the nodes all of whose submaps settled.
    fn settle(&mut self, node: usize, graph_moved: bool) {
        let started = Instant::now();
        let first_active_node = self
            .tracker
            .active_submaps()
            .iter()
            .map(SlamSubmap::first_node)
            .min()
            .unwrap_or(node);
        let ready = self.settled.settle(
            &self.graph,
            self.options.solve_above_chi2,
            self.options.degenerate_information_ratio,
            first_active_node,
            graph_moved,
        );
        for settled in ready {
            if self.graph.set_fixed(NodeId(settled), true).is_ok() {
                self.settled_nodes.push(settled);
                if self.options.refinement.enabled {
                    self.refined_ahead.fixed(settled);
                }
                if let Some(pose) = self.node_pose_in_map(settled) {
                    self.node_index.fix(settled, pose);
                }
            }
        }
        self.timings.settling_s += seconds_since(started);
    }

    /// Aligns the nodes fixed since as the final refinement would, a few a call
    /// ([`RefinedAhead`]), so that the end of the run is left with the nodes that never
    /// settled.
    fn refine_ahead(&mut self) {
        if !self.options.refinement.enabled || !self.refined_ahead.has_pending() {
            return;
        }
        let started = Instant::now();
        let submaps: Vec<&SlamSubmap> = self.finished.iter().map(|(submap, _)| submap).collect();
        let nodes = self.graph.nodes();
        self.refined_ahead.align_pending(
            self.options.refinement.nodes_ahead_per_node,
            |node| nodes.get(node).map(|n| n.pose_in_map),
            &submaps,
            &self.scans,
            &self.options,
        );
        self.stats.nodes_refined_ahead = self.refined_ahead.nodes_aligned();
        self.timings.refining_ahead_s += seconds_since(started);
    }

    /// Adds the final refinement's constraints (`active`: the submaps still active at the
    /// end, now finished) and optimises once more.
    fn refine(&mut self, active: &[SlamSubmap]) {
        let submaps: Vec<&SlamSubmap> = self
            .finished
            .iter()
            .map(|(submap, _)| submap)
            .chain(active)
            .collect();
        let every_node: Vec<usize> = (0..self.graph.nodes().len()).collect();
        let closures = refinement_closures(
            |node| self.node_pose_in_map(node),
            &every_node,
            &submaps,
            &self.scans,
            &self.options,
            &self.refined_ahead,
        );
        for closure in closures {
            if self.add_constraint(closure, false).is_some() {
                self.stats.refinement_constraints += 1;
            }
        }
        if self.closures_since_optimization > 0 {
            self.optimize();
        }
    }

    fn add_closure(&mut self, closure: FoundClosure) {
        self.add_closure_held(closure, false);
    }

    /// Adds a relocalisation's closure: it lies where the robot can be after its heading was
    /// lost (a ring the graph's linearised covariance cannot hold), so it is solved once
    /// without the kernel whatever the gate says.
    fn add_relocalisation(&mut self, closure: FoundClosure) {
        self.add_closure_held(closure, true);
    }

    /// [`Self::add_constraint`], counted and told to its submap.
    fn add_closure_held(&mut self, closure: FoundClosure, held: bool) {
        let submap_first_node = closure.submap_first_node;
        if let Some(id) = self.add_constraint(closure, held) {
            self.stats.loop_closures += 1;
            self.settled.closure_on_submap(submap_first_node, id);
        }
    }

    /// Adds `closure` to the graph as a robust constraint; whether it was added.
    ///
    /// A robust kernel judges a constraint by how far the graph holds it from what it
    /// measured, at the graph's current poses: after a long drift a true closure is metres
    /// off, and the kernel would switch it off before it could pull. So a closure that the
    /// kernel would weaken, but whose error is within the uncertainty of the scan's pose
    /// relative to the submap (its χ² against the sum of both covariances within
    /// [`LoopClosureOptions::max_consistent_chi2`](super::LoopClosureOptions::max_consistent_chi2)),
    /// is solved once without the kernel, and keeps it from then on; so is one `held` within
    /// the uncertainty by another test. Returns the edge added.
    fn add_constraint(&mut self, closure: FoundClosure, held: bool) -> Option<EdgeId> {
        let kernel = self.options.loop_closure_kernel;
        let edge = self.closure_edge(&closure).with_kernel(kernel);
        let within_uncertainty = if held {
            self.kernel_weakens(&edge)
        } else {
            self.is_within_uncertainty(&edge)
        };
        let Ok(id) = self.graph.add_edge(edge) else {
            return None;
        };
        if within_uncertainty && self.graph.set_kernel(id, None).is_ok() {
            self.unrobust_edges.push(id);
            self.stats.closures_within_uncertainty += 1;
        }
        self.closure_edges.push(id);
        self.closures_since_optimization += 1;
        // What the solve's first step sees of it: its χ² weighted by the kernel.
        self.chi2_since_optimization += if within_uncertainty {
            f64::INFINITY
        } else {
            self.graph
                .edge_chi2(id)
                .map_or(f64::INFINITY, |chi2| kernel.weight(chi2) * chi2)
        };
        Some(id)
    }

    /// Whether the kernel would weaken `edge` (not yet in the graph) at the current poses,
    /// while its error is within the uncertainty of its end's pose relative to its start.
    fn is_within_uncertainty(&self, edge: &Edge) -> bool {
        self.kernel_weakens(edge) && self.is_within_gate(edge)
    }

    /// Whether `edge`'s robust kernel would weaken it at the current poses.
    fn kernel_weakens(&self, edge: &Edge) -> bool {
        let (Some(from), Some(to)) = (self.graph.node(edge.from), self.graph.node(edge.to)) else {
            return false;
        };
        let chi2 = edge.chi2(from.pose_in_map, to.pose_in_map);
        edge.kernel.is_some_and(|kernel| kernel.weight(chi2) < 1.0)
    }

    fn optimize(&mut self) {
        let started = Instant::now();
        self.closures_since_optimization = 0;
        self.chi2_since_optimization = 0.0;
        self.stats.optimizations += 1;
        if self.graph.optimize(&self.options.optimize).is_err() {
            self.stats.failed_optimizations += 1;
        }
        let kernel = self.options.loop_closure_kernel;
        if !self.unrobust_edges.is_empty() {
            // Pulled once with full weight; from now on the kernel judges them as any other.
            for id in std::mem::take(&mut self.unrobust_edges) {
                let _ = self.graph.set_kernel(id, Some(kernel));
            }
            self.stats.optimizations += 1;
            if self.graph.optimize(&self.options.optimize).is_err() {
                self.stats.failed_optimizations += 1;
            }
        }
        self.stats.switched_off_closures = self
            .closure_edges
            .iter()
            .filter_map(|&id| self.graph.edge_chi2(id))
            .filter(|&chi2| kernel.weight(chi2) < 0.25)
            .count();
        let last = self.poses_in_local.len().saturating_sub(1);
        if let (Some(pose_in_map), Some(pose_in_local)) =
            (self.node_pose_in_map(last), self.poses_in_local.last())
        {
            self.map_from_local = pose_in_map * pose_in_local.inverse();
        }
        self.timings.optimization_s += seconds_since(started);
    }
}

/// The scan of `node` found by a search in the submap whose frame is `submap_first_node`.
fn found_closure(
    node: usize,
    submap_first_node: usize,
    closure: &super::loop_closer::LoopClosure,
) -> FoundClosure {
    FoundClosure {
        submap_first_node,
        node,
        pose_in_submap: closure.pose_in_submap,
        information_in_robot: Some(closure.information_in_robot),
    }
}

/// Scans found where a followed closure predicts them before they are offered to the
/// confirmation ([`GraphSlam::follow_waiting_closures`]): a closure from a search as wide as
/// the uncertain closer's must predict two more scans, as a look-alike place that goes on
/// looking alike for one scan more (two offices in a row) is not rare.
const FOLLOWED_MATCHES: usize = 2;

/// A closure of the uncertain closer waiting for its confirmation, and the scans found since
/// where it predicted them.
#[derive(Clone, Debug)]
struct FollowedClosure {
    closure: FoundClosure,
    found: Vec<FoundClosure>,
    /// Found by the relocaliser: the scans after it are tested as its matches are.
    relocalised: bool,
}

/// A stretch of scans local tracking could not place, and what it leaves unknown.
///
/// A lost scan keeps the motion prior's prediction; over a turn on the spot the heading is
/// then anyone's guess while the position is off by about the prior's translation for each
/// lost scan. The scans tracked since are right relative to each other, so the robot lies
/// on a ring around the last node placed before the stretch (its `anchor`), as far from it
/// as the estimate is, turned by the unknown heading error about it.
#[derive(Clone, Copy, Debug)]
struct LostHeading {
    /// The last node placed before the stretch.
    anchor: usize,
    /// The stretch's last lost node.
    last_lost: usize,
    /// The variance of the position the lost scans leave, m² (the prior's, summed).
    variance_m2: f64,
    /// Whether a relocalisation was confirmed since.
    found: bool,
}

/// Where the robot can be after a [`LostHeading`]: its estimate turned about the anchor by
/// the unknown heading error, its position within `slop_m` and its heading within
/// `drift_rad` (and what `slop_m` makes of a turn at that distance) of that.
#[derive(Clone, Copy, Debug)]
struct Ring {
    anchor_in_map: Pose2,
    estimate_in_map: Pose2,
    slop_m: f64,
    drift_rad: f64,
}

impl Ring {
    /// The ring's radius: the estimate's distance from the anchor, metres.
    fn radius_m(&self) -> f64 {
        distance_m(self.anchor_in_map, self.estimate_in_map)
    }

    /// The heading of the estimate turned about the anchor to the bearing of
    /// `pose_in_map`'s position, radians.
    fn heading_at(&self, pose_in_map: Pose2) -> f64 {
        self.estimate_in_map.theta_rad + self.turn_to(pose_in_map)
    }

    /// The turn about the anchor from the estimate's bearing to `pose_in_map`'s, radians.
    fn turn_to(&self, pose_in_map: Pose2) -> f64 {
        let bearing = |pose: Pose2| {
            (pose.y_m - self.anchor_in_map.y_m).atan2(pose.x_m - self.anchor_in_map.x_m)
        };
        crate::geometry::wrap_angle_rad(bearing(pose_in_map) - bearing(self.estimate_in_map))
    }

    /// How far either way the heading turns along the part of the ring a square window of
    /// half width `window_m` holds, radians (π where the window may hold the whole ring).
    fn turn_within_rad(&self, window_m: f64) -> f64 {
        let reach_m = window_m * std::f64::consts::SQRT_2 + self.slop_m;
        let radius_m = self.radius_m();
        if reach_m >= radius_m {
            return std::f64::consts::PI;
        }
        (reach_m / radius_m).asin() + self.drift_rad
    }

    /// The estimate turned about the anchor by `turn_rad`: where the robot is if that was
    /// the heading error.
    fn turned(&self, turn_rad: f64) -> Pose2 {
        let anchor = Pose2::new(self.anchor_in_map.x_m, self.anchor_in_map.y_m, 0.0);
        anchor * Pose2::new(0.0, 0.0, turn_rad) * anchor.inverse() * self.estimate_in_map
    }

    /// Places on the ring to centre searches of half width `window_m` on, so that every
    /// place the robot can be lies within one of them: the anchor, headed as the estimate,
    /// where one window holds the whole ring; otherwise the estimate turned about the anchor
    /// in steps of `window_m` along the ring.
    fn places(&self, window_m: f64) -> Vec<Pose2> {
        let radius_m = self.radius_m();
        if radius_m + self.slop_m <= window_m {
            let heading = self.estimate_in_map.theta_rad;
            return vec![Pose2::new(
                self.anchor_in_map.x_m,
                self.anchor_in_map.y_m,
                heading,
            )];
        }
        let count = (std::f64::consts::TAU * radius_m / window_m)
            .ceil()
            .max(1.0) as usize;
        (0..count)
            .map(|k| self.turned(std::f64::consts::TAU * k as f64 / count as f64))
            .collect()
    }

    /// The same ring in the frame `frame_in_map` (its poses, named in the map, then in that
    /// frame).
    fn in_frame(&self, frame_in_map: Pose2) -> Ring {
        let map_in_frame = frame_in_map.inverse();
        Ring {
            anchor_in_map: map_in_frame * self.anchor_in_map,
            estimate_in_map: map_in_frame * self.estimate_in_map,
            ..*self
        }
    }

    /// How far `pose_in_map`'s position lies off the circle, metres.
    fn off_m(&self, pose_in_map: Pose2) -> f64 {
        (distance_m(self.anchor_in_map, pose_in_map) - self.radius_m()).abs()
    }

    /// Whether `pose_in_map` is the estimate turned about the anchor: its position on the
    /// ring, and its heading turned by as much as its position (where the ring is wide
    /// enough for that angle to be known).
    fn holds(&self, pose_in_map: Pose2) -> bool {
        if self.off_m(pose_in_map) > self.slop_m {
            return false;
        }
        let radius_m = self.radius_m();
        if radius_m <= self.slop_m {
            return true;
        }
        let disagreement =
            crate::geometry::wrap_angle_rad(pose_in_map.theta_rad - self.heading_at(pose_in_map))
                .abs();
        disagreement <= (self.slop_m / radius_m).asin() + self.drift_rad
    }
}

impl PoseRegion for Ring {
    /// Whether a pose headed `heading_rad` in the rectangle may be [held](Ring::holds): the
    /// rectangle reaches into the band `slop_m` either side of the circle, and the heading is
    /// within the ring's tolerance of the heading the ring gives at some bearing of the
    /// rectangle from the anchor.
    fn may_hold(&self, heading_rad: f64, min_m: [f64; 2], max_m: [f64; 2]) -> bool {
        let anchor = [self.anchor_in_map.x_m, self.anchor_in_map.y_m];
        let nearest = |axis: usize| (min_m[axis] - anchor[axis]).max(anchor[axis] - max_m[axis]);
        let farthest = |axis: usize| {
            (min_m[axis] - anchor[axis])
                .abs()
                .max((max_m[axis] - anchor[axis]).abs())
        };
        let near_m = nearest(0).max(0.0).hypot(nearest(1).max(0.0));
        let far_m = farthest(0).hypot(farthest(1));
        let radius_m = self.radius_m();
        if near_m > radius_m + self.slop_m || far_m < radius_m - self.slop_m {
            return false;
        }
        if radius_m <= self.slop_m || near_m == 0.0 {
            // Every heading, or every bearing from the anchor.
            return true;
        }
        // The bearings of the rectangle from the anchor, about that of its centre: the anchor
        // lies outside it, so its corners span them, less than half a turn.
        let bearing = |p: [f64; 2]| (p[1] - anchor[1]).atan2(p[0] - anchor[0]);
        let centre = [0.5 * (min_m[0] + max_m[0]), 0.5 * (min_m[1] + max_m[1])];
        let centre_bearing = bearing(centre);
        let (mut low_rad, mut high_rad) = (0.0f64, 0.0f64);
        for corner in [min_m, [max_m[0], min_m[1]], max_m, [min_m[0], max_m[1]]] {
            let turn = crate::geometry::wrap_angle_rad(bearing(corner) - centre_bearing);
            low_rad = low_rad.min(turn);
            high_rad = high_rad.max(turn);
        }
        let tolerance_rad = (self.slop_m / radius_m).asin() + self.drift_rad;
        let at_centre = Pose2::new(centre[0], centre[1], 0.0);
        let turn = crate::geometry::wrap_angle_rad(heading_rad - self.heading_at(at_centre));
        let tau = std::f64::consts::TAU;
        [turn - tau, turn, turn + tau]
            .iter()
            .any(|&turn| (low_rad - tolerance_rad..=high_rad + tolerance_rad).contains(&turn))
    }
}

/// The distance between two poses' positions, metres.
fn distance_m(a: Pose2, b: Pose2) -> f64 {
    (a.x_m - b.x_m).hypot(a.y_m - b.y_m)
}

/// A finished submap the scan may be found in, and where.
#[derive(Clone, Copy, Debug)]
struct SubmapGuess {
    /// The scan's distance from the submap's frame, metres.
    distance_m: f64,
    /// The submap's index among the finished ones.
    submap: usize,
    /// The scan's estimated pose in the submap (`submap_from_robot`).
    guess_in_submap: Pose2,
    /// How far the uncertainty of that pose reaches along its most uncertain direction
    /// ([`LoopClosureOptions::gate_sigmas`] standard deviations), metres; 0 where not known.
    ///
    /// [`LoopClosureOptions::gate_sigmas`]: super::LoopClosureOptions::gate_sigmas
    reach_m: f64,
    /// How far it reaches in heading, radians; 0 where not known.
    reach_rad: f64,
    /// The covariance of that pose, in the scan's frame; `None` where not known.
    covariance: Option<Matrix3<f64>>,
}

/// Where to centre a search of a scan estimated at `guess_in_submap` in `submap`, the pose
/// uncertain with `covariance` (in the scan's frame): where the submap's scans were taken,
/// the one most likely under that uncertainty, when it lies beyond a window of `window_m`
/// around the guess and within `gate_sigmas` standard deviations of it; the guess otherwise.
/// After a stretch tracking could not place, the estimate may lie tens of metres from the
/// place it has come back to, farther than any window reaches, while the uncertainty it
/// carries still covers the place: the search goes where the robot could be and the submap
/// has seen, rather than where the robot was guessed to be.
fn most_likely_overlap(
    submap: &SlamSubmap,
    guess_in_submap: Pose2,
    covariance: &Matrix3<f64>,
    window_m: f64,
    gate_sigmas: f64,
) -> Pose2 {
    // The position's covariance in the submap frame: a perturbation in the scan's frame
    // turned by the guess's heading.
    let (sin, cos) = guess_in_submap.theta_rad.sin_cos();
    let rotation = nalgebra::Matrix2::new(cos, -sin, sin, cos);
    let position = covariance.fixed_view::<2, 2>(0, 0).into_owned();
    let Some(information) = (rotation * position * rotation.transpose()).try_inverse() else {
        return guess_in_submap;
    };
    let squared_sigmas = |pose: &Pose2| {
        let offset = nalgebra::Vector2::new(
            pose.x_m - guess_in_submap.x_m,
            pose.y_m - guess_in_submap.y_m,
        );
        (offset.transpose() * information * offset)[0]
    };
    let Some((nearest, sigmas2)) = submap
        .scan_poses_in_submap()
        .map(|pose| (pose, squared_sigmas(&pose)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return guess_in_submap;
    };
    let distance_m = (nearest.x_m - guess_in_submap.x_m).hypot(nearest.y_m - guess_in_submap.y_m);
    if distance_m <= window_m || sigmas2 > gate_sigmas * gate_sigmas {
        return guess_in_submap;
    }
    Pose2::new(nearest.x_m, nearest.y_m, guess_in_submap.theta_rad)
}

/// How far `gate_sigmas` standard deviations of a relative pose with `covariance` (x, y,
/// theta) reach: along the translation's most uncertain direction (m), and in heading (rad).
fn reach(covariance: &nalgebra::Matrix3<f64>, gate_sigmas: f64) -> [f64; 2] {
    let (xx, yy, xy) = (covariance[(0, 0)], covariance[(1, 1)], covariance[(0, 1)]);
    let largest = 0.5 * (xx + yy) + (0.25 * (xx - yy).powi(2) + xy * xy).sqrt();
    [
        gate_sigmas * largest.max(0.0).sqrt(),
        gate_sigmas * covariance[(2, 2)].max(0.0).sqrt(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan_match::synthetic::{WallInMap, cast_front_scan, polygon_walls};
    use std::f64::consts::{FRAC_PI_2, TAU};

    /// A ring corridor around a block, with alcoves and pillars that break its symmetry.
    fn ring_walls() -> Vec<WallInMap> {
        let mut walls = polygon_walls(&[[-6.0, -4.0], [6.0, -4.0], [6.0, 4.0], [-6.0, 4.0]]);
        walls.extend(polygon_walls(&[
            [-3.5, -1.5],
            [3.5, -1.5],
            [3.5, 1.5],
            [-3.5, 1.5],
        ]));
        for (x, y) in [
            (-5.2, 3.0),
            (2.0, -3.3),
            (5.3, -0.5),
            (-1.0, 2.2),
            (4.0, 3.3),
        ] {
            walls.extend(polygon_walls(&[
                [x - 0.2, y - 0.2],
                [x + 0.2, y - 0.2],
                [x + 0.2, y + 0.2],
                [x - 0.2, y + 0.2],
            ]));
        }
        walls
    }

    /// Poses round the ring, counter-clockwise, about 0.25 m apart, `laps` times.
    fn ring_trajectory(laps: f64) -> Vec<Pose2> {
        let steps = (laps * 140.0) as usize;
        (0..steps)
            .map(|k| {
                let angle = k as f64 / 140.0 * TAU;
                let (sin, cos) = angle.sin_cos();
                Pose2::new(4.75 * cos, 2.75 * sin, angle + FRAC_PI_2)
            })
            .collect()
    }

    #[test]
    fn tracks_a_ring_and_closes_the_loop_without_odometry() {
        let walls = ring_walls();
        let truth = ring_trajectory(1.3);
        let scans: Vec<Scan> = truth
            .iter()
            .map(|&pose| cast_front_scan(&walls, pose))
            .collect();
        let mut slam = GraphSlam::new(SlamOptions::default()).unwrap();
        for (k, scan) in scans.iter().enumerate() {
            slam.add_scan(k as f64 * 0.1, scan, None);
        }
        let result = slam.finish();
        assert_eq!(result.poses_in_map.len(), truth.len());
        assert!(result.stats.loop_closures > 0, "{:?}", result.stats);
        assert!(
            result.stats.refinement_constraints > 0,
            "{:?}",
            result.stats
        );
        // Every pose, in the frame of the first one, against the truth.
        let origin = truth[0].inverse();
        let mut worst_m: f64 = 0.0;
        for (estimate, truth) in result.poses_in_map.iter().zip(&truth) {
            let truth_in_first = origin * *truth;
            let error = truth_in_first.inverse() * *estimate;
            worst_m = worst_m.max(error.x_m.hypot(error.y_m));
        }
        // Over 33 m of noise-free scans; local tracking is the limit.
        assert!(worst_m < 0.10, "worst position error {worst_m} m");
    }

    /// Four laps of the ring with `options`: the SLAM before its end, and the truth.
    fn four_laps(options: SlamOptions) -> (GraphSlam, Vec<Pose2>) {
        let walls = ring_walls();
        let truth = ring_trajectory(4.0);
        let budget = options.loop_closure.max_searches_per_scan;
        let most = budget + options.uncertain_closure.max_searches_per_scan;
        let mut slam = GraphSlam::new(options).unwrap();
        for (k, pose) in truth.iter().enumerate() {
            let before = slam.stats().loop_closure_searches;
            slam.add_scan(k as f64 * 0.1, &cast_front_scan(&walls, *pose), None);
            // The usual searches, and those of a pose too uncertain for the usual window.
            let searches = slam.stats().loop_closure_searches - before;
            assert!(searches <= most, "scan {k}: {searches} searches");
        }
        (slam, truth)
    }

    #[test]
    fn laps_round_a_place_search_a_bounded_few_submaps_and_solve_only_on_disagreement() {
        let options = SlamOptions::default();
        let budget = options.loop_closure.max_searches_per_scan;
        let every = options.loop_closure.every_n_scans;
        let (slam, truth) = four_laps(options.clone());
        let stats = slam.stats();
        // The whole ring lies within the search distance: by the last lap every finished
        // submap is near, and more of them than the budget.
        let searched_on_last_lap = &slam.last_search;
        assert!(searched_on_last_lap.len() > 2 * budget, "{stats:?}");
        let last_lap_start = slam.poses_in_local.len() * 3 / 4;
        let old_enough = searched_on_last_lap.len() - 2;
        assert!(
            searched_on_last_lap[..old_enough]
                .iter()
                .all(|&node| node >= last_lap_start),
            "every submap searched in turn: {searched_on_last_lap:?}"
        );
        assert!(
            stats.loop_closure_searches <= budget * truth.len().div_ceil(every) + 10,
            "{stats:?}"
        );
        // Closures on the later laps agree with the graph: a solve for each of them, as
        // before, would have been many more.
        let every_closure = SlamOptions {
            solve_above_chi2: -1.0,
            ..options
        };
        let solved_each = four_laps(every_closure).0.stats();
        assert!(stats.loop_closures > 40, "{stats:?}");
        assert!(
            stats.optimizations * 5 < solved_each.optimizations,
            "{stats:?} against {solved_each:?}"
        );
        // The laps agree: the early ones settled, and the solves work on the later ones.
        let free = slam.graph.nodes().iter().filter(|n| !n.fixed).count();
        assert!(stats.settled_submaps > 0, "{stats:?}");
        assert_eq!(stats.fixed_nodes, slam.graph.nodes().len() - free - 1);
        assert!(
            free < slam.graph.nodes().len() / 2,
            "{free} free: {stats:?}"
        );
        // The settled places were refined as they settled, not left to the end.
        assert!(stats.nodes_refined_ahead > 0, "{stats:?}");
        assert!(slam.timings().refining_ahead_s > 0.0);
        let result = slam.finish();
        // Every part of the run was timed, each apart.
        let parts = result.timings;
        assert!(
            [
                parts.tracking_s,
                parts.closure_candidates_s,
                parts.closure_searches_s,
                parts.optimization_s,
                parts.finish_s
            ]
            .iter()
            .all(|&s| s > 0.0),
            "{parts:?}"
        );
        let worst_m = worst_error_m(&result.poses_in_map, &truth);
        assert!(worst_m < 0.10, "worst position error {worst_m} m");
    }

    /// The worst position error of a run's `poses_in_map` against `truth`, in the first
    /// pose's frame, metres.
    fn worst_error_m(poses_in_map: &[Pose2], truth: &[Pose2]) -> f64 {
        let origin = truth[0].inverse();
        poses_in_map
            .iter()
            .zip(truth)
            .map(|(estimate, truth)| {
                let error = (origin * *truth).inverse() * *estimate;
                error.x_m.hypot(error.y_m)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn places_the_pose_is_tied_to_already_are_searched_only_as_its_uncertainty_grows() {
        let (tied, truth) = four_laps(SlamOptions::default());
        let (every, _) = four_laps(SlamOptions {
            min_closure_gain_nats: 0.0,
            ..SlamOptions::default()
        });
        let (tied_stats, every_stats) = (tied.stats(), every.stats());
        let searches = |s: &SlamStats| s.loop_closure_searches + s.chain_closure_searches;
        assert_eq!(every_stats.closure_searches_skipped, 0, "{every_stats:?}");
        assert!(tied_stats.closure_searches_skipped > 0, "{tied_stats:?}");
        // Later laps are still closed, with fewer searches.
        assert!(tied_stats.loop_closures > 20, "{tied_stats:?}");
        assert!(
            searches(&tied_stats) * 3 < searches(&every_stats) * 2,
            "{tied_stats:?} against {every_stats:?}"
        );
        let worst = |slam: GraphSlam| worst_error_m(&slam.finish().poses_in_map, &truth);
        let (tied_m, every_m) = (worst(tied), worst(every));
        assert!(
            tied_m < 0.10,
            "worst position error {tied_m} m ({every_m} m)"
        );
    }

    /// A SLAM fed 1.1 laps of the ring but the last scan, the poses of every scan, and that
    /// last scan (back near the start).
    fn ring_but_the_last_scan() -> (GraphSlam, Vec<Pose2>, Scan) {
        let walls = ring_walls();
        let truth = ring_trajectory(1.1);
        let mut scans: Vec<Scan> = truth
            .iter()
            .map(|&pose| cast_front_scan(&walls, pose))
            .collect();
        let last = scans.pop().expect("scans");
        let mut slam = GraphSlam::new(SlamOptions::default()).unwrap();
        for (k, scan) in scans.iter().enumerate() {
            slam.add_scan(k as f64 * 0.1, scan, None);
        }
        (slam, truth, last)
    }

    /// Back on the ring at its start, the robot turns round on the spot and drives back the
    /// way it came: the scans of the turn show nothing (lost), and tracking keeps the last
    /// motion for them. The SLAM's poses after the turn, and the truth.
    fn turn_round_unseen(options: SlamOptions) -> (SlamResult, Vec<Pose2>) {
        let walls = ring_walls();
        let mut truth = ring_trajectory(1.1);
        let turned_at = *truth.last().expect("poses");
        let turn_steps = 6;
        for step in 1..=turn_steps {
            let turn = std::f64::consts::PI * f64::from(step) / f64::from(turn_steps);
            truth.push(turned_at * Pose2::new(0.0, 0.0, turn));
        }
        let lost_from = truth.len() - turn_steps as usize;
        let back = ring_trajectory(1.1);
        let turned_round = Pose2::new(0.0, 0.0, std::f64::consts::PI);
        truth.extend(
            back.iter()
                .rev()
                .skip(1)
                .take(60)
                .map(|&p| p * turned_round),
        );
        let nothing = Scan::from_points_in_robot(vec![None; 181]);
        let mut slam = GraphSlam::new(options).unwrap();
        for (k, &pose) in truth.iter().enumerate() {
            let scan = if (lost_from..lost_from + turn_steps as usize).contains(&k) {
                nothing.clone()
            } else {
                cast_front_scan(&walls, pose)
            };
            slam.add_scan(k as f64 * 0.1, &scan, None);
        }
        (slam.finish(), truth)
    }

    #[test]
    fn a_heading_lost_on_a_turn_is_found_again_on_the_ring_it_can_be_on() {
        let (found, truth) = turn_round_unseen(SlamOptions::default());
        assert!(found.stats.lost_scans >= 6, "{:?}", found.stats);
        assert!(found.stats.relocalisations >= 1, "{:?}", found.stats);
        // The lost scans' poses are what the graph makes of the prior; the others are seen.
        let seen = |poses: &[Pose2], lost: &[bool]| -> Vec<(Pose2, Pose2)> {
            poses
                .iter()
                .zip(&truth)
                .zip(lost)
                .filter(|(_, lost)| !**lost)
                .map(|((&estimate, &truth), _)| (estimate, truth))
                .collect()
        };
        let (estimates, truths): (Vec<Pose2>, Vec<Pose2>) =
            seen(&found.poses_in_map, &found.lost).into_iter().unzip();
        let error_m = worst_error_m(&estimates, &truths);
        assert!(error_m < 0.05, "worst position error {error_m} m");
        // Without relocalisation the drive back is mapped the wrong way.
        let mut options = SlamOptions::default();
        options.relocalisation.enabled = false;
        let (without, _) = turn_round_unseen(options);
        assert_eq!(without.stats.relocalisation_searches, 0);
        let error_m = worst_error_m(&without.poses_in_map, &truth);
        assert!(error_m > 1.0, "worst position error {error_m} m");
    }

    #[test]
    fn a_ring_holds_the_estimate_turned_about_its_anchor_and_nothing_else() {
        let anchor_in_map = Pose2::new(2.0, 1.0, 0.3);
        // 20 m ahead of the anchor, as tracking has it since the lost stretch.
        let estimate_in_map = anchor_in_map * Pose2::new(20.0, 0.0, 0.0);
        let ring = Ring {
            anchor_in_map,
            estimate_in_map,
            slop_m: 1.0,
            drift_rad: 2f64.to_radians(),
        };
        for turn_deg in [-170.0, -70.0, 0.0, 45.0, 120.0] {
            let pose = ring.turned(f64::to_radians(turn_deg));
            assert!(ring.holds(pose), "{turn_deg}°");
            // The same place with its heading not turned with it.
            let unturned = Pose2::new(pose.x_m, pose.y_m, estimate_in_map.theta_rad);
            assert_eq!(ring.holds(unturned), turn_deg == 0.0, "{turn_deg}°");
        }
        // Off the ring by more than its slop.
        assert!(!ring.holds(ring.turned(1.0) * Pose2::new(1.5, 0.0, 0.0)));
        assert!(ring.holds(ring.turned(1.0) * Pose2::new(0.5, 0.0, 0.0)));
        // A 16 m window on a 20 m ring may hold any heading; on a 200 m ring, a few degrees.
        assert_eq!(ring.turn_within_rad(16.0), std::f64::consts::PI);
        let far = Ring {
            estimate_in_map: anchor_in_map * Pose2::new(200.0, 0.0, 0.0),
            ..ring
        };
        let turn_deg = far.turn_within_rad(16.0).to_degrees();
        assert!((8.0..10.0).contains(&turn_deg), "{turn_deg}°");
    }

    #[test]
    fn the_places_of_a_ring_leave_no_part_of_it_outside_every_window() {
        let anchor_in_map = Pose2::new(-4.0, 7.0, 1.0);
        let window_m = 16.0;
        for radius_m in [3.0, 14.0, 40.0, 115.0] {
            let ring = Ring {
                anchor_in_map,
                estimate_in_map: anchor_in_map * Pose2::new(radius_m, 0.0, 0.5),
                slop_m: 2.0,
                drift_rad: 5f64.to_radians(),
            };
            let places = ring.places(window_m);
            if radius_m + ring.slop_m <= window_m {
                // One window on the anchor holds the whole ring.
                assert_eq!(places.len(), 1, "{radius_m} m");
                assert!(distance_m(places[0], anchor_in_map) < 1e-9);
            } else {
                // Each place is the estimate turned about the anchor: on the ring, headed
                // as the ring has it there.
                assert!(
                    places.iter().all(|&place| ring.holds(place)),
                    "{radius_m} m"
                );
            }
            // Every place the robot can be (on the ring, within the slop) lies within the
            // square window of one of them.
            for k in 0..720 {
                let turned = ring.turned(f64::from(k).to_radians() / 2.0);
                for off_m in [-ring.slop_m, 0.0, ring.slop_m] {
                    let pose = turned * Pose2::new(off_m, 0.0, 0.0);
                    let inside = places.iter().any(|place| {
                        (pose.x_m - place.x_m).abs() <= window_m
                            && (pose.y_m - place.y_m).abs() <= window_m
                    });
                    assert!(inside, "{radius_m} m, {k}/2°, {off_m} m off");
                }
            }
        }
    }

    #[test]
    fn a_ring_rules_out_no_block_that_holds_a_pose_on_it_and_decides_single_poses() {
        let anchor_in_map = Pose2::new(-4.0, 7.0, 1.0);
        // A ring in a submap's frame, as a relocalisation searches it.
        let frame_in_map = Pose2::new(10.0, -3.0, 2.0);
        for radius_m in [1.5, 6.0, 25.0] {
            let ring = Ring {
                anchor_in_map,
                estimate_in_map: anchor_in_map * Pose2::new(radius_m, 0.0, 0.5),
                slop_m: 2.0,
                drift_rad: 5f64.to_radians(),
            };
            let in_frame = ring.in_frame(frame_in_map);
            let mut ruled_out = 0;
            // Blocks of side 0 (single poses), 0.4 m and 3.2 m over a square around the
            // anchor, at headings 6° apart.
            for side_m in [0.0, 0.4, 3.2] {
                for i in -40..40 {
                    for j in -40..40 {
                        let min_in_map = [
                            anchor_in_map.x_m + 0.8 * f64::from(i) + 0.013,
                            anchor_in_map.y_m + 0.8 * f64::from(j) + 0.029,
                        ];
                        for k in 0..60 {
                            let heading_rad = (f64::from(k) * 6.0 + 0.7).to_radians();
                            // Poses spread over the block, in the map.
                            let poses_in_map: Vec<Pose2> = (0..=4)
                                .flat_map(|a| (0..=4).map(move |b| (a, b)))
                                .map(|(a, b)| {
                                    Pose2::new(
                                        min_in_map[0] + side_m * f64::from(a) / 4.0,
                                        min_in_map[1] + side_m * f64::from(b) / 4.0,
                                        heading_rad,
                                    )
                                })
                                .collect();
                            let held = poses_in_map.iter().any(|&pose| ring.holds(pose));
                            let corner = poses_in_map[0];
                            let may = ring.may_hold(
                                heading_rad,
                                min_in_map,
                                [min_in_map[0] + side_m, min_in_map[1] + side_m],
                            );
                            assert!(may || !held, "{radius_m} m, {side_m} m, {corner:?}");
                            if side_m == 0.0 {
                                assert_eq!(may, held, "{radius_m} m, {corner:?}");
                                // The same in the frame.
                                let in_frame_pose = frame_in_map.inverse() * corner;
                                let may_in_frame = in_frame.may_hold(
                                    in_frame_pose.theta_rad,
                                    [in_frame_pose.x_m, in_frame_pose.y_m],
                                    [in_frame_pose.x_m, in_frame_pose.y_m],
                                );
                                assert_eq!(may_in_frame, held, "{radius_m} m, {corner:?}");
                            }
                            ruled_out += usize::from(!may);
                        }
                    }
                }
            }
            // Most of the square and of the headings lies off the ring.
            assert!(
                ruled_out > 3 * 80 * 80 * 60 / 2,
                "{radius_m} m: {ruled_out}"
            );
        }
    }

    #[test]
    fn a_chain_of_earlier_scans_finds_a_scan_metres_from_where_it_is_believed() {
        let (mut slam, truth, last) = ring_but_the_last_scan();
        let earlier_len = truth.len() - 1;
        // Every scan turned enough to be a node.
        assert_eq!(slam.stats().nodes, earlier_len);
        // The last scan, back near the start, believed 3 m behind along the corridor.
        let node = earlier_len;
        let origin = truth[0].inverse();
        let believed = origin * truth[node] * Pose2::new(-3.0, 0.0, 0.0);
        let context = ChainContext {
            nodes: slam.graph.nodes(),
            nearest_earlier: slam.nearest_earlier_node(node, believed),
            poses_in_local: &slam.poses_in_local,
            scans: &slam.scans,
        };
        let mut searches = 0;
        let found = slam
            .chains
            .search(
                node,
                &slam.options.trusted_beams(&last),
                believed,
                &context,
                &mut searches,
            )
            .expect("found in the chain");
        let frame_in_map = slam
            .node_pose_in_map(found.submap_first_node)
            .expect("node");
        let error = (origin * truth[node]).inverse() * (frame_in_map * found.pose_in_submap);
        assert!(error.x_m.hypot(error.y_m) < 0.05, "{error:?}");
        assert!(error.theta_rad.abs() < 1f64.to_radians(), "{error:?}");
        assert!(found.information_in_robot.is_some());
    }

    #[test]
    fn a_drawn_chain_serves_the_next_search_until_the_graph_moves_its_scans() {
        let (slam, truth, last) = ring_but_the_last_scan();
        let node = truth.len() - 1;
        let believed = truth[0].inverse() * truth[node];
        let nearest = slam
            .nearest_earlier_node(node, believed)
            .expect("a node near the start");
        let mut options = slam.options.clone();
        options.chain_closure.reuse_within_m = 10.0;
        let mut chains = ChainCloser::new(&options).unwrap();
        let scan = slam.options.trusted_beams(&last);
        let mut nodes = slam.graph.nodes().to_vec();
        let mut search_from = |nearest_earlier: usize, nodes: &[crate::pose_graph::Node]| {
            let context = ChainContext {
                nodes,
                nearest_earlier: Some(nearest_earlier),
                poses_in_local: &slam.poses_in_local,
                scans: &slam.scans,
            };
            chains
                .search(node, &scan, believed, &context, &mut 0)
                .expect("found in the chain")
                .submap_first_node
        };
        assert_eq!(search_from(nearest, &nodes), nearest);
        // The next node, within reach of the chain drawn: found in that chain, in the frame
        // of its centre.
        assert_eq!(search_from(nearest + 1, &nodes), nearest);
        // One of its scans moved by a solve: drawn again around the nearest node.
        nodes[nearest].pose_in_map = nodes[nearest].pose_in_map * Pose2::new(0.01, 0.0, 0.0);
        assert_eq!(search_from(nearest + 1, &nodes), nearest + 1);
    }

    #[test]
    fn a_scan_far_beyond_the_usual_window_is_found_around_its_guess() {
        let (slam, truth, last) = ring_but_the_last_scan();
        let earlier_len = truth.len() - 1;
        // The last scan, back near the start, believed 6.3 m and 25° from where it is: in the
        // first submap, beyond the usual ±3 m and ±30°.
        let (submap, reference) = &slam.finished[0];
        let submap_in_map = slam.node_pose_in_map(submap.first_node()).expect("node");
        let truth_in_submap = submap_in_map.inverse() * truth[0].inverse() * truth[earlier_len];
        let guess = truth_in_submap * Pose2::new(-6.0, 2.0, 25f64.to_radians());
        let scan = slam.options.trusted_beams(&last);
        let error_of = |closure: &super::super::loop_closer::LoopClosure| {
            let error = truth_in_submap.inverse() * closure.pose_in_submap;
            (error.x_m.hypot(error.y_m), error.theta_rad.abs())
        };
        let usual = slam.closer.search(submap, reference, &scan, guess);
        assert!(
            usual.as_ref().is_none_or(|c| error_of(c).0 > 0.5),
            "{usual:?}"
        );
        let reference_scan = submap.reference_scan_from(|n| slam.scans.get(n));
        let found = slam
            .uncertain_closer
            .search_around_guess(submap, &reference_scan, &scan, guess)
            .expect("found around the guess");
        let (error_m, error_rad) = error_of(&found);
        assert!(error_m < 0.05, "{found:?}");
        assert!(error_rad < 1f64.to_radians(), "{found:?}");
    }

    #[test]
    fn a_search_far_from_a_very_uncertain_guess_goes_where_the_submap_was_seen() {
        let options = SlamOptions::default();
        let mut submap = SlamSubmap::new(Pose2::IDENTITY, 0, options.submap, options.point_map);
        let scan = cast_front_scan(&ring_walls(), Pose2::IDENTITY);
        for x_m in [0.0, 5.0, 10.0, 15.0, 20.0] {
            submap.insert(x_m as usize, &scan, Pose2::new(x_m, 0.0, 0.0));
        }
        let guess = Pose2::new(60.0, 3.0, 0.4);
        let sigma = |sigma_m: f64| {
            Matrix3::from_diagonal(&nalgebra::Vector3::new(
                sigma_m * sigma_m,
                sigma_m * sigma_m,
                0.01,
            ))
        };
        // 30 m uncertain: the nearest place the submap saw, 40 m away, is 1.3 σ off.
        let moved = most_likely_overlap(&submap, guess, &sigma(30.0), 16.0, 3.0);
        assert_eq!(moved, Pose2::new(20.0, 0.0, 0.4));
        // 5 m uncertain: 8 σ off, not where the robot can be.
        assert_eq!(
            most_likely_overlap(&submap, guess, &sigma(5.0), 16.0, 3.0),
            guess
        );
        // Within the window of the guess already: searched around the guess.
        let near = Pose2::new(30.0, 3.0, 0.4);
        assert_eq!(
            most_likely_overlap(&submap, near, &sigma(30.0), 16.0, 3.0),
            near
        );
    }

    #[test]
    fn odometry_is_used_when_given() {
        let walls = ring_walls();
        let truth = ring_trajectory(0.3);
        let mut slam = GraphSlam::new(SlamOptions::default()).unwrap();
        let scans: Vec<Scan> = truth
            .iter()
            .map(|&pose| cast_front_scan(&walls, pose))
            .collect();
        for (k, (scan, pose)) in scans.iter().zip(&truth).enumerate() {
            slam.add_scan(k as f64 * 0.1, scan, Some(*pose));
        }
        let result = slam.finish();
        let first = truth[0].inverse();
        let last = result.poses_in_map.last().copied().unwrap_or_default();
        let error = (first * truth[truth.len() - 1]).inverse() * last;
        assert!(error.x_m.hypot(error.y_m) < 0.03, "{error:?}");
    }
}
