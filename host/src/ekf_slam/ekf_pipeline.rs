//! Method 1 on the board link's events: trees found in each scan drive the EKF with local
//! maps, and GPS fixes put the map into a local metric frame at the datum and then update it.
//!
//! The board carries no odometry, so the robot moves by the constant-velocity model between
//! scans; time differences come from the board's stamps, so a replay gives the same
//! estimates as the live run whatever the host's speed.

use nalgebra::{Matrix2, Matrix3};

use super::frames::compose_pose;
use super::{
    ConstantVelocityModel, GpsAnchor, GpsAnchorOptions, GpsOutcome, LandmarkObservation,
    RangeBearingModel, SubmapSlam, SubmapSlamOptions,
};
use crate::georef::{GpsMeasurement, GpsMeasurementOptions, LocalFrame};
use crate::landmarks::{FeatureKind, FrontEndOptions, extract_features};
use crate::link::SensorEvent;

/// A time step longer than this (a gap in the scans) is not predicted across in one go: the
/// constant-velocity guess would run away, s.
const MAX_PREDICT_S: f64 = 0.5;

/// A pose estimate at a host time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedPose {
    /// Host time, seconds.
    pub time_s: f64,
    /// Robot pose in the map frame, `[x_m, y_m, theta_rad]`.
    pub pose_in_map: [f64; 3],
}

/// How the pipeline runs.
#[derive(Debug, Clone, PartialEq)]
pub struct EkfPipelineOptions {
    /// The laser's pose on the robot, `[x_m, y_m, theta_rad]` (x forward, y left).
    pub laser_in_robot: [f64; 3],
    /// The GPS antenna's position on the robot, `[x_m, y_m]`.
    pub antenna_in_robot: [f64; 2],
    /// Laser returns are used up to this range, metres.
    pub max_range_m: f64,
    /// A local map closes when it holds this many landmarks.
    pub landmarks_per_local_map: usize,
    /// `[lat_deg, lon_deg]` of the local metric frame's origin; the first fix when `None`.
    pub datum_lat_lon_deg: Option<[f64; 2]>,
}

impl Default for EkfPipelineOptions {
    fn default() -> Self {
        EkfPipelineOptions {
            laser_in_robot: [0.0; 3],
            antenna_in_robot: [0.0; 2],
            max_range_m: 40.0,
            landmarks_per_local_map: 30,
            datum_lat_lon_deg: None,
        }
    }
}

/// Totals of the pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct EkfPipelineStats {
    /// Scans used.
    pub scans: u64,
    /// Trees observed, summed over scans.
    pub tree_observations: u64,
    /// Fixes that carried a position.
    pub fixes: u64,
    /// Fixes fused as position updates.
    pub fixes_fused: u64,
    /// Fixes rejected as jumps.
    pub fixes_rejected: u64,
    /// Local maps joined into the global map.
    pub local_maps: u64,
    /// Scans whose time stamp did not advance (repeated or reordered), skipped.
    pub scans_out_of_order: u64,
}

/// EKF SLAM over the link's scans and fixes. See the [module documentation](self).
#[derive(Debug)]
pub struct EkfPipeline {
    slam: SubmapSlam<ConstantVelocityModel>,
    front_end: FrontEndOptions,
    anchor: GpsAnchor,
    frame: Option<LocalFrame>,
    gps_options: GpsMeasurementOptions,
    antenna_in_robot: [f64; 2],
    max_range_m: f64,
    last_board_time_s: Option<f64>,
    trajectory: Vec<StampedPose>,
    stats: EkfPipelineStats,
}

impl EkfPipeline {
    /// A pipeline with `options`.
    pub fn new(options: &EkfPipelineOptions) -> EkfPipeline {
        let sensor = RangeBearingModel {
            sensor_in_robot: options.laser_in_robot,
            sigma_range_m: 0.1,
            sigma_bearing_rad: 1f64.to_radians(),
        };
        let slam_options = SubmapSlamOptions {
            max_landmarks_per_local_map: options.landmarks_per_local_map,
            ..SubmapSlamOptions::default()
        };
        EkfPipeline {
            slam: SubmapSlam::new(
                ConstantVelocityModel::default(),
                sensor,
                slam_options,
                [0.0; 3],
            ),
            front_end: FrontEndOptions::default(),
            anchor: GpsAnchor::new(GpsAnchorOptions::default()),
            frame: options
                .datum_lat_lon_deg
                .and_then(|[lat, lon]| LocalFrame::new(lat, lon, 0.0).ok()),
            gps_options: GpsMeasurementOptions::default(),
            antenna_in_robot: options.antenna_in_robot,
            max_range_m: options.max_range_m,
            last_board_time_s: None,
            trajectory: Vec::new(),
            stats: EkfPipelineStats::default(),
        }
    }

    /// Uses one sensor reading.
    pub fn on_event(&mut self, event: &SensorEvent) {
        let board_time_s = event.board_time_s();
        if let Some(last) = self.last_board_time_s {
            let dt_s = board_time_s - last;
            if dt_s < 0.0 {
                if matches!(event, SensorEvent::Scan { .. }) {
                    self.stats.scans_out_of_order += 1;
                }
                return;
            }
            self.slam.predict(&(), dt_s.min(MAX_PREDICT_S));
        }
        self.last_board_time_s = Some(board_time_s);
        match event {
            SensorEvent::Scan {
                host_time_s, scan, ..
            } => {
                let features =
                    extract_features(&scan.to_range_scan(self.max_range_m), &self.front_end);
                let observations: Vec<LandmarkObservation> = features
                    .iter()
                    .filter_map(|f| match f.kind {
                        FeatureKind::Tree {
                            diameter_m,
                            occluded: false,
                            ..
                        } => Some(LandmarkObservation {
                            range_m: f.range_m,
                            bearing_rad: f.bearing_rad,
                            diameter_m: Some(diameter_m),
                        }),
                        _ => None,
                    })
                    .collect();
                self.stats.scans += 1;
                self.stats.tree_observations += observations.len() as u64;
                self.slam.observe(&observations);
                self.stats.local_maps = self.slam.stats().joins as u64;
                self.trajectory.push(StampedPose {
                    time_s: *host_time_s,
                    pose_in_map: self.slam.pose_in_map().0,
                });
            }
            SensorEvent::Fix { fix, .. } => self.on_fix(fix),
        }
    }

    fn on_fix(&mut self, fix: &protocol::GpsFixMsg) {
        let Some(position) = fix.position else {
            return;
        };
        let frame = match self.frame {
            Some(frame) => frame,
            None => match LocalFrame::new(position.lat_deg(), position.lon_deg(), 0.0) {
                Ok(frame) => *self.frame.insert(frame),
                Err(_) => return,
            },
        };
        let Ok(measurement) = GpsMeasurement::from_fix(fix, &frame, &self.gps_options) else {
            return;
        };
        self.stats.fixes += 1;
        let outcome = self.anchor.on_fix(
            &mut self.slam,
            measurement.position_in_enu_m,
            &measurement.covariance_in_enu_m2,
            self.antenna_in_robot,
        );
        match outcome {
            GpsOutcome::Aligned(enu_from_map) => {
                for stamped in &mut self.trajectory {
                    stamped.pose_in_map = compose_pose(enu_from_map, stamped.pose_in_map).0;
                }
            }
            GpsOutcome::Fused | GpsOutcome::Rejected | GpsOutcome::Paired => {}
        }
    }

    /// The robot's pose in the map frame and its covariance.
    pub fn pose(&self) -> ([f64; 3], Matrix3<f64>) {
        self.slam.pose_in_map()
    }

    /// The local metric frame, once there is a datum.
    pub fn frame(&self) -> Option<&LocalFrame> {
        self.frame.as_ref()
    }

    /// Whether the map frame is the local metric frame at the datum (the map is aligned to
    /// GPS): only then do map positions have a latitude and longitude.
    pub fn is_geo_referenced(&self) -> bool {
        self.anchor.is_aligned() && self.frame.is_some()
    }

    /// Every pose so far, one per scan.
    pub fn trajectory(&self) -> &[StampedPose] {
        &self.trajectory
    }

    /// The mapped landmarks (global map and current local map) in the map frame.
    pub fn landmarks_in_map(&self) -> Vec<[f64; 2]> {
        self.slam
            .landmarks_in_map()
            .iter()
            .map(|l| l.position_in_map)
            .collect()
    }

    /// The covariance of the landmark positions, for exports.
    pub fn landmark_covariances(&self) -> Vec<Matrix2<f64>> {
        self.slam
            .landmarks_in_map()
            .iter()
            .map(|l| l.covariance)
            .collect()
    }

    /// Totals so far.
    pub fn stats(&self) -> EkfPipelineStats {
        EkfPipelineStats {
            fixes_fused: self.anchor.fused as u64,
            fixes_rejected: self.anchor.rejected as u64,
            ..self.stats
        }
    }
}
