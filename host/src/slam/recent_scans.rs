//! The last few scans of the trajectory, drawn together as the reference of a wide search.

use std::collections::VecDeque;

use crate::geometry::Pose2;
use crate::scan_match::Scan;

/// The last `capacity` scans with their poses in the local frame.
#[derive(Clone, Debug)]
pub struct RecentScans {
    capacity: usize,
    scans: VecDeque<(Pose2, Scan)>,
}

impl RecentScans {
    /// Keeps at most `capacity` scans (at least one).
    pub fn new(capacity: usize) -> Self {
        RecentScans {
            capacity: capacity.max(1),
            scans: VecDeque::new(),
        }
    }

    /// Adds `scan`, taken at `pose_in_local`, dropping the oldest beyond capacity.
    pub fn push(&mut self, pose_in_local: Pose2, scan: Scan) {
        if self.scans.len() == self.capacity {
            self.scans.pop_front();
        }
        self.scans.push_back((pose_in_local, scan));
    }

    /// Forgets every scan.
    pub fn clear(&mut self) {
        self.scans.clear();
    }

    /// The newest scan's pose, if any.
    pub fn last_pose_in_local(&self) -> Option<Pose2> {
        self.scans.back().map(|(pose, _)| *pose)
    }

    /// True when no scan was added.
    pub fn is_empty(&self) -> bool {
        self.scans.is_empty()
    }

    /// Every kept scan's end points in the frame of `frame_in_local`, one polyline per scan
    /// (a beam without return separates them).
    pub fn reference_in(&self, frame_in_local: Pose2) -> Scan {
        let frame_from_local = frame_in_local.inverse();
        let mut points = Vec::new();
        for (pose_in_local, scan) in &self.scans {
            let frame_from_robot = frame_from_local * *pose_in_local;
            points.extend(
                scan.points_in_robot()
                    .iter()
                    .map(|p| p.map(|p| frame_from_robot.transform_point(p))),
            );
            points.push(None);
        }
        Scan::from_points_in_robot(points)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_joins_scans_in_the_asked_frame() {
        let mut recent = RecentScans::new(2);
        let scan = Scan::from_points_in_robot(vec![Some([1.0, 0.0])]);
        recent.push(Pose2::new(0.0, 0.0, 0.0), scan.clone());
        recent.push(Pose2::new(1.0, 0.0, 0.0), scan.clone());
        recent.push(Pose2::new(2.0, 0.0, 0.0), scan);
        let reference = recent.reference_in(Pose2::new(2.0, 0.0, 0.0));
        let points: Vec<_> = reference.points_in_robot().to_vec();
        assert_eq!(points.len(), 4);
        let [x, _] = points[0].unwrap_or([9.0, 9.0]);
        assert!((x - 0.0).abs() < 1e-12);
        let [x, _] = points[2].unwrap_or([9.0, 9.0]);
        assert!((x - 1.0).abs() < 1e-12);
        assert_eq!(points[3], None);
        assert_eq!(recent.last_pose_in_local(), Some(Pose2::new(2.0, 0.0, 0.0)));
    }
}
