//! Loop closure in a chain of earlier scans, for a scan no finished submap took.
//!
//! A long loop drifts further than the submaps' search window, and a stretch that local
//! tracking got wrong blurs a whole submap; so a scan the submaps did not take is searched
//! once more, over a wide window, in a chain of the earlier scans around the one nearest to
//! it, drawn at the poses the graph holds now ([`super::ChainClosureOptions`]). A closure
//! enters the graph once a second one agrees ([`ClosureConfirmation`]); while one waits,
//! every scan is searched. A chain drawn for one search serves the next ones while the
//! nearest scan stays near its centre and the graph holds its scans where they were
//! ([`ChainClosureOptions::reuse_within_m`](super::ChainClosureOptions::reuse_within_m)).

use super::closure_confirmation::{ClosureConfirmation, FoundClosure};
use super::loop_closer::{AlignedCandidate, LoopCloser, LoopClosure};
use super::options::SlamOptions;
use super::slam_submap::SlamSubmap;
use crate::geometry::Pose2;
use crate::grid::{LazyGrid, SubmapOptions};
use crate::pose_graph::Node;
use crate::scan_match::{PreparedReference, Scan, ScanMatchError};

/// What the graph holds now, for a chain search.
#[derive(Debug, Clone, Copy)]
pub(super) struct ChainContext<'a> {
    /// Every node as the graph holds it.
    pub nodes: &'a [Node],
    /// The earlier node nearest to the scan, within the search's `max_distance_m` and at
    /// least its `min_scans_apart` before it, if any ([`super::node_index`]).
    pub nearest_earlier: Option<usize>,
    /// Every scan's pose in the local tracking frame.
    pub poses_in_local: &'a [Pose2],
    /// Every scan added (trusted beams).
    pub scans: &'a [Scan],
}

/// Searches chains of earlier scans. See the [module documentation](self).
#[derive(Debug)]
pub(super) struct ChainCloser {
    options: SlamOptions,
    closer: LoopCloser,
    confirmation: ClosureConfirmation,
    /// The last node searched in a chain because a chain closure waits for confirmation.
    pending_until: usize,
    /// The chain searched last, kept while the graph holds its scans where they were.
    last_chain: Option<DrawnChain>,
}

/// A chain of earlier scans drawn into a submap, with its matcher reference.
///
/// Its occupancy is worked out only when a match in it reaches the acceptance test, and only
/// at the cells the test reads ([`LazyGrid`]): most searches end before, and ray casting tens
/// of scans into a grid is the dearest part of drawing a chain.
#[derive(Debug)]
struct DrawnChain {
    /// The node the chain is centred on, in whose frame it is drawn.
    centre: usize,
    /// The first node of the chain.
    first: usize,
    /// The poses of the chain's nodes, `first` on, in the map when it was drawn.
    poses_in_map: Vec<Pose2>,
    /// The chain's end points; its grid too where it cannot stay undrawn (the submap is then
    /// finished).
    submap: SlamSubmap,
    reference: PreparedReference,
    /// The chain's occupancy, once a match needed it, where it can be worked out cell by cell.
    occupancy: Option<LazyGrid>,
}

impl DrawnChain {
    /// The chain's nodes.
    fn nodes(&self) -> std::ops::Range<usize> {
        self.first..self.first + self.poses_in_map.len()
    }

    /// The pose of the chain's centre, its frame, in the map when it was drawn.
    fn centre_in_map(&self) -> Pose2 {
        self.poses_in_map[self.centre - self.first]
    }

    /// Whether the graph still holds every node of the chain where it was drawn.
    fn is_current(&self, nodes: &[Node]) -> bool {
        nodes.get(self.nodes()).is_some_and(|nodes| {
            nodes
                .iter()
                .zip(&self.poses_in_map)
                .all(|(node, &pose)| node.pose_in_map == pose)
        })
    }

    /// Readies the chain's occupancy for the acceptance test, once, from `scans`, the scans of
    /// its nodes. A [`LazyGrid`] where one gives the drawn grid's values; otherwise the grid
    /// is drawn.
    fn ready_occupancy(&mut self, options: SubmapOptions, scans: &[Scan]) {
        if self.occupancy.is_some() || self.submap.is_finished() {
            return;
        }
        let poses_in_map = &self.poses_in_map;
        let scans_at_poses = || scans.iter().zip(poses_in_map.iter().copied());
        self.occupancy = LazyGrid::new(options, self.submap.pose_in_local(), scans_at_poses());
        if self.occupancy.is_some() {
            return;
        }
        self.submap.reserve_for(scans_at_poses());
        for (scan, pose) in scans_at_poses() {
            self.submap.insert_into_grid(scan, pose);
        }
        self.submap.finish();
    }

    /// The acceptance test of `candidate` in the chain, by `closer`.
    fn accept(&self, closer: &LoopCloser, candidate: &AlignedCandidate) -> Option<LoopClosure> {
        match &self.occupancy {
            Some(occupancy) => closer.accept_on(&self.submap, occupancy, candidate),
            None => closer.accept(&self.submap, candidate),
        }
    }
}

impl ChainCloser {
    /// A chain closer with the SLAM's `options`.
    pub(super) fn new(options: &SlamOptions) -> Result<Self, ScanMatchError> {
        Ok(ChainCloser {
            closer: LoopCloser::new(options.chain_closure.search.clone())?,
            confirmation: ClosureConfirmation::new(options.chain_closure.search.confirmation),
            pending_until: 0,
            last_chain: None,
            options: options.clone(),
        })
    }

    /// Chain closures rejected: no second one agreed with them (those still waiting counted).
    pub(super) fn rejected(&self) -> usize {
        self.confirmation.rejected_at_end()
    }

    /// Whether a chain closure found before `node` still waits for its confirmation.
    pub(super) fn awaits_confirmation(&self, node: usize) -> bool {
        node <= self.pending_until
    }

    /// Searches the scan of `node`, believed at `pose_in_map`, and returns the closures
    /// confirmed by it (counting the search in `searches`).
    pub(super) fn close(
        &mut self,
        node: usize,
        scan: &Scan,
        pose_in_map: Pose2,
        context: &ChainContext<'_>,
        searches: &mut usize,
    ) -> Vec<FoundClosure> {
        let Some(found) = self.search(node, scan, pose_in_map, context, searches) else {
            return Vec::new();
        };
        let confirmed = self.confirmation.offer(found, context.poses_in_local);
        if confirmed.is_empty() {
            let window = self.options.chain_closure.search.confirmation.window_scans;
            self.pending_until = node + window;
        }
        confirmed
    }

    /// Searches the scan of `node`, believed at `pose_in_map`, in the chain of earlier scans
    /// around the one nearest to it ([`ChainClosureOptions`](super::ChainClosureOptions)),
    /// drawn at the poses the graph holds now. The closure is in the frame of that nearest
    /// scan.
    pub(super) fn search(
        &mut self,
        node: usize,
        scan: &Scan,
        pose_in_map: Pose2,
        context: &ChainContext<'_>,
        searches: &mut usize,
    ) -> Option<FoundClosure> {
        let chain = &self.options.chain_closure;
        let last_chained = node.checked_sub(chain.search.min_scans_apart)?;
        let nearest = context
            .nearest_earlier
            .filter(|&n| n <= last_chained && n < context.scans.len())?;
        // The chain drawn last serves while it covers the nearest scan and the graph holds its
        // scans where they were: drawn again, it would come out the same.
        let serves = self.last_chain.as_ref().is_some_and(|drawn| {
            context.nodes.get(nearest).is_some_and(|nearest| {
                let offset = drawn.centre_in_map().inverse() * nearest.pose_in_map;
                offset.x_m.hypot(offset.y_m) <= chain.reuse_within_m
            }) && drawn.is_current(context.nodes)
        });
        if !serves {
            let centre = nearest;
            let first = centre.saturating_sub(chain.half_length_scans);
            let last = (centre + chain.half_length_scans)
                .min(last_chained)
                .min(context.scans.len() - 1);
            let poses_in_map: Vec<Pose2> = context
                .nodes
                .get(first..=last)?
                .iter()
                .map(|n| n.pose_in_map)
                .collect();
            // The occupancy waits until a match needs it (`DrawnChain::ready_occupancy`).
            let mut submap = SlamSubmap::new(
                poses_in_map[centre - first],
                centre,
                self.options.submap,
                self.options.point_map,
            );
            for (chained, (scan, &pose)) in context.scans[first..=last]
                .iter()
                .zip(&poses_in_map)
                .enumerate()
            {
                submap.insert_points(first + chained, scan, pose);
            }
            let reference = self
                .closer
                .prepare(&submap.reference_scan().unwrap_or_default());
            self.last_chain = Some(DrawnChain {
                centre,
                first,
                poses_in_map,
                submap,
                reference,
                occupancy: None,
            });
        }
        let drawn = self.last_chain.as_mut()?;
        *searches += 1;
        let guess = drawn.centre_in_map().inverse() * pose_in_map;
        let candidate = self
            .closer
            .align(&drawn.submap, &drawn.reference, scan, guess)?;
        let chained = drawn.nodes();
        drawn.ready_occupancy(self.options.submap, &context.scans[chained]);
        let closure = drawn.accept(&self.closer, &candidate)?;
        Some(FoundClosure {
            submap_first_node: drawn.centre,
            node,
            pose_in_submap: closure.pose_in_submap,
            information_in_robot: Some(closure.information_in_robot),
        })
    }
}
