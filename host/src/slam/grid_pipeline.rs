//! Method 2 as one type: time-stamped scans in, tracking, loop closure and the final
//! refinement ([`GraphSlam`]), poses, trajectory and the global occupancy grid out.
//!
//! The daemon on the robot, the replay of its recordings, `hil-sim replay-carmen` and the
//! seeded whole-chain runs all drive this type; they only read inputs and write outputs, so
//! what the evaluations measure is what the robot runs.

use crate::geometry::Pose2;
use crate::grid::{ProbabilityGrid, RangeInserterOptions};
use crate::link::SensorEvent;
use crate::scan_match::{Scan, ScanMatchError};
use crate::slam::{
    ClosureConstraint, GraphSlam, SlamOptions, SlamResult, SlamStats, SlamTimings, TrackingCheck,
};

/// How the pipeline runs.
#[derive(Debug, Clone)]
pub struct GridPipelineOptions {
    /// The SLAM; its `max_range_m` is also the range up to which the link's scans are used.
    pub slam: SlamOptions,
    /// Cell size of the global occupancy grid, metres: the finest it is drawn at. A map wider
    /// than [`MAX_SIDE_CELLS`](crate::grid::MAX_SIDE_CELLS) of these (with room to grow) is
    /// drawn at twice the cell size, or four times, and so on, so that it is never cut
    /// ([`GridPipeline::global_grid`]; its limits give the cell size used).
    pub map_resolution_m: f64,
    /// The laser's pose on the robot: the link's scans (in the sensor frame) are moved into the
    /// robot frame with it, so the poses are the robot's.
    pub laser_in_robot: Pose2,
}

impl Default for GridPipelineOptions {
    fn default() -> Self {
        GridPipelineOptions {
            slam: SlamOptions::default(),
            map_resolution_m: 0.05,
            laser_in_robot: Pose2::IDENTITY,
        }
    }
}

/// Occupancy-grid SLAM over time-stamped scans. See the [module documentation](self).
#[derive(Debug)]
pub struct GridPipeline {
    /// The SLAM while the run goes on.
    slam: Option<GraphSlam>,
    /// What it made of the whole run, once [`GridPipeline::finish`] ran.
    result: Option<SlamResult>,
    options: GridPipelineOptions,
    /// The time of every scan added.
    times_s: Vec<f64>,
    last_pose: Pose2,
}

impl GridPipeline {
    /// A pipeline with `options`.
    ///
    /// # Errors
    /// The scan matcher's options are invalid.
    pub fn new(options: GridPipelineOptions) -> Result<GridPipeline, ScanMatchError> {
        Ok(GridPipeline {
            slam: Some(GraphSlam::new(options.slam.clone())?),
            result: None,
            options,
            times_s: Vec::new(),
            last_pose: Pose2::IDENTITY,
        })
    }

    /// The options the pipeline runs with.
    pub fn options(&self) -> &GridPipelineOptions {
        &self.options
    }

    /// Uses one sensor reading of the board link: its scans (fixes are for geo-referencing,
    /// downstream of the pipeline).
    pub fn on_event(&mut self, event: &SensorEvent) {
        if let SensorEvent::Scan {
            host_time_s, scan, ..
        } = event
        {
            let in_sensor = scan.to_scan(self.options.slam.max_range_m);
            let robot_from_sensor = self.options.laser_in_robot;
            let in_robot = if robot_from_sensor == Pose2::IDENTITY {
                in_sensor
            } else {
                Scan::from_points_in_robot(
                    in_sensor
                        .points_in_robot()
                        .iter()
                        .map(|p| p.map(|p| robot_from_sensor.transform_point(p)))
                        .collect(),
                )
            };
            self.add_scan(*host_time_s, &in_robot, None);
        }
    }

    /// Adds a scan (end points in the robot frame) taken at `time_s`, with the odometry pose
    /// at the scan when the source has one; returns the scan's pose in the map. Scans after
    /// [`GridPipeline::finish`] are not used.
    pub fn add_scan(&mut self, time_s: f64, scan: &Scan, odometry: Option<Pose2>) -> Pose2 {
        let Some(slam) = self.slam.as_mut() else {
            return self.last_pose;
        };
        self.last_pose = slam.add_scan(time_s, scan, odometry);
        self.times_s.push(time_s);
        self.last_pose
    }

    /// Has the next scan's tracking score `motion_from_last_scan` (a reference trajectory's)
    /// beside its candidates ([`GraphSlam::check_next_motion`]).
    pub fn check_next_motion(&mut self, motion_from_last_scan: Pose2) {
        if let Some(slam) = self.slam.as_mut() {
            slam.check_next_motion(motion_from_last_scan);
        }
    }

    /// The check the last scan's tracking made, if one was asked for it.
    pub fn last_check(&self) -> Option<&TrackingCheck> {
        self.slam.as_ref().and_then(GraphSlam::last_check)
    }

    /// The robot's pose in the map frame after the last scan.
    pub fn pose(&self) -> Pose2 {
        self.last_pose
    }

    /// Ends the run: the SLAM's final refinement (every node not aligned as its place settled
    /// aligned on the submaps near it, [`GraphSlam::finish`]) and its last optimisation, with
    /// every node free. Scans that come later are not used.
    pub fn finish(&mut self) {
        if let Some(slam) = self.slam.take() {
            let result = slam.finish();
            if let Some(&last) = result.poses_in_map.last() {
                self.last_pose = last;
            }
            self.result = Some(result);
        }
    }

    /// Every scan's pose as the graph holds it now (after [`GridPipeline::finish`], as it
    /// holds them at the end), in the order the scans were added.
    pub fn poses_in_map(&self) -> Vec<Pose2> {
        match (&self.result, &self.slam) {
            (Some(result), _) => result.poses_in_map.clone(),
            (None, Some(slam)) => slam.poses_in_map(),
            (None, None) => Vec::new(),
        }
    }

    /// The time and pose of the `index`-th scan added, as [`GridPipeline::trajectory`] holds
    /// it, without copying the others.
    pub fn stamped_pose(&self, index: usize) -> Option<(f64, Pose2)> {
        let time_s = *self.times_s.get(index)?;
        let pose = match (&self.result, &self.slam) {
            (Some(result), _) => result.poses_in_map.get(index).copied(),
            (None, Some(slam)) => slam.pose_in_map(index),
            (None, None) => None,
        }?;
        Some((time_s, pose))
    }

    /// Every scan's time and pose as the graph holds it now.
    pub fn trajectory(&self) -> Vec<(f64, Pose2)> {
        let poses = self.poses_in_map();
        self.times_s.iter().copied().zip(poses).collect()
    }

    /// Every loop closure and refinement constraint that entered the pose graph, once the
    /// run is over ([`GridPipeline::finish`]); empty before.
    pub fn closures(&self) -> &[ClosureConstraint] {
        self.result.as_ref().map_or(&[], |result| &result.closures)
    }

    /// How many scans were added.
    pub fn scan_count(&self) -> usize {
        self.times_s.len()
    }

    /// Whether local tracking could not place the last scan: the robot is lost until a scan
    /// fits again (and loop closure puts it back on its map).
    pub fn is_lost(&self) -> bool {
        self.lost().last().copied().unwrap_or(false)
    }

    /// For every scan added, whether local tracking could not place it.
    pub fn lost(&self) -> &[bool] {
        match (&self.result, &self.slam) {
            (Some(result), _) => &result.lost,
            (None, Some(slam)) => slam.lost(),
            (None, None) => &[],
        }
    }

    /// Where the SLAM's time went so far, part by part (wall time on this machine).
    pub fn timings(&self) -> SlamTimings {
        match (&self.result, &self.slam) {
            (Some(result), _) => result.timings,
            (None, Some(slam)) => slam.timings(),
            (None, None) => SlamTimings::default(),
        }
    }

    /// Totals so far.
    pub fn stats(&self) -> SlamStats {
        match (&self.result, &self.slam) {
            (Some(result), _) => result.stats,
            (None, Some(slam)) => slam.stats(),
            (None, None) => SlamStats::default(),
        }
    }

    /// The global occupancy grid from the scans the map is made of (those the motion filter
    /// inserted, [`crate::slam::motion_filter`]) at their current poses.
    ///
    /// Drawn at the options' `map_resolution_m`, doubled as often as needed for every scan to
    /// fit whole.
    pub fn global_grid(&self) -> ProbabilityGrid {
        let map_scans: Vec<(Pose2, &Scan)> = match (&self.result, &self.slam) {
            (Some(result), _) => result.map_scans().collect(),
            (None, Some(slam)) => slam.map_scans().collect(),
            (None, None) => Vec::new(),
        };
        let resolution_m =
            global_grid_resolution_m(map_scans.iter().copied(), self.options.map_resolution_m);
        ProbabilityGrid::from_scans(
            map_scans,
            resolution_m,
            Default::default(),
            RangeInserterOptions::default(),
        )
    }
}

/// The finest cell size, `finest_m` doubled zero or more times, at which a grid holds every
/// end point of `scans_in_map` within [`MAX_SIDE_CELLS`](crate::grid::MAX_SIDE_CELLS) a side,
/// with room for its growth margins.
fn global_grid_resolution_m<'a>(
    scans_in_map: impl IntoIterator<Item = (Pose2, &'a Scan)>,
    finest_m: f64,
) -> f64 {
    let (mut low, mut high) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (pose, scan) in scans_in_map {
        let origin = [pose.x_m, pose.y_m];
        let ends = scan.points_in_robot().iter().flatten();
        for point in std::iter::once(origin).chain(ends.map(|&p| pose.transform_point(p))) {
            for axis in 0..2 {
                low[axis] = low[axis].min(point[axis]);
                high[axis] = high[axis].max(point[axis]);
            }
        }
    }
    let extent_m = (high[0] - low[0]).max(high[1] - low[1]);
    // The grid grows by up to a few hundred cells beyond what it needs on each side.
    let usable_cells = (crate::grid::MAX_SIDE_CELLS - 640) as f64;
    let mut resolution_m = finest_m;
    while extent_m.is_finite() && extent_m / resolution_m > usable_cells {
        resolution_m *= 2.0;
    }
    resolution_m
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::link::LaserScan;
    use crate::scan_match::synthetic::{cast_front_scan, irregular_room_walls};

    /// The robot wandering in a room, one scan per pose, as the link hands them over.
    fn room_events(count: usize) -> Vec<SensorEvent> {
        let walls = irregular_room_walls();
        (0..count)
            .map(|k| {
                let k_f = k as f64;
                let pose = Pose2::new(
                    1.5 * (k_f / 12.0).sin(),
                    0.8 * (k_f / 17.0).sin(),
                    0.4 * (k_f / 9.0).sin(),
                );
                let ranges_m = cast_front_scan(&walls, pose)
                    .points_in_robot()
                    .iter()
                    .map(|p| p.map_or(f64::NAN, |[x, y]| x.hypot(y)))
                    .collect();
                SensorEvent::Scan {
                    host_time_s: 0.2 * k_f,
                    board_time_s: 0.2 * k_f,
                    scan_counter: k as u32,
                    scan: Arc::new(LaserScan {
                        ranges_m,
                        first_angle_rad: -std::f64::consts::FRAC_PI_2,
                        angle_step_rad: 1f64.to_radians(),
                    }),
                }
            })
            .collect()
    }

    #[test]
    fn a_map_too_wide_for_the_finest_cells_is_coarsened_not_cut() {
        // Two scans 300 m apart: 6 000 cells at 5 cm.
        let scan = Scan::from_points_in_robot(vec![Some([1.0, 0.0]), Some([1.0, 0.5])]);
        let poses = [Pose2::IDENTITY, Pose2::new(300.0, 0.0, 0.0)];
        let resolution_m = global_grid_resolution_m(poses.iter().map(|&p| (p, &scan)), 0.05);
        assert_eq!(resolution_m, 0.1);
        let near = [Pose2::IDENTITY, Pose2::new(30.0, 0.0, 0.0)];
        assert_eq!(
            global_grid_resolution_m(near.iter().map(|&p| (p, &scan)), 0.05),
            0.05
        );
        let grid = ProbabilityGrid::from_scans(
            poses.iter().map(|&p| (p, &scan)),
            resolution_m,
            Default::default(),
            RangeInserterOptions::default(),
        );
        // Both end points of the far scan are in the grid.
        assert!(grid.probability_at([301.0, 0.0]).is_some());
        assert!(grid.probability_at([1.0, 0.0]).is_some());
    }

    #[test]
    fn finishing_refines_the_run_and_ends_it() {
        let events = room_events(110);
        let mut pipeline =
            GridPipeline::new(GridPipelineOptions::default()).expect("valid options");
        for event in &events[..100] {
            pipeline.on_event(event);
        }
        assert_eq!(pipeline.stats().refinement_constraints, 0);
        pipeline.finish();
        let stats = pipeline.stats();
        // The first submap is finished once the third starts (scan 60); later scans of the
        // same room are tied to it.
        assert!(stats.refinement_constraints > 0, "{stats:?}");
        assert_eq!(pipeline.trajectory().len(), 100);
        assert_eq!(
            pipeline.trajectory().last().map(|t| t.1),
            Some(pipeline.pose())
        );

        // The run is over: later scans and a second finish change nothing.
        for event in &events[100..] {
            pipeline.on_event(event);
        }
        pipeline.finish();
        assert_eq!(pipeline.trajectory().len(), 100);
        assert_eq!(pipeline.stats(), stats);
    }
}
