//! Method 1 on the board link's events: trees found in each scan drive the EKF with local
//! maps, and GPS fixes put the map into a local metric frame at the datum and then update it.
//!
//! The method itself is [`LandmarkSlam`]; this adapter finds the trees in each scan and turns
//! fixes into `enu` measurements. The board carries no odometry, so the robot moves by the
//! constant-velocity model between scans; time differences come from the board's stamps, so
//! a replay gives the same estimates as the live run whatever the host's speed.
//!
//! Events reach the filter in the order the board stamped them: a [`BoardTimeOrder`] holds
//! each for [`EkfPipelineOptions::reorder_window_s`], because a fix is sent a sentence after
//! its stamp and may arrive after a scan stamped later (the estimate lags by the window). A
//! receiver reports each epoch in several sentences (GGA, RMC, ...); the filter takes one per
//! epoch, the one that says most about its error (GST sigmas, else HDOP).

use nalgebra::{Matrix2, Matrix3};

use std::io;

use super::{
    ConstantVelocityModel, GpsOutcome, LandmarkObservation, LandmarkSlam, LandmarkSlamOptions,
    MappedLandmark, PoseHistory, PoseHistoryOptions, RangeBearingModel, SubmapSlamOptions,
};
use crate::geometry::Pose2;
use crate::georef::{GpsMeasurement, GpsMeasurementOptions, LocalFrame};
use crate::landmarks::{FeatureKind, FrontEndOptions, extract_features};
use crate::link::{BoardTimeOrder, GpsFix, SensorEvent, board_time_order};

/// A time step longer than this (a gap in the scans) is not predicted across in one go: the
/// constant-velocity guess would run away, s.
const MAX_PREDICT_S: f64 = 0.5;

/// A pose estimate at a host time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedPose {
    /// Host time, seconds.
    pub time_s: f64,
    /// Robot pose in the map frame.
    pub pose_in_map: Pose2,
}

/// How the pipeline runs.
#[derive(Debug, Clone, PartialEq)]
pub struct EkfPipelineOptions {
    /// The laser's pose on the robot (x forward, y left).
    pub laser_in_robot: Pose2,
    /// The GPS antenna's position on the robot, `[x_m, y_m]`.
    pub antenna_in_robot: [f64; 2],
    /// Laser returns are used up to this range, metres.
    pub max_range_m: f64,
    /// A local map closes when it holds this many landmarks.
    pub landmarks_per_local_map: usize,
    /// `[lat_deg, lon_deg]` of the local metric frame's origin; the first fix when `None`.
    pub datum_lat_lon_deg: Option<[f64; 2]>,
    /// How the trajectory is kept: the newest poses in memory, older ones in a file.
    pub trajectory: PoseHistoryOptions,
    /// How long an event is held to be put in board-time order, s
    /// ([`board_time_order::DEFAULT_WINDOW_S`]); 0 takes events as they come.
    pub reorder_window_s: f64,
}

impl Default for EkfPipelineOptions {
    fn default() -> Self {
        EkfPipelineOptions {
            laser_in_robot: Pose2::IDENTITY,
            antenna_in_robot: [0.0; 2],
            max_range_m: 40.0,
            landmarks_per_local_map: 30,
            datum_lat_lon_deg: None,
            trajectory: PoseHistoryOptions::default(),
            reorder_window_s: board_time_order::DEFAULT_WINDOW_S,
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
    /// Scans whose time stamp did not advance (repeated, or later than the reorder window),
    /// skipped.
    pub scans_out_of_order: u64,
    /// Further reports of a GPS epoch already taken (a receiver reports one epoch in several
    /// sentences), not used again.
    pub fixes_repeated: u64,
}

/// EKF SLAM over the link's scans and fixes. See the [module documentation](self).
#[derive(Debug)]
pub struct EkfPipeline {
    method: LandmarkSlam<ConstantVelocityModel>,
    front_end: FrontEndOptions,
    frame: Option<LocalFrame>,
    gps_options: GpsMeasurementOptions,
    max_range_m: f64,
    /// The pose at each scan the method used, at the scan's host time, bounded in memory.
    trajectory: PoseHistory,
    /// Events waiting to be used in board-time order.
    order: BoardTimeOrder,
    /// The UTC epoch (s since midnight) of the last fix handed to the method, and that
    /// report's [`report_rank`].
    last_epoch: Option<(f64, u8)>,
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
        let method_options = LandmarkSlamOptions {
            slam: SubmapSlamOptions {
                max_landmarks_per_local_map: options.landmarks_per_local_map,
                ..SubmapSlamOptions::default()
            },
            antenna_in_robot: options.antenna_in_robot,
            max_predict_s: MAX_PREDICT_S,
            // The smoothing pass holds the model's own entries at their final values: right
            // for odometry calibration, wrong for the constant-velocity model's velocity.
            smooth: false,
            keep_trajectory: false,
            ..LandmarkSlamOptions::default()
        };
        EkfPipeline {
            method: LandmarkSlam::new(ConstantVelocityModel::default(), sensor, method_options),
            front_end: FrontEndOptions::default(),
            frame: options
                .datum_lat_lon_deg
                .and_then(|[lat, lon]| LocalFrame::new(lat, lon, 0.0).ok()),
            gps_options: GpsMeasurementOptions::default(),
            max_range_m: options.max_range_m,
            trajectory: PoseHistory::new(options.trajectory.clone()),
            order: BoardTimeOrder::new(options.reorder_window_s),
            last_epoch: None,
            stats: EkfPipelineStats::default(),
        }
    }

    /// Takes one sensor reading; it is used once the reorder window has passed it (see the
    /// [module documentation](self)). Time differences come from the board's stamps.
    pub fn on_event(&mut self, event: &SensorEvent) {
        if let SensorEvent::Fix { fix, .. } = event
            && self.is_repeated_report(fix)
        {
            self.stats.fixes_repeated += 1;
            return;
        }
        for due in self.order.push(event.clone()) {
            self.use_event(&due);
        }
    }

    /// Whether `fix` reports an epoch already taken or held; a held report of the epoch is
    /// replaced by `fix` when `fix` says more about its error. A report that says more than
    /// the one already taken (which may have given no measurement at all: an RMC without
    /// HDOP, its GGA arriving after the window) is used as well.
    fn is_repeated_report(&mut self, fix: &GpsFix) -> bool {
        let Some(epoch_s) = fix.utc_time_s else {
            return false;
        };
        if let Some((taken_s, taken_rank)) = self.last_epoch
            && taken_s == epoch_s
        {
            return report_rank(fix) <= taken_rank;
        }
        for held in self.order.pending_mut() {
            if let SensorEvent::Fix { fix: held_fix, .. } = held
                && held_fix.utc_time_s == Some(epoch_s)
            {
                // The held report keeps its stamp and its place in the order.
                if report_rank(fix) > report_rank(held_fix) {
                    *held_fix = *fix;
                }
                return true;
            }
        }
        false
    }

    /// Uses one reading, in board-time order.
    fn use_event(&mut self, event: &SensorEvent) {
        match event {
            SensorEvent::Scan {
                host_time_s,
                board_time_s,
                scan,
                ..
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
                if !self.method.on_observations(*board_time_s, &observations) {
                    self.stats.scans_out_of_order += 1;
                    return;
                }
                self.trajectory.push(StampedPose {
                    time_s: *host_time_s,
                    pose_in_map: self.method.reported_pose(),
                });
                self.stats.scans += 1;
                self.stats.tree_observations += observations.len() as u64;
                self.stats.local_maps = self.method.slam().stats().joins as u64;
            }
            SensorEvent::Fix {
                board_time_s, fix, ..
            } => {
                if let Some(epoch_s) = fix.utc_time_s {
                    self.last_epoch = Some((epoch_s, report_rank(fix)));
                }
                self.on_fix(*board_time_s, fix);
            }
        }
    }

    /// A fix: a position update (or a step of the alignment to GPS) when it makes a
    /// measurement; else the filter only moves to its time, as for any event.
    fn on_fix(&mut self, board_time_s: f64, fix: &GpsFix) {
        match GpsMeasurement::in_frame_or_first(fix, &mut self.frame, &self.gps_options) {
            Ok(measurement) => {
                let used = self.method.on_fix(
                    board_time_s,
                    measurement.position_in_enu_m,
                    &measurement.covariance_in_enu_m2,
                );
                if let Some(GpsOutcome::Aligned(enu_from_map)) = used {
                    self.trajectory.transform(enu_from_map);
                }
                if used.is_some() {
                    self.stats.fixes += 1;
                }
            }
            Err(_) => {
                self.method.advance_to(board_time_s);
            }
        }
    }

    /// Ends the run: the events still held are used, then the last local map is joined into
    /// the global map ([`LandmarkSlam::finish`]).
    pub fn finish(&mut self) {
        for event in self.order.drain() {
            self.use_event(&event);
        }
        self.method.finish();
    }

    /// The robot's pose in the map frame and its covariance.
    pub fn pose(&self) -> (Pose2, Matrix3<f64>) {
        self.method.pose()
    }

    /// The local metric frame, once there is a datum.
    pub fn frame(&self) -> Option<&LocalFrame> {
        self.frame.as_ref()
    }

    /// Whether the map frame is the local metric frame at the datum (the map is aligned to
    /// GPS): only then do map positions have a latitude and longitude.
    pub fn is_geo_referenced(&self) -> bool {
        self.method.is_aligned() && self.frame.is_some()
    }

    /// The pose at the newest scan placed.
    pub fn last_pose(&self) -> Option<StampedPose> {
        self.trajectory.last()
    }

    /// At most a few thousand poses of the trajectory, evenly spaced, the newest among them:
    /// what a live view draws ([`PoseHistory::thinned`]).
    pub fn thinned_trajectory(&self) -> impl Iterator<Item = StampedPose> + '_ {
        self.trajectory.thinned()
    }

    /// Scans the pipeline has placed (one trajectory pose each).
    pub fn scans_placed(&self) -> usize {
        self.trajectory.len()
    }

    /// Every pose so far, one per scan used, at the scan's host time, as estimated at the
    /// time (re-expressed in the `enu` frame once aligned to GPS). Older poses are read back
    /// from the history's temporary file.
    ///
    /// # Errors
    /// The temporary file cannot be read back, or failed when the map was aligned to GPS
    /// (then its poses were not re-expressed).
    pub fn trajectory(&self) -> io::Result<Vec<StampedPose>> {
        self.trajectory.to_vec()
    }

    /// The mapped landmarks (global map and current local map) in the map frame, with their
    /// covariances and what else is known of them (diameter, observations).
    pub fn mapped_landmarks(&self) -> Vec<MappedLandmark> {
        self.method.landmarks_in_map()
    }

    /// The mapped landmarks (global map and current local map) in the map frame.
    pub fn landmarks_in_map(&self) -> Vec<[f64; 2]> {
        self.method
            .landmarks_in_map()
            .iter()
            .map(|l| l.position_in_map)
            .collect()
    }

    /// The covariance of the landmark positions, for exports.
    pub fn landmark_covariances(&self) -> Vec<Matrix2<f64>> {
        self.method
            .landmarks_in_map()
            .iter()
            .map(|l| l.covariance)
            .collect()
    }

    /// Totals so far.
    pub fn stats(&self) -> EkfPipelineStats {
        EkfPipelineStats {
            fixes_fused: self.method.anchor().fused as u64,
            fixes_rejected: self.method.anchor().rejected as u64,
            ..self.stats
        }
    }
}

/// How much a fix report says about its own error: a GST error estimate over an HDOP over
/// neither; a report without a position says nothing.
fn report_rank(fix: &GpsFix) -> u8 {
    if !fix.has_position() {
        0
    } else if fix.error_ellipse.is_some() || fix.lat_lon_sigma_m.is_some() {
        3
    } else if fix.hdop.is_some() {
        2
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use protocol::{FixQuality, FixSource};

    use super::*;
    use crate::link::LaserScan;

    fn scan(board_time_s: f64) -> SensorEvent {
        SensorEvent::Scan {
            host_time_s: board_time_s,
            board_time_s,
            scan_counter: 0,
            scan: Arc::new(LaserScan {
                ranges_m: vec![f64::NAN; 181],
                first_angle_rad: -std::f64::consts::FRAC_PI_2,
                angle_step_rad: 1f64.to_radians(),
            }),
        }
    }

    /// A report of the epoch `utc_time_s`, stamped at `board_time_s`, with an HDOP or not.
    fn fix(
        board_time_s: f64,
        utc_time_s: f64,
        source: FixSource,
        hdop: Option<f64>,
    ) -> SensorEvent {
        SensorEvent::Fix {
            host_time_s: board_time_s,
            board_time_s,
            fix: GpsFix {
                source,
                utc_time_s: Some(utc_time_s),
                quality: FixQuality::Gps,
                lat_lon_deg: Some([48.1, 11.5]),
                height_m: None,
                satellites: Some(8),
                hdop,
                error_ellipse: None,
                lat_lon_sigma_m: None,
                speed_mps: None,
                course_rad: None,
            },
        }
    }

    fn run(options: &EkfPipelineOptions, events: &[SensorEvent]) -> EkfPipelineStats {
        let mut pipeline = EkfPipeline::new(options);
        for event in events {
            pipeline.on_event(event);
        }
        pipeline.finish();
        pipeline.stats()
    }

    /// Scans every 0.1 s; each second's fix is stamped 0.05 s after a scan but arrives after
    /// the next one.
    fn fix_behind_a_later_scan() -> Vec<SensorEvent> {
        let mut events = Vec::new();
        for second in 0..3 {
            let t0 = f64::from(second);
            events.push(scan(t0));
            events.push(scan(t0 + 0.1));
            events.push(fix(t0 + 0.05, 3600.0 + t0, FixSource::Gga, Some(1.0)));
            events.extend((2..10).map(|i| scan(t0 + 0.1 * f64::from(i))));
        }
        events
    }

    #[test]
    fn a_fix_that_arrives_after_a_later_scan_is_used_in_its_place() {
        let stats = run(&EkfPipelineOptions::default(), &fix_behind_a_later_scan());
        assert_eq!(
            (stats.scans, stats.scans_out_of_order),
            (30, 0),
            "{stats:?}"
        );
        assert_eq!(stats.fixes, 3, "{stats:?}");
        // Taken as they come, each fix is older than the filter's time and goes unused.
        let as_they_come = EkfPipelineOptions {
            reorder_window_s: 0.0,
            ..EkfPipelineOptions::default()
        };
        let stats = run(&as_they_come, &fix_behind_a_later_scan());
        assert_eq!(stats.fixes, 0, "{stats:?}");
    }

    #[test]
    fn one_report_per_epoch_the_one_with_an_hdop() {
        let mut events = Vec::new();
        for second in 0..3 {
            let t0 = f64::from(second);
            let epoch_s = 3600.0 + t0;
            events.push(scan(t0));
            // The RMC first (no HDOP), then the GGA of the same epoch.
            events.push(fix(t0 + 0.01, epoch_s, FixSource::Rmc, None));
            events.push(fix(t0 + 0.08, epoch_s, FixSource::Gga, Some(1.0)));
            events.extend((1..10).map(|i| scan(t0 + 0.1 * f64::from(i))));
            // A late repeat of the epoch, after it was used.
            events.push(fix(t0 + 0.95, epoch_s, FixSource::Gll, None));
        }
        let stats = run(&EkfPipelineOptions::default(), &events);
        assert_eq!(stats.fixes_repeated, 6, "{stats:?}");
        // The GGA's HDOP gives the measurement its covariance; an RMC alone has none.
        assert_eq!(stats.fixes, 3, "{stats:?}");
        assert_eq!(stats.scans_out_of_order, 0, "{stats:?}");
    }

    #[test]
    fn a_better_report_after_the_window_is_still_used() {
        let as_they_come = EkfPipelineOptions {
            reorder_window_s: 0.0,
            ..EkfPipelineOptions::default()
        };
        let mut events = Vec::new();
        for second in 0..3 {
            let t0 = f64::from(second);
            events.push(scan(t0));
            // The RMC is taken at once and gives no measurement (no HDOP); its GGA does.
            events.push(fix(t0 + 0.01, 3600.0 + t0, FixSource::Rmc, None));
            events.push(fix(t0 + 0.08, 3600.0 + t0, FixSource::Gga, Some(1.0)));
            events.push(fix(t0 + 0.09, 3600.0 + t0, FixSource::Gll, None));
        }
        let stats = run(&as_they_come, &events);
        assert_eq!((stats.fixes, stats.fixes_repeated), (3, 3), "{stats:?}");
    }
}
