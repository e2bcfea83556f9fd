//! The earlier node nearest a point, without a pass over every node.
//!
//! A scan that no finished submap took is searched in a chain of earlier scans around the
//! node nearest to it ([`super::chain_closer`]); after an hour in one building there are tens
//! of thousands of nodes, and a pass over all of them for each searched scan grows with the
//! time spent. Settled nodes ([`super::settled_submaps`]) are fixed for the rest of the run:
//! they do not move, so they wait in a grid of square cells by where they lie. The free
//! nodes, which every solve moves, are the pass under way and the places seen once: few, and
//! read where the graph holds them now.
//!
//! The answer is the one a pass over every node would give, ties to the lowest node.

use std::collections::{BTreeSet, HashMap};

use foldhash::fast::FixedState;

use crate::geometry::Pose2;

/// Where the nodes lie, for nearest-node queries. See the [module documentation](self).
#[derive(Debug)]
pub(super) struct NodeIndex {
    /// The side of a cell, m; a query looks at the cells within its distance.
    cell_m: f64,
    /// Fixed nodes by the cell they lie in.
    fixed_by_cell: HashMap<(i64, i64), Vec<usize>, FixedState>,
    /// The other nodes.
    free: BTreeSet<usize>,
}

impl NodeIndex {
    /// An empty index with cells `cell_m` on a side (`> 0`; the distance queries usually
    /// ask for is a good choice).
    pub(super) fn new(cell_m: f64) -> NodeIndex {
        NodeIndex {
            cell_m,
            fixed_by_cell: HashMap::default(),
            free: BTreeSet::new(),
        }
    }

    /// A new node, free.
    pub(super) fn add(&mut self, node: usize) {
        self.free.insert(node);
    }

    /// `node` is fixed at `pose_in_map` for the rest of the run.
    pub(super) fn fix(&mut self, node: usize, pose_in_map: Pose2) {
        if self.free.remove(&node) {
            self.fixed_by_cell
                .entry(self.cell_of(pose_in_map.x_m, pose_in_map.y_m))
                .or_default()
                .push(node);
        }
    }

    /// The node up to `last` (inclusive) nearest to `point_in_map` within `max_distance_m`,
    /// each where `pose_in_map` puts it; ties go to the lowest node.
    pub(super) fn nearest(
        &self,
        point_in_map: [f64; 2],
        max_distance_m: f64,
        last: usize,
        pose_in_map: impl Fn(usize) -> Option<Pose2>,
    ) -> Option<usize> {
        let mut best: Option<(f64, usize)> = None;
        let mut consider = |node: usize| {
            let Some(pose) = pose_in_map(node) else {
                return;
            };
            let distance_m = (pose.x_m - point_in_map[0]).hypot(pose.y_m - point_in_map[1]);
            let nearer = best.is_none_or(|(best_m, best_node)| {
                distance_m
                    .total_cmp(&best_m)
                    .then(node.cmp(&best_node))
                    .is_lt()
            });
            if nearer {
                best = Some((distance_m, node));
            }
        };
        for &node in self.free.range(..=last) {
            consider(node);
        }
        if max_distance_m.is_finite() && max_distance_m >= 0.0 {
            let reach = (max_distance_m / self.cell_m).ceil() as i64;
            let (x, y) = self.cell_of(point_in_map[0], point_in_map[1]);
            for cx in x - reach..=x + reach {
                for cy in y - reach..=y + reach {
                    for &node in self.fixed_by_cell.get(&(cx, cy)).into_iter().flatten() {
                        if node <= last {
                            consider(node);
                        }
                    }
                }
            }
        } else {
            for &node in self.fixed_by_cell.values().flatten() {
                if node <= last {
                    consider(node);
                }
            }
        }
        best.filter(|&(distance_m, _)| distance_m <= max_distance_m)
            .map(|(_, node)| node)
    }

    fn cell_of(&self, x_m: f64, y_m: f64) -> (i64, i64) {
        (
            (x_m / self.cell_m).floor() as i64,
            (y_m / self.cell_m).floor() as i64,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The answer of a pass over every node: the first of the nearest.
    fn by_every_node(poses: &[Pose2], point: [f64; 2], max_m: f64, last: usize) -> Option<usize> {
        let distance = |p: &Pose2| (p.x_m - point[0]).hypot(p.y_m - point[1]);
        (0..=last.min(poses.len() - 1))
            .min_by(|&a, &b| distance(&poses[a]).total_cmp(&distance(&poses[b])))
            .filter(|&n| distance(&poses[n]) <= max_m)
    }

    #[test]
    fn the_same_node_as_a_pass_over_every_node() {
        // A robot driving laps of a 30 m square, with repeated poses (standing still) and
        // half the nodes fixed along the way.
        let mut poses = Vec::new();
        for k in 0..600 {
            let s = (k % 120) as f64 * 1.0;
            let (x, y) = match (s / 30.0) as usize {
                0 => (s, 0.0),
                1 => (30.0, s - 30.0),
                2 => (90.0 - s, 30.0),
                _ => (0.0, 120.0 - s),
            };
            let wobble = 0.01 * (k / 120) as f64;
            poses.push(Pose2::new(x + wobble, y - wobble, 0.0));
            if k % 50 == 7 {
                poses.push(Pose2::new(x + wobble, y - wobble, 0.0));
            }
        }
        let mut index = NodeIndex::new(10.0);
        for node in 0..poses.len() {
            index.add(node);
            if node % 3 != 0 && node + 40 < poses.len() {
                index.fix(node, poses[node]);
            }
        }
        let at = |node: usize| poses.get(node).copied();
        for (i, point) in [
            [0.0, 0.0],
            [15.2, 0.3],
            [30.0, 29.9],
            [-7.0, 12.0],
            [60.0, 60.0],
        ]
        .into_iter()
        .enumerate()
        {
            for last in [0, 10, 299, 601, poses.len() - 1] {
                for max_m in [0.5, 3.0, 10.0, 25.0, f64::INFINITY] {
                    assert_eq!(
                        index.nearest(point, max_m, last, at),
                        by_every_node(&poses, point, max_m, last),
                        "point {i}, last {last}, within {max_m} m"
                    );
                }
            }
        }
    }

    #[test]
    fn nothing_near_and_nothing_indexed() {
        let index = NodeIndex::new(10.0);
        assert_eq!(index.nearest([0.0, 0.0], 10.0, 100, |_| None), None);
        let mut index = NodeIndex::new(10.0);
        index.add(0);
        index.fix(0, Pose2::new(50.0, 0.0, 0.0));
        let at = |_| Some(Pose2::new(50.0, 0.0, 0.0));
        assert_eq!(index.nearest([0.0, 0.0], 10.0, 0, at), None);
        assert_eq!(index.nearest([45.0, 0.0], 10.0, 0, at), Some(0));
    }
}
