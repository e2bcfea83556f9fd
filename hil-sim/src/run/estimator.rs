//! The host's pose estimate during a run: the host library's pipelines, with the daemon's
//! default configuration, fed the link's sensor events as the daemon feeds them.
//!
//! Indoors (and for CARMEN logs and raw captures) method 2 runs
//! ([`host::slam::GridPipeline`]); outdoors (and for Victoria Park) method 1
//! ([`host::ekf_slam::EkfPipeline`]) with GPS, whose map becomes the local frame at the
//! world's datum once it is aligned to the fixes. With the camera (`--method camera`,
//! outdoors) the camera method runs ([`host::camera::CameraPipeline`]) on the frames the
//! robot computer's camera takes and the fixes from the board; the laser's scans are only
//! given the camera's pose at their time.

use std::io;

use host::camera::{
    CameraPipeline, CameraPipelineOptions, ForwardMotionPrior, LevelPrior, MonoSlamOptions,
    PinholeCamera,
};
use host::ekf_slam::{EkfPipeline, EkfPipelineStats, MappedLandmark};
use host::geometry::Pose2;
use host::link::SensorEvent;
use host::scan_match::ScanMatchError;
use host::slam::{GridPipeline, SlamStats, SlamTimings};
use robot_host::config::SlamConfig;

/// Which of the two methods estimates the pose. See the [module documentation](self).
#[derive(Debug)]
pub enum Estimator {
    /// Method 2: scan matching against occupancy-grid submaps with loop closure.
    Grid(Box<GridPipeline>),
    /// Method 1: EKF SLAM on trees with local maps, aligned to and updated by GPS.
    Ekf(Box<EkfPipeline>),
    /// Method 1 on the camera, aligned to GPS; the host times of the scans, whose poses it
    /// gives from the camera's.
    Camera {
        pipeline: Box<CameraPipeline>,
        scan_times_s: Vec<f64>,
    },
}

impl Estimator {
    /// Method 2 with the daemon's default configuration (its motion filter on,
    /// [`host::slam::motion_filter`]), or with every scan a node of the map when
    /// `every_scan`.
    ///
    /// # Errors
    /// The configuration's scan-matcher options are invalid.
    pub fn grid(every_scan: bool) -> Result<Estimator, ScanMatchError> {
        let mut options = SlamConfig::default().grid_pipeline_options();
        if every_scan {
            options.slam.motion_filter.enabled = false;
        }
        Ok(Estimator::Grid(Box::new(GridPipeline::new(options)?)))
    }

    /// Method 1 with the daemon's default configuration, its local metric frame at
    /// `datum_lat_lon_deg`.
    pub fn ekf(datum_lat_lon_deg: [f64; 2]) -> Estimator {
        let options = SlamConfig::default().ekf_pipeline_options(Some(datum_lat_lon_deg));
        Estimator::Ekf(Box::new(EkfPipeline::new(&options)))
    }

    /// The camera method with `camera`, held `level` (`None`: not held level), its motion
    /// held to its optical axis by `forward_motion` (`None`: not), the fixes fused into its
    /// filter with `fuse_gps`, its local metric frame at `datum_lat_lon_deg`.
    ///
    /// # Errors
    /// The datum is not a latitude and longitude.
    pub fn camera(
        camera: PinholeCamera,
        level: Option<LevelPrior>,
        forward_motion: Option<ForwardMotionPrior>,
        fuse_gps: bool,
        datum_lat_lon_deg: [f64; 2],
    ) -> io::Result<Estimator> {
        let defaults = CameraPipelineOptions::default();
        let options = CameraPipelineOptions {
            datum_lat_lon_deg: Some(datum_lat_lon_deg),
            fuse_gps,
            slam: MonoSlamOptions {
                level,
                forward_motion,
                ..defaults.slam
            },
            ..defaults
        };
        let pipeline = CameraPipeline::new(camera, options).map_err(io::Error::other)?;
        Ok(Estimator::Camera {
            pipeline: Box::new(pipeline),
            scan_times_s: Vec::new(),
        })
    }

    /// Uses one sensor event.
    pub fn on_event(&mut self, event: &SensorEvent) {
        match self {
            Estimator::Grid(pipeline) => pipeline.on_event(event),
            Estimator::Ekf(pipeline) => pipeline.on_event(event),
            Estimator::Camera {
                pipeline,
                scan_times_s,
            } => {
                if let SensorEvent::Scan { host_time_s, .. } = event {
                    scan_times_s.push(*host_time_s);
                }
                pipeline.on_event(event);
            }
        }
    }

    /// Uses one camera frame taken at host time `t_s`; `false` where the method has no
    /// camera.
    pub fn on_camera_frame(&mut self, t_s: f64, image: &image::GrayImage) -> bool {
        match self {
            Estimator::Camera { pipeline, .. } => pipeline.on_frame(t_s, image).is_some(),
            _ => false,
        }
    }

    /// The camera method, when it runs.
    pub fn camera_pipeline(&self) -> Option<&CameraPipeline> {
        match self {
            Estimator::Camera { pipeline, .. } => Some(pipeline),
            _ => None,
        }
    }

    /// Where the grid method's SLAM spent its time so far, part by part; `None` for the EKF.
    pub fn slam_timings(&self) -> Option<SlamTimings> {
        match self {
            Estimator::Grid(pipeline) => Some(pipeline.timings()),
            Estimator::Ekf(_) | Estimator::Camera { .. } => None,
        }
    }

    /// What the grid method's SLAM did so far (nodes, searches, closures, solves); `None` for
    /// the EKF.
    pub fn slam_stats(&self) -> Option<SlamStats> {
        match self {
            Estimator::Grid(pipeline) => Some(pipeline.stats()),
            Estimator::Ekf(_) | Estimator::Camera { .. } => None,
        }
    }

    /// What the EKF method did so far; `None` for the other methods.
    pub fn ekf_stats(&self) -> Option<EkfPipelineStats> {
        match self {
            Estimator::Ekf(pipeline) => Some(pipeline.stats()),
            Estimator::Grid(_) | Estimator::Camera { .. } => None,
        }
    }

    /// Ends the run: the grid method's final refinement, the EKF method's last join.
    pub fn finish(&mut self) {
        match self {
            Estimator::Grid(pipeline) => pipeline.finish(),
            Estimator::Ekf(pipeline) => pipeline.finish(),
            Estimator::Camera { .. } => {}
        }
    }

    /// The pose `[x_m, y_m, theta_rad]` of every scan the pipeline placed, as it holds them
    /// now, in the order the scans came (the EKF skips a scan whose time stamp goes back).
    ///
    /// # Errors
    /// The EKF pipeline's trajectory cannot be read back from its temporary file.
    pub fn trajectory(&self) -> io::Result<Vec<[f64; 3]>> {
        let entries = |p: &Pose2| [p.x_m, p.y_m, p.theta_rad];
        Ok(match self {
            Estimator::Grid(pipeline) => pipeline.poses_in_map().iter().map(entries).collect(),
            Estimator::Ekf(pipeline) => pipeline
                .trajectory()?
                .iter()
                .map(|p| entries(&p.pose_in_map))
                .collect(),
            Estimator::Camera {
                pipeline,
                scan_times_s,
            } => scan_times_s
                .iter()
                .map(|&t| pipeline.pose_at(t).map_or([0.0; 3], |p| entries(&p)))
                .collect(),
        })
    }

    /// The host time of every scan the pipeline placed, in the order of
    /// [`Self::trajectory`], for a pipeline that places a scan later than it is given (the
    /// EKF holds events to take them in board-time order); `None` when each scan is placed
    /// as it comes.
    ///
    /// # Errors
    /// The EKF pipeline's trajectory cannot be read back from its temporary file.
    pub fn placed_times_s(&self) -> io::Result<Option<Vec<f64>>> {
        Ok(match self {
            Estimator::Ekf(pipeline) => {
                Some(pipeline.trajectory()?.iter().map(|p| p.time_s).collect())
            }
            Estimator::Grid(_) | Estimator::Camera { .. } => None,
        })
    }

    /// The landmarks the EKF method mapped (none for the other methods), in the frame of
    /// [`Self::trajectory`].
    pub fn mapped_landmarks(&self) -> Vec<MappedLandmark> {
        match self {
            Estimator::Ekf(pipeline) => pipeline.mapped_landmarks(),
            Estimator::Grid(_) | Estimator::Camera { .. } => Vec::new(),
        }
    }

    /// How many scans the pipeline has placed so far.
    pub fn trajectory_len(&self) -> usize {
        match self {
            Estimator::Grid(pipeline) => pipeline.scan_count(),
            Estimator::Ekf(pipeline) => pipeline.scans_placed(),
            Estimator::Camera { scan_times_s, .. } => scan_times_s.len(),
        }
    }

    /// Whether the map frame is the local frame at the datum (aligned to GPS) rather than
    /// the robot's first pose.
    pub fn is_geo_referenced(&self) -> bool {
        match self {
            Estimator::Grid(_) => false,
            Estimator::Ekf(pipeline) => pipeline.is_geo_referenced(),
            Estimator::Camera { pipeline, .. } => pipeline.is_geo_referenced(),
        }
    }
}
