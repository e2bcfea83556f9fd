//! Local tracking: each scan placed in the `local` frame against the active submap.
//!
//! The motion since the last scan is predicted from the odometry when there is some, else
//! taken to be the last motion again (constant velocity). The prediction is refined on the
//! older active submap's interpolated grid. If the scan then fits poorly (the prediction was
//! too far off for a local refinement), the exact raster matcher searches a wide window
//! against the last scans, and the best of both refinements wins. The pose found goes into
//! both active submaps; the older is finished when the newer has received
//! [`SlamOptions::scans_per_submap`] scans.

use super::options::SlamOptions;
use super::recent_scans::RecentScans;
use super::slam_submap::SlamSubmap;
use super::window_matcher::window_matcher;
use crate::grid::{Refinement, ScanRefiner};
use crate::scan_match::{FastMatcher, Pose2, Scan, ScanMatcher};

/// What tracking made of one scan.
#[derive(Clone, Debug)]
pub struct TrackedScan {
    /// The scan's node number (0, 1, 2, … in the order scans came).
    pub node: usize,
    /// `local_from_robot` at the scan.
    pub pose_in_local: Pose2,
    /// Mean grid probability at the scan's end points after refinement (1 for the first scan).
    pub probability: f64,
    /// Whether the wide search ran.
    pub searched: bool,
    /// A submap this scan finished, to keep for loop closure.
    pub finished_submap: Option<SlamSubmap>,
}

/// The local-tracking state. See the [module documentation](self).
#[derive(Debug)]
pub struct LocalTracker {
    options: SlamOptions,
    /// Older first; at most two.
    active: Vec<SlamSubmap>,
    recent: RecentScans,
    refiner: ScanRefiner,
    wide_search: FastMatcher,
    last_pose_in_local: Option<Pose2>,
    last_motion: Pose2,
    last_odometry: Option<Pose2>,
    next_node: usize,
}

impl LocalTracker {
    /// A tracker with no scan yet.
    ///
    /// # Errors
    /// When the wide-search options do not make a valid raster or table.
    pub fn new(options: SlamOptions) -> Result<Self, crate::scan_match::ScanMatchError> {
        let local = &options.local;
        let wide_search = window_matcher(
            local.search_window_m,
            local.search_window_rad,
            local.search_resolution_m,
            local.search_rotation_step_rad,
            256,
        )?;
        Ok(LocalTracker {
            refiner: ScanRefiner::new(local.refiner),
            wide_search,
            recent: RecentScans::new(local.recent_scans),
            active: Vec::new(),
            last_pose_in_local: None,
            last_motion: Pose2::IDENTITY,
            last_odometry: None,
            next_node: 0,
            options,
        })
    }

    /// Places `scan` (beam end points in the robot frame) in the local frame; `odometry` is
    /// the robot's pose in the odometry frame at the scan, when known.
    pub fn track(&mut self, scan: &Scan, odometry: Option<Pose2>) -> TrackedScan {
        let node = self.next_node;
        self.next_node += 1;
        let odometry_motion = match (self.last_odometry, odometry) {
            (Some(previous), Some(current)) => Some(previous.inverse() * current),
            _ => None,
        };
        self.last_odometry = odometry;
        let Some(last_pose) = self.last_pose_in_local else {
            let pose = Pose2::IDENTITY;
            self.accept(node, scan, pose);
            return TrackedScan {
                node,
                pose_in_local: pose,
                probability: 1.0,
                searched: false,
                finished_submap: None,
            };
        };
        let motion = odometry_motion.unwrap_or(self.last_motion);
        let predicted = last_pose * motion;
        let (mut best, mut searched) = (self.refine(scan, predicted), false);
        let min_probability = self.options.local.min_refined_probability;
        if best.as_ref().is_none_or(|(_, p)| *p < min_probability) {
            searched = true;
            let reference = self.recent.reference_in(last_pose);
            if let Ok(found) = self.wide_search.match_scans(&reference, scan, motion) {
                let candidate = last_pose * found.reference_from_new;
                if let Some(refined) = self.refine(scan, candidate)
                    && best.as_ref().is_none_or(|(_, p)| refined.1 > *p)
                {
                    best = Some(refined);
                }
            }
        }
        let (pose, probability) = best.unwrap_or((predicted, 0.0));
        let finished_submap = self.accept(node, scan, pose);
        self.last_motion = last_pose.inverse() * pose;
        TrackedScan {
            node,
            pose_in_local: pose,
            probability,
            searched,
            finished_submap,
        }
    }

    /// The submaps being built, older first.
    pub fn active_submaps(&self) -> &[SlamSubmap] {
        &self.active
    }

    /// Refines `guess_in_local` on the older active submap: the pose and its probability.
    fn refine(&mut self, scan: &Scan, guess_in_local: Pose2) -> Option<(Pose2, f64)> {
        let submap = self.active.first_mut()?;
        let submap_in_local = submap.pose_in_local();
        let guess = submap_in_local.inverse() * guess_in_local;
        let Refinement {
            grid_from_robot,
            mean_probability,
            ..
        } = self.refiner.refine(scan, submap.interpolated(), guess)?;
        Some((submap_in_local * grid_from_robot, mean_probability))
    }

    /// Inserts the scan at `pose` and starts and finishes submaps as due.
    fn accept(&mut self, node: usize, scan: &Scan, pose: Pose2) -> Option<SlamSubmap> {
        if self.active.is_empty() {
            self.active
                .push(SlamSubmap::new(pose, node, self.options.submap));
        }
        for submap in &mut self.active {
            submap.insert(node, scan, pose);
        }
        let newest_full = self
            .active
            .last()
            .is_some_and(|s| s.num_scans() >= self.options.scans_per_submap);
        let mut finished = None;
        if newest_full {
            let mut next = SlamSubmap::new(pose, node, self.options.submap);
            next.insert(node, scan, pose);
            self.active.push(next);
            if self.active.len() > 2 {
                let mut old = self.active.remove(0);
                old.finish();
                finished = Some(old);
            }
        }
        self.recent.push(pose, scan.clone());
        self.last_pose_in_local = Some(pose);
        finished
    }

    /// Finishes and returns the active submaps (at the end of a run).
    pub fn finish(&mut self) -> Vec<SlamSubmap> {
        let mut submaps = std::mem::take(&mut self.active);
        for submap in &mut submaps {
            submap.finish();
        }
        submaps
    }
}
