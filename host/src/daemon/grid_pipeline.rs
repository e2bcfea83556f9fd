//! The indoor pipeline: raster scan matching against occupancy-grid submaps with loop closure
//! (method 2), one scan at a time, and the global occupancy grid redrawn for the live view.

use super::config::SlamConfig;
use super::link_session::SensorEvent;
use super::state::GridView;
use crate::grid::{MapExport, MapExportOptions, ProbabilityGrid, RangeInserterOptions};
use crate::scan_match::{Pose2, Scan};
use crate::slam::{GraphSlam, SlamOptions, SlamStats};

/// Occupancy-grid SLAM over the link's scans. See the [module documentation](self).
#[derive(Debug)]
pub struct GridPipeline {
    slam: Option<GraphSlam>,
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

    /// Every scan's host time and pose as the graph holds it now.
    pub fn trajectory(&self) -> Vec<(f64, Pose2)> {
        let poses = self
            .slam
            .as_ref()
            .map_or_else(Vec::new, GraphSlam::poses_in_map);
        self.host_times_s.iter().copied().zip(poses).collect()
    }

    /// Totals so far.
    pub fn stats(&self) -> SlamStats {
        self.slam
            .as_ref()
            .map_or_else(SlamStats::default, GraphSlam::stats)
    }

    /// The global occupancy grid from every scan at its current pose.
    pub fn render(&self) -> MapExport {
        let poses = self
            .slam
            .as_ref()
            .map_or_else(Vec::new, GraphSlam::poses_in_map);
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
