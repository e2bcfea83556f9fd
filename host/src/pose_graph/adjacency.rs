//! Which edges meet at each node, laid out for walks over the free part of a pose graph:
//! the fixed nodes move together (they do not move at all), so a walk enters and leaves
//! them as one node. One flat list in compressed rows, built in two passes over the edges,
//! instead of a list per node.

use super::graph::PoseGraph;

/// The edges of a graph, each once per free end, in edge order: those of a free
/// node in one slice of a flat list, and those leaving the fixed nodes (to a free node) in
/// another. An edge between two fixed nodes is left out: the fixed nodes do not move
/// relative to one another.
pub(super) struct Adjacency {
    /// `(node, neighbour, edge index)`, grouped by free node.
    of_free: Vec<(usize, usize, usize)>,
    /// Where each node's group starts in `of_free` (the node after it: where it ends).
    starts: Vec<usize>,
    /// `(fixed node, free neighbour, edge index)`.
    pub(super) from_fixed: Vec<(usize, usize, usize)>,
}

impl Adjacency {
    /// The edges of `graph` as its nodes are fixed or free now.
    pub(super) fn new(graph: &PoseGraph) -> Adjacency {
        let nodes = graph.nodes();
        let free = |node: usize| !nodes[node].fixed;
        let mut starts = vec![0usize; nodes.len() + 1];
        let mut from_fixed = Vec::new();
        for (index, edge) in graph.edges().iter().enumerate() {
            let (from, to) = (edge.from.0, edge.to.0);
            for (end, other) in [(from, to), (to, from)] {
                if free(end) {
                    starts[end + 1] += 1;
                } else if free(other) {
                    from_fixed.push((end, other, index));
                }
            }
        }
        for node in 0..nodes.len() {
            starts[node + 1] += starts[node];
        }
        let mut filled = starts.clone();
        let mut of_free = vec![(0, 0, 0); starts[nodes.len()]];
        for (index, edge) in graph.edges().iter().enumerate() {
            let (from, to) = (edge.from.0, edge.to.0);
            for (end, other) in [(from, to), (to, from)] {
                if free(end) {
                    of_free[filled[end]] = (end, other, index);
                    filled[end] += 1;
                }
            }
        }
        Adjacency {
            of_free,
            starts,
            from_fixed,
        }
    }

    /// The edges of free node `node`.
    pub(super) fn edges_of_free(&self, node: usize) -> &[(usize, usize, usize)] {
        &self.of_free[self.starts[node]..self.starts[node + 1]]
    }
}
