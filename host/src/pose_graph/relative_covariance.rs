//! How uncertain one node's pose is relative to every other node: the covariance of the
//! relative pose compounded along the most certain path of edges between them.
//!
//! This is the "Dijkstra projection" of Bosse et al. 2004 ("Simultaneous localization and
//! map building in large-scale cyclic environments using the Atlas framework"), also used by
//! Olson's loop-closure gating: from the source node, the graph is explored in order of
//! growing uncertainty, and each node receives the covariance of the chain of edges that
//! reached it first, compounded to first order at the poses the graph holds now. A path
//! through a loop closure is as short as the closure is certain, so after a loop is closed the
//! nodes on its far side are close again; a stretch of scans tracking could not place (whose
//! edges carry the motion prior's wide uncertainty) makes everything beyond it uncertain.
//! It is an upper bound of the true marginal (it ignores that parallel paths reinforce each
//! other) at the cost of one pass over the graph, without any factorisation.
//!
//! Perturbations are on the right, as in [`Edge::error`](super::Edge::error): a relative pose
//! `T` is `T̄ · exp(δ)` with `δ = (x, y, theta)` in the frame of the pose it measures, so
//! every covariance returned is of the source's pose, in the source's own frame.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap, HashSet};

use foldhash::fast::FixedState;

use nalgebra::Matrix3;

use super::graph::PoseGraph;
use super::node::NodeId;
use crate::geometry::Pose2;

/// For every node `a` of `graph`, the covariance (x, y, theta in the source's frame; m², rad²)
/// of the pose of `source` relative to `a` (`a_from_source`), compounded along the most certain
/// path, read with [`RelativeCovariances::get`]: `None` for nodes no edge path reaches (and
/// for every node when `source` is not in the graph). A robust edge counts with its
/// information scaled by its kernel's weight at the current poses, so a constraint the
/// optimisation switched off does not make a shortcut. The graph is explored from `source` in
/// order of growing positional variance, and each node keeps the covariance of the path that
/// reached it first (Bosse et al. 2004's "Dijkstra projection"): an upper bound of the true
/// marginal, found without a factorisation.
///
/// Fixed nodes are the map's reference: they hold one another rigidly, so every fixed node
/// receives the covariance of the first one reached, and the walk leaves them through any of
/// their edges as from one node. The walk (the priority queue, the covariances it compounds
/// and the edges it follows) covers the free part only: in a graph whose settled part is
/// fixed, it costs what the free part holds however large the graph.
pub fn relative_covariances(graph: &PoseGraph, source: NodeId) -> RelativeCovariances {
    Walk::new(graph, source, None)
        .map(|walk| RelativeCovariances {
            covariances: walk.covariances,
            fixed_covariance: walk.fixed_covariance,
        })
        .unwrap_or_default()
}

/// What [`relative_covariances`] found from one source node.
#[derive(Debug, Clone, Default)]
pub struct RelativeCovariances {
    /// The free nodes' (and those fixed nodes' reached before the first was settled).
    covariances: HashMap<usize, Matrix3<f64>, FixedState>,
    /// Every fixed node's, once one was reached.
    fixed_covariance: Option<Matrix3<f64>>,
}

impl RelativeCovariances {
    /// The covariance of the source's pose relative to `node` of `graph` (the graph the walk
    /// ran on, unchanged since); `None` when no edge path reaches it or it is not in the graph.
    pub fn get(&self, graph: &PoseGraph, node: NodeId) -> Option<Matrix3<f64>> {
        if graph.node(node)?.fixed {
            self.fixed_covariance
        } else {
            self.covariances.get(&node.0).copied()
        }
    }
}

/// The covariance of the pose of `source` relative to `target` alone: what
/// [`relative_covariances`] gives for `target`, to the same bits. The walk stops once it
/// reaches `target`, so it walks only the nodes more certain than it: for a target near the
/// source, a few, however large the graph.
pub fn relative_covariance(
    graph: &PoseGraph,
    source: NodeId,
    target: NodeId,
) -> Option<Matrix3<f64>> {
    let walk = Walk::new(graph, source, Some(target.0))?;
    if graph.node(target)?.fixed {
        walk.fixed_covariance
    } else {
        walk.covariances.get(&target.0).copied()
    }
}

/// What a walk of the Dijkstra projection found: the covariance of every node it reached
/// (the fixed ones as one, apart).
struct Walk {
    covariances: HashMap<usize, Matrix3<f64>, FixedState>,
    /// The fixed nodes', once the first of them was settled: they hold one another rigidly.
    fixed_covariance: Option<Matrix3<f64>>,
}

impl Walk {
    /// Walks from `source` until every node it reaches is settled, or `until` is; `None` when
    /// `source` is not in the graph.
    fn new(graph: &PoseGraph, source: NodeId, until: Option<usize>) -> Option<Walk> {
        let nodes = graph.nodes();
        let source_in_map = nodes.get(source.0)?.pose_in_map;
        let adjacency = graph.adjacency();
        let mut leaving: Vec<(usize, usize, usize)> = Vec::new();
        let mut settled: HashSet<usize, FixedState> = HashSet::default();
        let mut walk = Walk {
            covariances: HashMap::from_iter([(source.0, Matrix3::zeros())]),
            fixed_covariance: None,
        };
        let until_fixed = until.is_some_and(|node| nodes.get(node).is_some_and(|n| n.fixed));
        // Keyed by the positional variance (trace of the translation block): non-negative
        // floats order as their bit patterns do.
        let mut queue = BinaryHeap::new();
        queue.push(Reverse((0u64, source.0)));
        while let Some(Reverse((_, b))) = queue.pop() {
            if !settled.insert(b) {
                continue;
            }
            let Some(&b_covariance) = walk.covariances.get(&b) else {
                continue;
            };
            // Edges leave the fixed nodes together, each from its own end, as from one node.
            leaving.clear();
            if nodes[b].fixed {
                if walk.fixed_covariance.is_some() {
                    continue;
                }
                walk.fixed_covariance = Some(b_covariance);
                if until_fixed {
                    break;
                }
                leaving.extend(adjacency.edges_leaving_fixed(nodes));
            } else {
                if until == Some(b) {
                    break;
                }
                leaving.extend(
                    adjacency
                        .edges_of(b)
                        .iter()
                        .map(|&(a, index)| (b, a, index)),
                );
            }
            for &(end, a, index) in &leaving {
                // Once the fixed nodes are reached, all of them are.
                if settled.contains(&a) || (nodes[a].fixed && walk.fixed_covariance.is_some()) {
                    continue;
                }
                let b_in_map = nodes[end].pose_in_map;
                // Moves a perturbation of `a_from_b` into the source's frame: Ad(source_from_b).
                let into_source = adjoint(source_in_map.inverse() * b_in_map);
                let edge = &graph.edges()[index];
                let a_in_map = nodes[a].pose_in_map;
                let Some(edge_covariance) = edge_covariance(graph, index) else {
                    continue;
                };
                // The edge measures `to` in `from`; seen from `a` it is `a_from_b`.
                let a_from_b_covariance = if edge.from.0 == a {
                    edge_covariance
                } else {
                    let b_from_a = b_in_map.inverse() * a_in_map;
                    let flip = adjoint(b_from_a);
                    flip * edge_covariance * flip.transpose()
                };
                let candidate =
                    into_source * a_from_b_covariance * into_source.transpose() + b_covariance;
                let key = positional_variance(&candidate);
                let known = walk.covariances.get(&a);
                if known.is_none_or(|known| key < positional_variance(known)) {
                    walk.covariances.insert(a, candidate);
                    queue.push(Reverse((key.to_bits(), a)));
                }
            }
        }
        Some(walk)
    }
}

/// The positional variance of a pose covariance: the trace of its translation block, m².
fn positional_variance(covariance: &Matrix3<f64>) -> f64 {
    (covariance[(0, 0)] + covariance[(1, 1)]).max(0.0)
}

/// The covariance of edge `index`'s measurement, its information scaled by its kernel's
/// weight at the current poses; `None` when it cannot be inverted or the kernel switched the
/// edge off entirely.
fn edge_covariance(graph: &PoseGraph, index: usize) -> Option<Matrix3<f64>> {
    let edge = &graph.edges()[index];
    let weight = match edge.kernel {
        Some(kernel) => kernel.weight(graph.edge_chi2(super::EdgeId(index))?),
        None => 1.0,
    };
    if weight <= 0.0 || !weight.is_finite() {
        return None;
    }
    (edge.information * weight).try_inverse()
}

/// The adjoint of `pose` on SE(2) in `(x, y, theta)` order: `pose · exp(δ) · pose⁻¹ =
/// exp(Ad · δ)`, which moves a right perturbation of a frame into the frame `pose` is given
/// in.
fn adjoint(pose: Pose2) -> Matrix3<f64> {
    let (sin, cos) = pose.theta_rad.sin_cos();
    Matrix3::new(
        cos, -sin, pose.y_m, //
        sin, cos, -pose.x_m, //
        0.0, 0.0, 1.0,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose_graph::{Edge, RobustKernel};

    /// What [`relative_covariances`] gives for every node of `graph`, in node order.
    fn every_node(graph: &PoseGraph, source: NodeId) -> Vec<Option<Matrix3<f64>>> {
        let found = relative_covariances(graph, source);
        (0..graph.nodes().len())
            .map(|node| found.get(graph, NodeId(node)))
            .collect()
    }

    fn chain(steps: &[Pose2], sigmas: [f64; 3]) -> PoseGraph {
        let mut graph = PoseGraph::new();
        let mut pose = Pose2::IDENTITY;
        let _ = graph.add_node(pose);
        for (i, step) in steps.iter().enumerate() {
            pose = pose * *step;
            let _ = graph.add_node(pose);
            let information = Edge::information_from_std_devs(sigmas[0], sigmas[1], sigmas[2]);
            let edge = Edge::new(NodeId(i), NodeId(i + 1), *step, information);
            assert!(graph.add_edge(edge).is_ok());
        }
        graph
    }

    #[test]
    fn a_straight_chain_grows_sideways_with_the_heading_uncertainty() {
        // Ten 1 m steps, each uncertain by 0.01 m and 0.01 rad.
        let steps = vec![Pose2::new(1.0, 0.0, 0.0); 10];
        let (sigma_m, sigma_rad) = (0.01, 0.01);
        let graph = chain(&steps, [sigma_m, sigma_m, sigma_rad]);
        let covariances = every_node(&graph, NodeId(10));
        let last = covariances[0].expect("reached");
        // Seen from node 0, the last node's heading gathers all ten rotations; its lateral
        // position every rotation times the distance still to go after the node it turns
        // (9 m for the first step's, 0 m for the last's).
        let lateral: f64 =
            (0..10).map(|k| (k as f64 * sigma_rad).powi(2)).sum::<f64>() + 10.0 * sigma_m * sigma_m;
        assert!((last[(2, 2)] - 10.0 * sigma_rad * sigma_rad).abs() < 1e-12);
        assert!((last[(0, 0)] - 10.0 * sigma_m * sigma_m).abs() < 1e-12);
        assert!((last[(1, 1)] - lateral).abs() < 1e-9, "{last}");
        assert!(covariances[10].is_some_and(|c| c.amax() == 0.0));
    }

    #[test]
    fn walking_the_chain_backwards_gives_the_inverse_pose_covariance() {
        let steps = [
            Pose2::new(1.0, 0.2, 0.3),
            Pose2::new(0.5, -0.4, -0.8),
            Pose2::new(2.0, 0.1, 1.2),
        ];
        let graph = chain(&steps, [0.05, 0.02, 0.03]);
        // Node 3 seen from node 0, and node 0 seen from node 3: the same uncertainty, moved
        // through the inverse.
        let forward = every_node(&graph, NodeId(3))[0].expect("reached");
        let backward = every_node(&graph, NodeId(0))[3].expect("reached");
        let zero_from_three = graph.nodes()[0].pose_in_map.inverse() * graph.nodes()[3].pose_in_map;
        let flip = adjoint(zero_from_three);
        let moved = flip * forward * flip.transpose();
        assert!((moved - backward).amax() < 1e-12, "{moved} vs {backward}");
    }

    #[test]
    fn a_certain_loop_closure_is_a_shortcut_and_a_switched_off_one_is_not() {
        // A square loop of 40 steps; the last node closes on the first.
        let mut steps = Vec::new();
        for _ in 0..4 {
            steps.extend(std::iter::repeat_n(Pose2::new(1.0, 0.0, 0.0), 9));
            steps.push(Pose2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2));
        }
        let mut graph = chain(&steps, [0.05, 0.05, 0.02]);
        let far = every_node(&graph, NodeId(40))[1].expect("reached");
        let first_to_last = graph.nodes()[0].pose_in_map.inverse() * graph.nodes()[40].pose_in_map;
        let information = Edge::information_from_std_devs(0.05, 0.05, 0.02);
        let closure = Edge::new(NodeId(0), NodeId(40), first_to_last, information)
            .with_kernel(RobustKernel::Dcs { phi: 1.0 });
        let closure_id = graph.add_edge(closure).expect("valid edge");
        let near = every_node(&graph, NodeId(40))[1].expect("reached");
        assert!(positional_variance(&near) < 0.1 * positional_variance(&far));

        // The same closure, badly wrong at the current poses: its kernel all but drops it.
        let mut wrong = closure;
        wrong.to_in_from = first_to_last * Pose2::new(5.0, 5.0, 1.0);
        let mut disputed = chain(&steps, [0.05, 0.05, 0.02]);
        assert_eq!(disputed.add_edge(wrong).ok(), Some(closure_id));
        let ignored = every_node(&disputed, NodeId(40))[1].expect("reached");
        assert!(positional_variance(&ignored) > 0.9 * positional_variance(&far));
    }

    #[test]
    fn fixed_nodes_are_one_rigid_reference() {
        let steps = vec![Pose2::new(1.0, 0.0, 0.1); 10];
        let mut graph = chain(&steps, [0.05, 0.05, 0.02]);
        let free = every_node(&graph, NodeId(10));
        for node in 0..=5 {
            graph.set_fixed(NodeId(node), true).expect("node");
        }
        let fixed = every_node(&graph, NodeId(10));
        // Beyond the first fixed node reached (5) nothing adds: the fixed nodes do not move
        // relative to one another.
        assert!(fixed[..=5].iter().all(|&covariance| covariance == free[5]));
        assert_eq!(fixed[6..], free[6..]);
        // From inside the fixed part, every fixed node is certain and the free ones are as
        // far as their chain from node 5.
        let inside = every_node(&graph, NodeId(2));
        assert!(
            inside[..=5]
                .iter()
                .all(|c| c.is_some_and(|c| c.amax() == 0.0))
        );
        let from_five = {
            let mut unfixed = chain(&steps, [0.05, 0.05, 0.02]);
            unfixed.set_fixed(NodeId(0), false).expect("node");
            every_node(&unfixed, NodeId(5))
        };
        // The same chain seen from node 5, moved into node 2's frame.
        let two_from_five = graph.nodes()[2].pose_in_map.inverse() * graph.nodes()[5].pose_in_map;
        let flip = adjoint(two_from_five);
        for node in 6..=10 {
            let moved = flip * from_five[node].expect("reached") * flip.transpose();
            assert!((moved - inside[node].expect("reached")).amax() < 1e-12);
        }
    }

    #[test]
    fn one_target_gets_the_bits_of_the_whole_walk() {
        // A turning chain with a loop closure back to its start, nodes 3 to 6 fixed, and a
        // node no edge reaches.
        let steps = vec![Pose2::new(1.0, 0.0, 0.3); 14];
        let mut graph = chain(&steps, [0.05, 0.03, 0.02]);
        let closure = Edge::new(
            NodeId(0),
            NodeId(14),
            graph.nodes()[0].pose_in_map.inverse() * graph.nodes()[14].pose_in_map,
            Edge::information_from_std_devs(0.02, 0.02, 0.01),
        );
        assert!(graph.add_edge(closure).is_ok());
        let _ = graph.add_node(Pose2::new(50.0, 0.0, 0.0));
        for node in 3..=6 {
            graph.set_fixed(NodeId(node), true).expect("node");
        }
        for source in [0, 4, 9, 14, 15] {
            let every = every_node(&graph, NodeId(source));
            for (target, covariance) in every.iter().enumerate() {
                assert_eq!(
                    relative_covariance(&graph, NodeId(source), NodeId(target)),
                    *covariance,
                    "from {source} to {target}"
                );
            }
        }
        assert_eq!(relative_covariance(&graph, NodeId(0), NodeId(99)), None);
    }

    #[test]
    fn unreached_nodes_and_an_unknown_source_have_none() {
        let mut graph = chain(&[Pose2::new(1.0, 0.0, 0.0)], [0.1, 0.1, 0.1]);
        let _ = graph.add_node(Pose2::new(5.0, 0.0, 0.0));
        let covariances = every_node(&graph, NodeId(0));
        assert!(covariances[1].is_some() && covariances[2].is_none());
        assert!(every_node(&graph, NodeId(7)).iter().all(Option::is_none));
    }
}
