//! A node of the pose graph: one robot pose in the map frame, free or fixed.
//!
//! Nodes are numbered in the order they are added, from zero; a [`NodeId`] is that number. A
//! fixed node keeps its pose through optimisation. Fixing at least one node of every connected
//! part of the graph removes the gauge freedom (the whole graph could otherwise slide and turn
//! without changing any constraint), which is why the first node added is fixed by default.

use std::fmt;

use crate::geometry::Pose2;

/// The index of a node in its [`PoseGraph`](super::PoseGraph), in the order nodes were added.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId(pub usize);

impl fmt::Display for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "node {}", self.0)
    }
}

/// One pose variable of the graph.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// The pose of the robot in the map frame (`map_from_robot`).
    pub pose_in_map: Pose2,
    /// Whether optimisation leaves this pose unchanged.
    pub fixed: bool,
}
