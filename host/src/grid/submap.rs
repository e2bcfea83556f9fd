//! A submap: a local occupancy grid built from a short run of consecutive scans.
//!
//! Scans are matched against a submap rather than the whole map, so the drift of the robot's
//! pose only accumulates within one submap; the pose graph then places whole submaps. The grid
//! lives in the *submap frame*, fixed to the submap; `pose_in_map` (`map_from_submap`) places
//! that frame in the map. By default the submap frame is the pose of the robot when the first
//! scan was inserted, so the submap's grid is aligned with the robot's heading at that moment.
//!
//! A submap takes scans until it is finished; after that its grid no longer changes and the
//! matcher's precomputed views of it stay valid.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::probability_grid::{ProbabilityGrid, ProbabilityGridOptions};
use super::range_inserter::{RangeInserter, RangeInserterOptions};
use crate::geometry::Pose2;
use crate::scan_match::Scan;

/// How a submap's grid is built.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SubmapOptions {
    /// Side of one grid cell, in metres; 0.05.
    pub resolution_m: f64,
    /// Probability limits of the grid.
    pub grid: ProbabilityGridOptions,
    /// How scans update the grid.
    pub range_inserter: RangeInserterOptions,
}

impl Default for SubmapOptions {
    /// 5 cm cells, default grid limits and inserter.
    fn default() -> Self {
        SubmapOptions {
            resolution_m: 0.05,
            grid: ProbabilityGridOptions::default(),
            range_inserter: RangeInserterOptions::default(),
        }
    }
}

/// A scan was offered to a submap that is already finished; the submap is unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SubmapFinishedError;

impl fmt::Display for SubmapFinishedError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot insert a scan into a finished submap")
    }
}

impl std::error::Error for SubmapFinishedError {}

/// A probability grid in its own submap frame, placed in the map by `pose_in_map`.
#[derive(Clone, Debug)]
pub struct Submap {
    /// `map_from_submap`; `None` until the first scan fixes it.
    pose_in_map: Option<Pose2>,
    grid: ProbabilityGrid,
    inserter: RangeInserter,
    num_scans: usize,
    finished: bool,
}

impl Submap {
    /// An empty submap whose frame will be the robot pose of the first inserted scan.
    ///
    /// # Panics
    ///
    /// On invalid options, as [`ProbabilityGrid::new`] and [`RangeInserter::new`].
    pub fn new(options: SubmapOptions) -> Self {
        Submap {
            pose_in_map: None,
            grid: ProbabilityGrid::new(options.resolution_m, options.grid),
            inserter: RangeInserter::new(options.range_inserter),
            num_scans: 0,
            finished: false,
        }
    }

    /// An empty submap whose frame sits at `pose_in_map` (`map_from_submap`).
    ///
    /// # Panics
    ///
    /// On invalid options, as [`Submap::new`].
    pub fn with_pose_in_map(pose_in_map: Pose2, options: SubmapOptions) -> Self {
        Submap {
            pose_in_map: Some(pose_in_map),
            ..Submap::new(options)
        }
    }

    /// The submap frame in the map (`map_from_submap`), once known: given at construction or
    /// fixed by the first inserted scan.
    pub fn pose_in_map(&self) -> Option<Pose2> {
        self.pose_in_map
    }

    /// Moves the submap frame to `pose_in_map` (`map_from_submap`), for instance after the pose
    /// graph is optimised. The grid moves with the frame; scans inserted later are placed
    /// relative to the new pose.
    pub fn set_pose_in_map(&mut self, pose_in_map: Pose2) {
        self.pose_in_map = Some(pose_in_map);
    }

    /// The occupancy grid, in the submap frame.
    pub fn grid(&self) -> &ProbabilityGrid {
        &self.grid
    }

    /// Number of scans inserted so far.
    pub fn num_scans(&self) -> usize {
        self.num_scans
    }

    /// True once [`Submap::finish`] was called; the grid no longer changes.
    pub fn is_finished(&self) -> bool {
        self.finished
    }

    /// Marks the submap finished, releases the inserter's scratch memory and the grid's room
    /// for growth.
    pub fn finish(&mut self) {
        self.finished = true;
        self.inserter = RangeInserter::new(*self.inserter.options());
        self.grid.shrink_to_fit();
    }

    /// Grows the grid at once to hold every cell that inserting each of `scans` (with its
    /// `map_from_robot`) would touch, where it can ([`ProbabilityGrid::reserve_bounds`]), so
    /// that inserting them in turn does not grow it step by step. The grid's values come out
    /// the same either way. Does nothing before the submap's frame is fixed.
    pub fn reserve_for<'a>(&mut self, scans: impl IntoIterator<Item = (&'a Scan, Pose2)>) {
        let Some(map_from_submap) = self.pose_in_map else {
            return;
        };
        let bounds = self
            .inserter
            .bounds_of_scans(scans, map_from_submap.inverse());
        if let Some((lower, upper)) = bounds {
            self.grid.reserve_bounds(lower, upper);
        }
    }

    /// Inserts `scan`, taken with the robot at `robot_pose_in_map` (`map_from_robot`), into the
    /// grid. The first scan of a submap without a pose fixes the submap frame at
    /// `robot_pose_in_map`.
    ///
    /// # Errors
    ///
    /// [`SubmapFinishedError`] if the submap is finished; nothing changes.
    pub fn insert(
        &mut self,
        scan: &Scan,
        robot_pose_in_map: Pose2,
    ) -> Result<(), SubmapFinishedError> {
        if self.finished {
            return Err(SubmapFinishedError);
        }
        let map_from_submap = *self.pose_in_map.get_or_insert(robot_pose_in_map);
        let submap_from_robot = map_from_submap.inverse() * robot_pose_in_map;
        self.inserter
            .insert(scan, submap_from_robot, &mut self.grid);
        self.num_scans += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_first_scan_fixes_the_frame() {
        let mut submap = Submap::new(SubmapOptions::default());
        assert_eq!(submap.pose_in_map(), None);
        let scan = Scan::from_points_in_robot(vec![Some([1.02, 0.02])]);
        let first_pose_in_map = Pose2::new(3.0, -2.0, 1.0);
        submap.insert(&scan, first_pose_in_map).unwrap();
        assert_eq!(submap.pose_in_map(), Some(first_pose_in_map));
        // In the submap frame the robot sat at the origin, looking along x.
        let p = submap.grid().probability_at([1.02, 0.02]).unwrap();
        assert!((p - 0.55).abs() < 1e-6);
        assert!(submap.grid().probability_at([0.5, 0.0]).unwrap() < 0.5);

        // A second scan from another pose lands where it belongs in the map.
        let second_pose_in_map = first_pose_in_map * Pose2::new(0.0, 0.0, std::f64::consts::PI);
        submap.insert(&scan, second_pose_in_map).unwrap();
        assert!(submap.grid().probability_at([-1.02, -0.02]).unwrap() > 0.5);
        assert_eq!(submap.num_scans(), 2);
    }

    #[test]
    fn test_given_pose_and_finish() {
        let submap_pose_in_map = Pose2::new(1.0, 1.0, 0.0);
        let mut submap = Submap::with_pose_in_map(submap_pose_in_map, SubmapOptions::default());
        let scan = Scan::from_points_in_robot(vec![Some([1.02, 0.02])]);
        submap.insert(&scan, Pose2::new(2.0, 1.0, 0.0)).unwrap();
        assert_eq!(submap.pose_in_map(), Some(submap_pose_in_map));
        assert!(submap.grid().probability_at([2.02, 0.02]).unwrap() > 0.5);
        assert!(!submap.is_finished());
        submap.finish();
        assert!(submap.is_finished());
        let known = submap.grid().num_known_cells();
        assert_eq!(
            submap.insert(&scan, Pose2::IDENTITY),
            Err(SubmapFinishedError)
        );
        assert_eq!(submap.grid().num_known_cells(), known);
        assert_eq!(submap.num_scans(), 1);
    }

    #[test]
    fn reserving_room_first_changes_no_cell() {
        let scans: Vec<(Scan, Pose2)> = (0..6)
            .map(|k| {
                let k = f64::from(k);
                let points = (0..30)
                    .map(|beam| {
                        let angle = -1.5 + 0.1 * f64::from(beam);
                        let range = 2.0 + k + 0.3 * f64::from(beam % 5);
                        Some([range * angle.cos(), range * angle.sin()])
                    })
                    .collect();
                let pose = Pose2::new(1.5 * k, -0.7 * k, 0.8 * k);
                (Scan::from_points_in_robot(points), pose)
            })
            .collect();
        let first_pose = scans[0].1;
        let mut step_by_step = Submap::with_pose_in_map(first_pose, SubmapOptions::default());
        let mut reserved = step_by_step.clone();
        reserved.reserve_for(scans.iter().map(|(scan, pose)| (scan, *pose)));
        let reserved_cells = reserved.grid().limits().num_cells();
        for (scan, pose) in &scans {
            step_by_step.insert(scan, *pose).unwrap();
            reserved.insert(scan, *pose).unwrap();
        }
        // Room was made once, for every scan, and no scan grew the grid after.
        assert_eq!(reserved.grid().limits().num_cells(), reserved_cells);
        assert!(reserved.grid().same_values(step_by_step.grid()));
        assert!(reserved.grid().num_known_cells() > 1000);
    }

    #[test]
    fn a_box_beyond_the_largest_grid_is_left_to_grow_scan_by_scan() {
        let mut grid = ProbabilityGrid::new(0.05, Default::default());
        let side_m = crate::grid::probability_grid::MAX_SIDE_CELLS as f64 * 0.05;
        assert!(!grid.reserve_bounds([0.0, 0.0], [side_m, 1.0]));
        assert_eq!(grid.limits().num_cells(), 0);
        assert!(grid.reserve_bounds([0.0, 0.0], [10.0, 1.0]));
        assert!(grid.limits().num_cells() > 0);
    }
}
