//! A submap as SLAM keeps it: the occupancy grid, the scans it holds drawn as one reference for
//! the raster matcher, and which trajectory nodes it spans.

use crate::grid::{InterpolatedGrid, Submap, SubmapOptions};
use crate::scan_match::{Pose2, Scan};

/// One submap of the trajectory. Its frame is the local pose of its first scan, so a scan's
/// pose in the submap is also its pose relative to that first node.
#[derive(Clone, Debug)]
pub struct SlamSubmap {
    submap: Submap,
    /// `local_from_submap`.
    pose_in_local: Pose2,
    /// End points of every inserted scan in the submap frame, one polyline per scan.
    points_in_submap: Vec<Option<[f64; 2]>>,
    first_node: usize,
    last_node: usize,
    interpolated: Option<InterpolatedGrid>,
}

impl SlamSubmap {
    /// An empty submap whose frame is `pose_in_local`, the pose of node `first_node`.
    pub fn new(pose_in_local: Pose2, first_node: usize, options: SubmapOptions) -> Self {
        SlamSubmap {
            submap: Submap::with_pose_in_map(pose_in_local, options),
            pose_in_local,
            points_in_submap: Vec::new(),
            first_node,
            last_node: first_node,
            interpolated: None,
        }
    }

    /// Inserts `scan` of node `node`, taken at `robot_pose_in_local`. Nothing happens once
    /// the submap is finished.
    pub fn insert(&mut self, node: usize, scan: &Scan, robot_pose_in_local: Pose2) {
        if self.submap.insert(scan, robot_pose_in_local).is_err() {
            return;
        }
        let submap_from_robot = self.pose_in_local.inverse() * robot_pose_in_local;
        self.points_in_submap.extend(
            scan.points_in_robot()
                .iter()
                .map(|p| p.map(|p| submap_from_robot.transform_point(p))),
        );
        self.points_in_submap.push(None);
        self.last_node = node;
        self.interpolated = None;
    }

    /// Stops insertion and keeps the interpolated grid for matching.
    pub fn finish(&mut self) {
        self.submap.finish();
        self.interpolated();
    }

    /// The interpolated probabilities of the grid (rebuilt after an insertion).
    pub fn interpolated(&mut self) -> &InterpolatedGrid {
        self.interpolated
            .get_or_insert_with(|| InterpolatedGrid::new(self.submap.grid()))
    }

    /// The interpolated grid if it is up to date.
    pub fn interpolated_if_ready(&self) -> Option<&InterpolatedGrid> {
        self.interpolated.as_ref()
    }

    /// Every inserted scan in the submap frame, as one reference for the raster matcher.
    pub fn reference_scan(&self) -> Scan {
        Scan::from_points_in_robot(self.points_in_submap.clone())
    }

    /// `local_from_submap`.
    pub fn pose_in_local(&self) -> Pose2 {
        self.pose_in_local
    }

    /// The node whose pose is the submap frame.
    pub fn first_node(&self) -> usize {
        self.first_node
    }

    /// The last node inserted.
    pub fn last_node(&self) -> usize {
        self.last_node
    }

    /// Scans inserted.
    pub fn num_scans(&self) -> usize {
        self.submap.num_scans()
    }

    /// Whether insertion has stopped.
    pub fn is_finished(&self) -> bool {
        self.submap.is_finished()
    }
}
