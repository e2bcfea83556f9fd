//! The indoor pipeline: raster scan matching against occupancy-grid submaps with loop closure
//! (method 2), one scan at a time, and the global occupancy grid redrawn for the live view.

use super::config::SlamConfig;
use super::link_session::SensorEvent;
use super::state::GridView;
use crate::grid::{MapExport, MapExportOptions, ProbabilityGrid, RangeInserterOptions};
use crate::scan_match::{Pose2, Scan};
use crate::slam::{GraphSlam, SlamOptions, SlamResult, SlamStats};

/// Occupancy-grid SLAM over the link's scans. See the [module documentation](self).
#[derive(Debug)]
pub struct GridPipeline {
    /// The SLAM while the run goes on.
    slam: Option<GraphSlam>,
    /// What it made of the whole run, once [`GridPipeline::finish`] ran.
    result: Option<SlamResult>,
    options: SlamOptions,
    resolution_m: f64,
    /// The beams the SLAM trusted, per scan, for the map.
    scans: Vec<Scan>,
    host_times_s: Vec<f64>,
    last_pose: Pose2,
}

impl GridPipeline {
    /// A pipeline configured by `config`.
    pub fn new(config: &SlamConfig) -> GridPipeline {
        let options = SlamOptions {
            max_range_m: config.grid_max_range_m,
            ..SlamOptions::default()
        };
        GridPipeline {
            slam: GraphSlam::new(options.clone()).ok(),
            result: None,
            options,
            resolution_m: config.grid_resolution_m,
            scans: Vec::new(),
            host_times_s: Vec::new(),
            last_pose: Pose2::IDENTITY,
        }
    }

    /// Uses one sensor reading (fixes are not used indoors).
    pub fn on_event(&mut self, event: &SensorEvent) {
        let SensorEvent::Scan {
            host_time_s, scan, ..
        } = event
        else {
            return;
        };
        let Some(slam) = self.slam.as_mut() else {
            return;
        };
        let scan = scan.to_scan(self.options.max_range_m);
        self.last_pose = slam.add_scan(&scan, None);
        self.scans.push(self.options.trusted_beams(&scan));
        self.host_times_s.push(*host_time_s);
    }

    /// The robot's pose in the map frame after the last scan.
    pub fn pose(&self) -> Pose2 {
        self.last_pose
    }

    /// Ends the run: the SLAM's final refinement (every scan aligned on the submaps near it,
    /// [`GraphSlam::finish`]) and its last optimisation. Scans that come later are not used.
    pub fn finish(&mut self) {
        if let Some(slam) = self.slam.take() {
            let result = slam.finish(&self.scans);
            if let Some(&last) = result.poses_in_map.last() {
                self.last_pose = last;
            }
            self.result = Some(result);
        }
    }

    /// Every scan's pose as the graph holds it now (after [`GridPipeline::finish`], as it
    /// holds them at the end).
    fn poses_in_map(&self) -> Vec<Pose2> {
        match (&self.result, &self.slam) {
            (Some(result), _) => result.poses_in_map.clone(),
            (None, Some(slam)) => slam.poses_in_map(),
            (None, None) => Vec::new(),
        }
    }

    /// Every scan's host time and pose as the graph holds it now.
    pub fn trajectory(&self) -> Vec<(f64, Pose2)> {
        let poses = self.poses_in_map();
        self.host_times_s.iter().copied().zip(poses).collect()
    }

    /// Totals so far.
    pub fn stats(&self) -> SlamStats {
        match (&self.result, &self.slam) {
            (Some(result), _) => result.stats,
            (None, Some(slam)) => slam.stats(),
            (None, None) => SlamStats::default(),
        }
    }

    /// The global occupancy grid from every scan at its current pose.
    pub fn render(&self) -> MapExport {
        let poses = self.poses_in_map();
        let grid = ProbabilityGrid::from_scans(
            poses.into_iter().zip(self.scans.iter()),
            self.resolution_m,
            Default::default(),
            RangeInserterOptions::default(),
        );
        MapExport::from_grid(&grid, &MapExportOptions::default())
    }

    /// The global grid as the live view shows it.
    pub fn grid_view(&self) -> GridView {
        let export = self.render();
        let mut png = Vec::new();
        // Writing into memory fails only on an empty grid, which shows as no grid.
        let _ = export.write_png(&mut png);
        GridView {
            png,
            resolution_m: export.resolution_m(),
            origin_m: export.lower_corner_in_grid(),
            size_cells: [export.width_px() as u32, export.height_px() as u32],
        }
    }
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
    fn finishing_refines_the_run_and_ends_it() {
        let events = room_events(110);
        let mut pipeline = GridPipeline::new(&SlamConfig::default());
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
