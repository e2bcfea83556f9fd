//! Which edges meet at each node, kept up to date as the graph grows, for walks over the free
//! part of a pose graph: the fixed nodes move together (they do not move at all), so a walk
//! enters and leaves them as one node. Adding a node or an edge, or fixing or freeing a node,
//! costs the same however large the graph, so a walk that covers only the free part costs
//! what that part holds, not what the whole graph does.

use std::collections::BTreeSet;

use super::node::Node;

/// The edges of a graph, each once per end, in edge order, and which nodes are free.
#[derive(Debug, Clone, Default)]
pub(super) struct Adjacency {
    /// For each node, `(neighbour, edge index)` of every edge at it, in edge order.
    of_node: Vec<Vec<(usize, usize)>>,
    /// The free nodes, in order.
    free: BTreeSet<usize>,
}

impl Adjacency {
    /// Takes in the next node.
    pub(super) fn add_node(&mut self, fixed: bool) {
        if !fixed {
            self.free.insert(self.of_node.len());
        }
        self.of_node.push(Vec::new());
    }

    /// Takes in edge `index` between the existing nodes `from` and `to`.
    pub(super) fn add_edge(&mut self, index: usize, from: usize, to: usize) {
        self.of_node[from].push((to, index));
        self.of_node[to].push((from, index));
    }

    /// Notes that `node` is now fixed or free.
    pub(super) fn set_fixed(&mut self, node: usize, fixed: bool) {
        if fixed {
            self.free.remove(&node);
        } else {
            self.free.insert(node);
        }
    }

    /// `(neighbour, edge index)` of every edge at `node`, in edge order.
    pub(super) fn edges_of(&self, node: usize) -> &[(usize, usize)] {
        self.of_node.get(node).map_or(&[], Vec::as_slice)
    }

    /// The free nodes, in order.
    pub(super) fn free_nodes(&self) -> impl Iterator<Item = usize> + '_ {
        self.free.iter().copied()
    }

    /// The free nodes and the edges with a free end, each in order: what optimisation can
    /// change, gathered from the free nodes' edges.
    pub(super) fn free_part(&self) -> (Vec<usize>, Vec<usize>) {
        let mut edges: Vec<usize> = self
            .free
            .iter()
            .flat_map(|&free| self.edges_of(free).iter().map(|&(_, index)| index))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        (self.free_nodes().collect(), edges)
    }

    /// `(fixed node, free neighbour, edge index)` of every edge leaving the fixed nodes, in
    /// edge order: what a walk leaves the fixed nodes through. Gathered from the free nodes'
    /// edges, so it costs what the free part holds. An edge between two fixed nodes is left
    /// out: the fixed nodes do not move relative to one another.
    pub(super) fn edges_leaving_fixed(&self, nodes: &[Node]) -> Vec<(usize, usize, usize)> {
        let mut leaving: Vec<(usize, usize, usize)> = self
            .free
            .iter()
            .flat_map(|&free| {
                self.edges_of(free)
                    .iter()
                    .filter(|&&(other, _)| nodes[other].fixed)
                    .map(move |&(fixed, index)| (fixed, free, index))
            })
            .collect();
        leaving.sort_unstable_by_key(|&(_, _, index)| index);
        leaving
    }
}

#[cfg(test)]
mod tests {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    use super::*;
    use crate::geometry::Pose2;

    #[test]
    fn kept_up_to_date_it_holds_what_a_pass_over_the_edges_finds() {
        let mut rng = StdRng::seed_from_u64(7);
        let mut nodes: Vec<Node> = Vec::new();
        let mut edges: Vec<(usize, usize)> = Vec::new();
        let mut adjacency = Adjacency::default();
        for _ in 0..2_000 {
            match rng.random_range(0..4) {
                0 => {
                    let fixed = nodes.is_empty() || rng.random_range(0..5) == 0;
                    nodes.push(Node {
                        pose_in_map: Pose2::IDENTITY,
                        fixed,
                    });
                    adjacency.add_node(fixed);
                }
                1 | 2 if nodes.len() >= 2 => {
                    let from = rng.random_range(0..nodes.len());
                    let to = (from + rng.random_range(1..nodes.len())) % nodes.len();
                    adjacency.add_edge(edges.len(), from, to);
                    edges.push((from, to));
                }
                _ if !nodes.is_empty() => {
                    let node = rng.random_range(0..nodes.len());
                    let fixed = !nodes[node].fixed;
                    nodes[node].fixed = fixed;
                    adjacency.set_fixed(node, fixed);
                }
                _ => {}
            }
        }
        for node in 0..nodes.len() {
            let at_node: Vec<(usize, usize)> = edges
                .iter()
                .enumerate()
                .filter_map(|(index, &(from, to))| {
                    (from == node)
                        .then_some((to, index))
                        .or((to == node).then_some((from, index)))
                })
                .collect();
            assert_eq!(adjacency.edges_of(node), at_node.as_slice(), "node {node}");
        }
        let leaving: Vec<(usize, usize, usize)> = edges
            .iter()
            .enumerate()
            .filter_map(
                |(index, &(from, to))| match (nodes[from].fixed, nodes[to].fixed) {
                    (true, false) => Some((from, to, index)),
                    (false, true) => Some((to, from, index)),
                    _ => None,
                },
            )
            .collect();
        assert!(!leaving.is_empty());
        assert_eq!(adjacency.edges_leaving_fixed(&nodes), leaving);
    }
}
