//! Settled places: finished submaps that later passes agree with become the map's fixed
//! reference, so that the work of a scan follows the place, not the time spent in it.
//!
//! Every pass through a place adds nodes, a submap and loop closures to the pose graph. With
//! every node free, the solves, the relative covariances that choose where to search
//! ([`relative_covariances`](crate::pose_graph::relative_covariances)) and the final
//! refinement all grow with the time the robot has spent, lap after lap of the same rooms.
//! Yet once a later pass has closed on a submap and the graph agrees with those closures,
//! more closures there confirm what the graph holds rather than move it.
//!
//! A finished submap is **settled** once at least
//! [`SettleOptions::min_agreeing_closures`] loop closures from later scans (on the submap,
//! or on a chain of scans around one of its nodes) agree with the graph: the graph holds
//! each within its own covariance, its χ² at the graph's poses within the bound below which
//! a new closure does not call for a solve
//! ([`SlamOptions::solve_above_chi2`](super::SlamOptions::solve_above_chi2)), and each
//! measures every direction of translation (it is not left loose along a corridor,
//! [`super::degeneracy`]: where along the corridor the place lies is what a later loop may
//! still correct). A node whose
//! submaps have all settled is fixed where the graph holds it. Fixed nodes stay in the
//! graph: loop closure searches their submaps as before, and a closure on them pins the free
//! scans of the pass under way. During the run the solver works on the free nodes only, and
//! the relative covariances walk the free part and treat the fixed nodes as one rigid
//! reference. At the end of the run every node is released for the last solve, so that what
//! later passes told about a settled place still moves it. A node's final refinement
//! ([`super::final_refinement`]) is made when it is fixed, and its constraints wait for that
//! solve.
//!
//! A loop that closes for the first time is solved with every node of it free: its submaps
//! settle only after the solve that made the graph agree with their closures. During the run,
//! the error of a later loop goes into the scans of the passes that have not settled, which
//! is where it arose. This is how Cartographer's localisation against a finished map treats
//! the map (its submaps stay fixed while new scans are placed against them), applied here
//! place by place as places settle, and undone for the map's last solve.

use std::collections::HashMap;
use std::ops::RangeInclusive;

use super::degeneracy::weak_translation;
use crate::pose_graph::{EdgeId, NodeId, PoseGraph};

/// When a finished submap is settled. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct SettleOptions {
    /// Whether submaps settle at all (off: every node stays free during the run).
    pub enabled: bool,
    /// Loop closures from later scans that must agree with the graph before a submap
    /// settles (at least one).
    pub min_agreeing_closures: usize,
}

impl Default for SettleOptions {
    fn default() -> Self {
        SettleOptions {
            enabled: true,
            min_agreeing_closures: 2,
        }
    }
}

/// Which finished submaps have settled, and which nodes may be fixed for it.
#[derive(Debug, Default)]
pub(crate) struct SettledSubmaps {
    options: SettleOptions,
    /// For every finished submap (in the order they finished): its nodes.
    nodes: Vec<RangeInclusive<usize>>,
    /// For every finished submap: the loop closures on it.
    closures: Vec<Vec<EdgeId>>,
    /// For every finished submap: whether it settled.
    settled: Vec<bool>,
    /// Finished submaps that received a closure since the last [`Self::settle`].
    with_new_closures: Vec<usize>,
    /// Finished submaps by their first node.
    by_first_node: HashMap<usize, usize>,
    /// For every node: how many finished submaps it went into are not settled.
    unsettled_cover: Vec<u32>,
}

impl SettledSubmaps {
    pub(crate) fn new(options: SettleOptions) -> Self {
        SettledSubmaps {
            options,
            ..SettledSubmaps::default()
        }
    }

    /// A submap holding `nodes` has finished.
    pub(crate) fn finished(&mut self, nodes: RangeInclusive<usize>) {
        let index = self.nodes.len();
        if self.unsettled_cover.len() <= *nodes.end() {
            self.unsettled_cover.resize(nodes.end() + 1, 0);
        }
        for node in nodes.clone() {
            self.unsettled_cover[node] += 1;
        }
        self.by_first_node.insert(*nodes.start(), index);
        self.nodes.push(nodes);
        self.closures.push(Vec::new());
        self.settled.push(false);
    }

    /// A loop closure `edge` from the frame of the submap whose first node is
    /// `submap_first_node` entered the graph (a frame that is no finished submap's is not
    /// counted).
    pub(crate) fn closure_on_submap(&mut self, submap_first_node: usize, edge: EdgeId) {
        if let Some(&index) = self.by_first_node.get(&submap_first_node) {
            self.credit(index, edge);
        }
    }

    /// A loop closure `edge` from the frame of a chain of earlier scans around `node`
    /// entered the graph: it closes on the finished submaps that hold `node`.
    pub(crate) fn closure_on_node(&mut self, node: usize, edge: EdgeId) {
        // Submaps finish in the order they start, and at most a few hold one node.
        let after = self.nodes.partition_point(|nodes| *nodes.start() <= node);
        for index in after.saturating_sub(3)..after {
            if self.nodes[index].contains(&node) {
                self.credit(index, edge);
            }
        }
    }

    fn credit(&mut self, index: usize, edge: EdgeId) {
        self.closures[index].push(edge);
        self.with_new_closures.push(index);
    }

    /// Settles the submaps whose closures now agree with the graph (a closure agrees when its
    /// χ² at the graph's poses is at most `agree_below_chi2`, and it measures every direction
    /// of translation: the weaker holds at least `min_information_ratio` of the information
    /// of the stronger), and returns the nodes all of
    /// whose submaps have now settled, to be fixed: every node before `first_active_node`
    /// (from there on nodes still go into a submap under way, and are returned when that one
    /// settles in turn). Only the submaps that received closures since the last call are
    /// tested, unless `graph_moved` (the graph was solved since).
    pub(crate) fn settle(
        &mut self,
        graph: &PoseGraph,
        agree_below_chi2: f64,
        min_information_ratio: f64,
        first_active_node: usize,
        graph_moved: bool,
    ) -> Vec<usize> {
        let mut tested = std::mem::take(&mut self.with_new_closures);
        if !self.options.enabled {
            return Vec::new();
        }
        if graph_moved {
            tested = (0..self.settled.len()).collect();
        }
        tested.sort_unstable();
        tested.dedup();
        let agrees = |edge: &EdgeId| {
            let well_conditioned = graph.edges().get(edge.0).is_some_and(|edge| {
                weak_translation(&edge.information, min_information_ratio).is_none()
            });
            well_conditioned
                && graph
                    .edge_chi2(*edge)
                    .is_some_and(|chi2| chi2 <= agree_below_chi2)
        };
        let needed = self.options.min_agreeing_closures.max(1);
        let settling: Vec<usize> = tested
            .into_iter()
            .filter(|&index| !self.settled[index])
            .filter(|&index| self.closures[index].iter().filter(|e| agrees(e)).count() >= needed)
            .collect();
        let mut ready = Vec::new();
        for index in settling {
            self.settled[index] = true;
            for node in self.nodes[index].clone() {
                self.unsettled_cover[node] -= 1;
                if self.unsettled_cover[node] == 0
                    && node < first_active_node
                    && graph.node(NodeId(node)).is_some_and(|n| !n.fixed)
                {
                    ready.push(node);
                }
            }
        }
        ready.sort_unstable();
        ready
    }

    /// Finished submaps settled.
    pub(crate) fn settled_submaps(&self) -> usize {
        self.settled.iter().filter(|&&settled| settled).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;
    use crate::pose_graph::Edge;

    use crate::pose_graph::RobustKernel;

    const KERNEL: RobustKernel = RobustKernel::Dcs { phi: 10.0 };
    /// The default bound of [`super::super::SlamOptions::solve_above_chi2`].
    const AGREE_BELOW_CHI2: f64 = 7.81;

    /// Ten nodes 1 m apart along x, chained.
    fn chain() -> PoseGraph {
        let mut graph = PoseGraph::new();
        let information = Edge::information_from_std_devs(0.05, 0.05, 0.01);
        for node in 0..10 {
            graph
                .add_node(Pose2::new(f64::from(node), 0.0, 0.0))
                .expect("node");
            if node > 0 {
                let step = Edge::new(
                    NodeId(node as usize - 1),
                    NodeId(node as usize),
                    Pose2::new(1.0, 0.0, 0.0),
                    information,
                );
                graph.add_edge(step).expect("edge");
            }
        }
        graph
    }

    /// A closure from `from` to node 9, off by `error_m` along x.
    fn closure(graph: &mut PoseGraph, from: usize, error_m: f64) -> EdgeId {
        let measured = Pose2::new(9.0 - from as f64 + error_m, 0.0, 0.0);
        let information = Edge::information_from_std_devs(0.03, 0.03, 0.01);
        let edge = Edge::new(NodeId(from), NodeId(9), measured, information).with_kernel(KERNEL);
        graph.add_edge(edge).expect("edge")
    }

    #[test]
    fn a_node_settles_once_every_submap_it_went_into_has_and_none_under_way_holds_it() {
        let mut graph = chain();
        let mut settled = SettledSubmaps::new(SettleOptions::default());
        // Two overlapping submaps; a third, under way, holds the nodes from 6 on.
        settled.finished(0..=5);
        settled.finished(3..=8);
        let first_active_node = 6;
        assert!(
            settled
                .settle(&graph, AGREE_BELOW_CHI2, 0.03, first_active_node, false)
                .is_empty()
        );

        // One agreeing closure on the first submap is not enough; a disagreeing one (1 m off
        // against 3 cm) does not count.
        let agreeing = closure(&mut graph, 0, 0.0);
        settled.closure_on_submap(0, agreeing);
        let disagreeing = closure(&mut graph, 0, 1.0);
        settled.closure_on_submap(0, disagreeing);
        assert!(
            settled
                .settle(&graph, AGREE_BELOW_CHI2, 0.03, first_active_node, false)
                .is_empty()
        );
        assert_eq!(settled.settled_submaps(), 0);

        // A second agreeing one settles it: its nodes that no other submap holds are ready
        // (but node 0, the graph's anchor, fixed from the start).
        let second = closure(&mut graph, 0, 0.01);
        settled.closure_on_submap(0, second);
        assert_eq!(
            settled.settle(&graph, AGREE_BELOW_CHI2, 0.03, first_active_node, false),
            vec![1, 2]
        );
        assert_eq!(settled.settled_submaps(), 1);

        // A frame that is no finished submap's is not counted as one.
        let elsewhere = closure(&mut graph, 4, 0.0);
        settled.closure_on_submap(4, elsewhere);
        assert!(
            settled
                .settle(&graph, AGREE_BELOW_CHI2, 0.03, first_active_node, false)
                .is_empty()
        );
        // A closure on a chain around node 4 closes on the second submap, which holds it.
        settled.closure_on_node(4, elsewhere);

        // The second submap settles: its nodes before the one under way are ready, each once.
        let edge = closure(&mut graph, 3, 0.02);
        settled.closure_on_submap(3, edge);
        assert_eq!(
            settled.settle(&graph, AGREE_BELOW_CHI2, 0.03, first_active_node, false),
            vec![3, 4, 5]
        );
        assert!(
            settled
                .settle(&graph, AGREE_BELOW_CHI2, 0.03, first_active_node, true)
                .is_empty()
        );
        assert_eq!(settled.settled_submaps(), 2);
    }

    #[test]
    fn nothing_settles_when_disabled() {
        let mut graph = chain();
        let options = SettleOptions {
            enabled: false,
            ..SettleOptions::default()
        };
        let mut settled = SettledSubmaps::new(options);
        settled.finished(0..=5);
        for _ in 0..3 {
            let edge = closure(&mut graph, 0, 0.0);
            settled.closure_on_submap(0, edge);
        }
        assert!(
            settled
                .settle(&graph, AGREE_BELOW_CHI2, 0.03, 9, true)
                .is_empty()
        );
    }
}
