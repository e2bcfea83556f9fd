//! `hil-sim replay-victoria`: method 1 ([`host::ekf_slam::LandmarkSlam`], with the car's
//! odometry) over the Victoria Park run, optionally fusing its GPS, measured against that GPS.
//! This adapter only reads the files, merges the streams and writes the outputs.
//!
//! The run's three streams share one clock and are merged by time: every drive input
//! (`inputs.dat`) is held until the next event; each event first moves the filter to its time
//! with the latest input, then applies itself: a tree scan (`measurements.dat`) is one batch
//! of range-bearing-diameter observations, a GPS fix (`gps.dat`) a position update.
//!
//! With GPS the map frame becomes the frame of `gps.dat`: the filter starts in the frame of
//! the first pose, and once enough fixes (spread over [`GPS_ALIGNMENT_SPAN_M`]) pair with the
//! filter's positions, the weighted rigid alignment `enu_from_map` re-expresses the map and the
//! trajectory so far; fixes are fused from then on, each gated against the filter (the
//! receiver jumps at times).
//!
//! Outputs in the output directory:
//!
//! * `trajectory.tsv`: `t_s x_m y_m theta_rad` of the laser at each scan, estimated again
//!   once the map is finished: the run's inputs replayed against the final map's trees (and
//!   the fixes), forwards and then backwards ([`host::ekf_slam::MapSmoother`]), so stretches
//!   driven before a loop closed carry the closure's correction and the end of a GPS outage
//!   is bridged from both sides;
//! * `online_trajectory.tsv`: the same poses as the filter estimated them at the time;
//! * `landmarks.tsv`: `x_m y_m diameter_m observations sigma_x_m sigma_y_m`;
//! * `summary.json`: `wall_s`, `steps`, `landmarks`, `local_maps`, `loop_closures`, the RMS
//!   position error against `gps.dat` and the step times against the size of the map.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use host::ekf_slam::{
    AckermannGeometry, AckermannInput, AckermannModel, GpsAnchorOptions, LandmarkObservation,
    LandmarkSlam, LandmarkSlamOptions, MapSmootherStats, RangeBearingModel, SubmapSlam,
    SubmapSlamOptions, SubmapSlamStats, TimedPose,
};
use host::evaluation::{TimedPosition, error_to_gps, receiver_jumps};
use host::geometry::Pose2;
use host::georef::{GeoRefError, LandmarkInEnu, LocalFrame, write_geojson, write_kml};
use nalgebra::Matrix2;
use serde::Serialize;

use crate::replay::LogError;
use crate::replay::victoria::{CarGeometry, LocalGpsFix, VictoriaPark};

/// GPS fixes start being fused once those paired with the filter span this many metres.
pub const GPS_ALIGNMENT_SPAN_M: f64 = 30.0;
/// Distance of the laser ahead of the rear axle, metres. `info.txt` gives `a = 0.95 m`
/// (measured on a drawing that is not in the dataset); the vehicle model published with the
/// data (Guivant and Nebot 2001) puts the laser 3.78 m ahead of the axle, and the data agree:
/// with 0.95 m the first 300 s map 227 trees where 3.78 m maps 152, and the laser's track lies
/// 1.4 m RMS from the GPS where the axle's lies 4.1 m.
pub const LASER_AHEAD_M: f64 = 3.78;
/// A fix that lies further from both its neighbours than this speed could carry the car is a
/// receiver jump, metres per second (twice the run's top wheel speed, 6.6 m/s).
pub const GPS_JUMP_SPEED_MPS: f64 = 15.0;
/// Width of the map-size classes of the step-time table, landmarks.
const SIZE_CLASS_LANDMARKS: usize = 50;

/// What to run.
#[derive(Debug, Clone)]
pub struct VictoriaSlamOptions {
    /// The `rfs_slam_ascii` directory.
    pub dir: PathBuf,
    /// Where the outputs go (created if missing).
    pub out: PathBuf,
    /// Fuse the GPS fixes.
    pub use_gps: bool,
    /// Standard deviation of a GPS fix on each axis, metres.
    pub gps_sigma_m: f64,
    /// GPS fixes further than this squared Mahalanobis distance from the filter are jumps.
    pub gps_gate_distance2: f64,
    /// Trees further than this are not used, metres.
    pub max_range_m: f64,
    /// Where the origin of `gps.dat`'s metric frame lies on the Earth (the file carries no
    /// datum); with GPS fused, the map and trajectory are also written in WGS84 as
    /// `map.geojson` and `map.kml`.
    pub datum: Option<LocalFrame>,
    /// Use only the events of the first this many seconds (all when `None`).
    pub duration_s: Option<f64>,
    /// The car model.
    pub motion: AckermannModel,
    /// The laser and its noise.
    pub sensor: RangeBearingModel,
    /// The filter.
    pub slam: SubmapSlamOptions,
}

impl VictoriaSlamOptions {
    /// Defaults for the Victoria Park vehicle and its laser.
    pub fn new(dir: PathBuf, out: PathBuf) -> VictoriaSlamOptions {
        let geometry = CarGeometry::default();
        VictoriaSlamOptions {
            dir,
            out,
            use_gps: true,
            gps_sigma_m: 1.0,
            gps_gate_distance2: 25.0,
            max_range_m: 40.0,
            duration_s: None,
            datum: None,
            motion: AckermannModel {
                sigma_speed_mps: 0.5,
                sigma_steer_rad: 5f64.to_radians(),
                ..AckermannModel::new(AckermannGeometry {
                    wheelbase_m: geometry.l_m,
                    encoder_offset_m: geometry.h_m,
                })
            },
            sensor: RangeBearingModel {
                sensor_in_robot: Pose2 {
                    x_m: LASER_AHEAD_M,
                    y_m: geometry.b_m,
                    theta_rad: 0.0,
                },
                sigma_range_m: 1.0,
                sigma_bearing_rad: 3f64.to_radians(),
            },
            slam: SubmapSlamOptions::default(),
        }
    }

    /// Covariance of a GPS fix.
    fn gps_noise(&self) -> Matrix2<f64> {
        Matrix2::identity() * self.gps_sigma_m.powi(2)
    }

    /// Where on the car the fixes are taken: the laser, which the GPS track follows.
    fn antenna_in_robot(&self) -> [f64; 2] {
        [
            self.sensor.sensor_in_robot.x_m,
            self.sensor.sensor_in_robot.y_m,
        ]
    }
}

/// Step times of scans taken while the global map had a given number of landmarks.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct StepTimeClass {
    /// Landmarks in the global map, from (inclusive)…
    pub landmarks_from: usize,
    /// …to (exclusive).
    pub landmarks_to: usize,
    /// Scan steps in the class that closed no local map.
    pub steps: usize,
    /// Mean time of a scan step that closed no local map (prediction to its time, gate,
    /// JCBB, update, new landmarks), microseconds.
    pub mean_us: f64,
    /// Longest such step, microseconds.
    pub max_us: f64,
    /// Scan steps that also closed the local map and joined it.
    pub joins: usize,
    /// Mean time of those, microseconds.
    pub join_mean_us: f64,
    /// Longest of those, microseconds.
    pub join_max_us: f64,
}

/// `summary.json`.
#[derive(Debug, Clone, Serialize)]
pub struct VictoriaSlamSummary {
    /// Seconds the filter and the smoothing pass took (not reading the files or writing the
    /// outputs).
    pub wall_s: f64,
    /// Events processed: drive inputs, scans and GPS fixes.
    pub steps: usize,
    /// Scans (observation batches).
    pub scans: usize,
    /// Landmarks in the final map.
    pub landmarks: usize,
    /// Local maps joined.
    pub local_maps: usize,
    /// Joins that fused landmarks mapped two or more local maps earlier.
    pub loop_closures: usize,
    /// Whether GPS was fused.
    pub gps_used: bool,
    /// GPS fixes fused.
    pub gps_fused: usize,
    /// GPS fixes rejected by the gate.
    pub gps_rejected: usize,
    /// GPS fixes the error is measured on (those after the first filter pose).
    pub gps_compared: usize,
    /// RMS distance between the trajectory (`trajectory.tsv`, smoothed) and the GPS
    /// fixes, metres: directly when GPS was fused, after the best rigid alignment when not.
    pub rms_to_gps_m: f64,
    /// Median of the same distances, metres.
    pub median_to_gps_m: f64,
    /// Fixes of `gps.dat` that are receiver jumps by their own neighbours (further from both
    /// the previous and the next fix than [`GPS_JUMP_SPEED_MPS`] allows), whatever the filter.
    pub gps_jumps: usize,
    /// RMS distance as `rms_to_gps_m`, over the fixes that are not jumps, metres.
    pub rms_to_gps_without_jumps_m: f64,
    /// `rms_to_gps_m` of the online trajectory (each pose as estimated at its scan).
    pub online_rms_to_gps_m: f64,
    /// `median_to_gps_m` of the online trajectory.
    pub online_median_to_gps_m: f64,
    /// `rms_to_gps_without_jumps_m` of the online trajectory.
    pub online_rms_to_gps_without_jumps_m: f64,
    /// Of `wall_s`, the seconds the smoothing pass took ([`MapSmoother`]).
    pub smoothing_s: f64,
    /// Observations the smoothing pass paired with a tree of the final map.
    pub smoother_paired: usize,
    /// Observations it left out: no tree of the map within the gate, or more than one.
    pub smoother_unpaired: usize,
    /// GPS fixes it used.
    pub smoother_fixes_used: usize,
    /// Final speed scale and steering offset (radians) of the online calibration.
    pub calibration: Option<[f64; 2]>,
    /// The filter's counters.
    pub filter: FilterCounts,
    /// Scan step times by global map size.
    pub step_time_by_map_size: Vec<StepTimeClass>,
}

/// The counters of [`SubmapSlamStats`], flattened for JSON.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct FilterCounts {
    /// Observations paired with a landmark.
    pub associated: usize,
    /// Observations that started a landmark.
    pub new_landmarks: usize,
    /// Observations dropped as ambiguous.
    pub ambiguous: usize,
    /// Landmarks fused across local maps.
    pub fused: usize,
    /// Revisits confirmed by the history memory.
    pub recognised_places: usize,
    /// Of those, places the join turned down (implausible to the map, too few trees).
    pub rejected_places: usize,
    /// Updates that failed (not positive definite).
    pub failed_updates: usize,
}

impl From<SubmapSlamStats> for FilterCounts {
    fn from(stats: SubmapSlamStats) -> Self {
        FilterCounts {
            associated: stats.observations.associated,
            new_landmarks: stats.observations.new_landmarks,
            ambiguous: stats.observations.ambiguous,
            fused: stats.fused,
            recognised_places: stats.recognised_places,
            rejected_places: stats.rejected_places,
            failed_updates: stats.failed_updates,
        }
    }
}

/// Errors of the command.
#[derive(Debug, thiserror::Error)]
pub enum VictoriaSlamError {
    /// A file of the run could not be read.
    #[error(transparent)]
    Log(#[from] LogError),
    /// An output could not be written.
    #[error("writing {path}: {source}")]
    Write {
        /// The output.
        path: PathBuf,
        /// What failed.
        source: io::Error,
    },
    /// The WGS84 exports failed.
    #[error("writing the WGS84 exports: {0}")]
    GeoRef(#[from] GeoRefError),
    /// The run holds no scan.
    #[error("{0} holds no tree scan")]
    Empty(PathBuf),
}

/// One event of the merged streams.
#[derive(Debug, Clone, Copy)]
enum Event {
    Input(usize),
    Scan(usize),
    Gps(usize),
}

/// A pose of the trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
struct StampedPose {
    t_s: f64,
    pose: Pose2,
}

/// Runs the filter over the run in `options.dir` and writes the outputs.
///
/// # Errors
/// A missing or malformed input file, an unwritable output directory, a run without scans.
pub fn replay_victoria(
    options: &VictoriaSlamOptions,
) -> Result<VictoriaSlamSummary, VictoriaSlamError> {
    let park = VictoriaPark::read_dir(&options.dir)?;
    if park.scans.is_empty() {
        return Err(VictoriaSlamError::Empty(options.dir.clone()));
    }
    let run = run_filter(&park, options);
    write_outputs(options, &park, &run)
}

/// What a run produced.
struct FilterRun {
    /// Against the final map, smoothed ([`smoothed_trajectory`]).
    trajectory: Vec<StampedPose>,
    /// As estimated at each scan.
    online_trajectory: Vec<StampedPose>,
    smoother: MapSmootherStats,
    slam: SubmapSlam<AckermannModel>,
    wall_s: f64,
    smoothing_s: f64,
    steps: usize,
    gps_fused: usize,
    gps_rejected: usize,
    step_times: Vec<(usize, bool, f64)>,
}

/// Merges the streams by time: at equal times inputs first, then scans, then fixes.
fn merged_events(park: &VictoriaPark, use_gps: bool) -> Vec<(f64, Event)> {
    let mut events: Vec<(f64, Event)> = park
        .inputs
        .iter()
        .enumerate()
        .map(|(i, input)| (input.t_s, Event::Input(i)))
        .chain(
            park.scans
                .iter()
                .enumerate()
                .map(|(i, s)| (s.t_s, Event::Scan(i))),
        )
        .chain(
            park.gps
                .iter()
                .enumerate()
                .filter(|_| use_gps)
                .map(|(i, fix)| (fix.t_s, Event::Gps(i))),
        )
        .collect();
    let rank = |event: &Event| match event {
        Event::Input(_) => 0,
        Event::Scan(_) => 1,
        Event::Gps(_) => 2,
    };
    events.sort_by(|a, b| a.0.total_cmp(&b.0).then(rank(&a.1).cmp(&rank(&b.1))));
    events
}

fn run_filter(park: &VictoriaPark, options: &VictoriaSlamOptions) -> FilterRun {
    let mut events = merged_events(park, options.use_gps);
    if let (Some(duration_s), Some(&(first_s, _))) = (options.duration_s, events.first()) {
        events.retain(|e| e.0 <= first_s + duration_s);
    }
    let started = Instant::now();
    let mut method = LandmarkSlam::new(
        options.motion,
        options.sensor,
        LandmarkSlamOptions {
            slam: options.slam,
            gps: GpsAnchorOptions {
                alignment_span_m: GPS_ALIGNMENT_SPAN_M,
                gate_distance2: options.gps_gate_distance2,
                ..GpsAnchorOptions::default()
            },
            antenna_in_robot: options.antenna_in_robot(),
            // The trajectory is the laser's, which the GPS track follows.
            reported_in_robot: Some(options.sensor.sensor_in_robot),
            ..LandmarkSlamOptions::default()
        },
    );
    if let Some(&(first_s, _)) = events.first() {
        method.start_at(first_s);
    }
    let mut step_times = Vec::with_capacity(park.scans.len());
    let gps_noise = options.gps_noise();
    for &(t_s, event) in &events {
        match event {
            Event::Input(i) => {
                method.on_input(t_s, drive_input(park, i));
            }
            Event::Scan(i) => {
                let step_started = Instant::now();
                let observations = scan_observations(park, i, options);
                let landmarks = method.slam().global_landmark_count();
                let joins = method.slam().stats().joins;
                method.on_observations(t_s, &observations);
                let joined = method.slam().stats().joins != joins;
                step_times.push((landmarks, joined, step_started.elapsed().as_secs_f64()));
            }
            Event::Gps(i) => {
                let fix = park.gps[i];
                method.on_fix(t_s, [fix.x_m, fix.y_m], &gps_noise);
            }
        }
    }
    let filtered_s = started.elapsed().as_secs_f64();
    method.finish();
    let wall_s = started.elapsed().as_secs_f64();
    let stamped = |poses: &[TimedPose]| -> Vec<StampedPose> {
        poses
            .iter()
            .map(|p| StampedPose {
                t_s: p.t_s,
                pose: p.pose_in_map,
            })
            .collect()
    };
    FilterRun {
        trajectory: stamped(method.trajectory()),
        online_trajectory: stamped(method.online_trajectory()),
        smoother: method.smoother_stats().unwrap_or_default(),
        slam: method.slam().clone(),
        wall_s,
        smoothing_s: wall_s - filtered_s,
        steps: events.len(),
        gps_fused: method.anchor().fused,
        gps_rejected: method.anchor().rejected,
        step_times,
    }
}

/// The car's drive input number `i`.
fn drive_input(park: &VictoriaPark, i: usize) -> AckermannInput {
    AckermannInput {
        wheel_speed_mps: park.inputs[i].speed_mps,
        steer_rad: park.inputs[i].steer_rad,
    }
}

/// One scan's tree detections as observations, those beyond the range limit left out.
fn scan_observations(
    park: &VictoriaPark,
    scan: usize,
    options: &VictoriaSlamOptions,
) -> Vec<LandmarkObservation> {
    park.scans[scan]
        .detections
        .iter()
        .filter(|d| d.range_m <= options.max_range_m && d.range_m > 0.0)
        .map(|d| LandmarkObservation {
            range_m: d.range_m,
            // The file's bearings run 0..π with π/2 straight ahead.
            bearing_rad: d.bearing_rad - std::f64::consts::FRAC_PI_2,
            diameter_m: Some(d.diameter_m),
        })
        .collect()
}

/// A fix of `gps.dat` as a timed position for [`host::evaluation`].
fn timed_fix(fix: &LocalGpsFix) -> TimedPosition {
    TimedPosition {
        t_s: fix.t_s,
        position_m: [fix.x_m, fix.y_m],
    }
}

/// The trajectory's positions for [`host::evaluation`].
fn positions(trajectory: &[StampedPose]) -> Vec<TimedPosition> {
    trajectory
        .iter()
        .map(|p| TimedPosition {
            t_s: p.t_s,
            position_m: [p.pose.x_m, p.pose.y_m],
        })
        .collect()
}

/// Step times grouped by map size.
fn step_time_classes(step_times: &[(usize, bool, f64)]) -> Vec<StepTimeClass> {
    let largest = step_times.iter().map(|s| s.0).max().unwrap_or(0);
    let stats = |times: &[f64]| {
        let mean = times.iter().sum::<f64>() / times.len().max(1) as f64;
        (mean, times.iter().copied().fold(0.0, f64::max))
    };
    (0..=largest / SIZE_CLASS_LANDMARKS)
        .filter_map(|class| {
            let from = class * SIZE_CLASS_LANDMARKS;
            let to = from + SIZE_CLASS_LANDMARKS;
            let in_class = |joined: bool| -> Vec<f64> {
                step_times
                    .iter()
                    .filter(|s| s.0 >= from && s.0 < to && s.1 == joined)
                    .map(|s| s.2 * 1e6)
                    .collect()
            };
            let (steps, joins) = (in_class(false), in_class(true));
            if steps.is_empty() && joins.is_empty() {
                return None;
            }
            let (mean_us, max_us) = stats(&steps);
            let (join_mean_us, join_max_us) = stats(&joins);
            Some(StepTimeClass {
                landmarks_from: from,
                landmarks_to: to,
                steps: steps.len(),
                mean_us,
                max_us,
                joins: joins.len(),
                join_mean_us,
                join_max_us,
            })
        })
        .collect()
}

fn write_outputs(
    options: &VictoriaSlamOptions,
    park: &VictoriaPark,
    run: &FilterRun,
) -> Result<VictoriaSlamSummary, VictoriaSlamError> {
    let write_error = |path: &Path| {
        let path = path.to_path_buf();
        move |source| VictoriaSlamError::Write { path, source }
    };
    fs::create_dir_all(&options.out).map_err(write_error(&options.out))?;
    let slam = run.slam.clone();
    let calibration = (options.motion.calibrate).then(|| {
        let robot = slam.robot_in_local_map();
        [robot[3], robot[4]]
    });
    let (global, stats) = slam.finish();
    let state = global.state();

    for (name, trajectory) in [
        ("trajectory.tsv", &run.trajectory),
        ("online_trajectory.tsv", &run.online_trajectory),
    ] {
        let path = options.out.join(name);
        let mut out = BufWriter::new(fs::File::create(&path).map_err(write_error(&path))?);
        for stamped in trajectory {
            let Pose2 {
                x_m: x,
                y_m: y,
                theta_rad: theta,
            } = stamped.pose;
            writeln!(out, "{:.3}\t{x:.4}\t{y:.4}\t{theta:.6}", stamped.t_s)
                .map_err(write_error(&path))?;
        }
        out.flush().map_err(write_error(&path))?;
    }

    let path = options.out.join("landmarks.tsv");
    let mut out = BufWriter::new(fs::File::create(&path).map_err(write_error(&path))?);
    writeln!(
        out,
        "# x_m\ty_m\tdiameter_m\tobservations\tsigma_x_m\tsigma_y_m"
    )
    .map_err(write_error(&path))?;
    for (i, info) in global.landmark_info().iter().enumerate() {
        let [x, y] = state.landmark(i);
        let covariance = state.landmark_covariance(i);
        writeln!(
            out,
            "{x:.4}\t{y:.4}\t{:.3}\t{}\t{:.4}\t{:.4}",
            info.diameter_m.unwrap_or(f64::NAN),
            info.observations,
            covariance[(0, 0)].max(0.0).sqrt(),
            covariance[(1, 1)].max(0.0).sqrt()
        )
        .map_err(write_error(&path))?;
    }
    out.flush().map_err(write_error(&path))?;

    if let (Some(frame), true) = (&options.datum, options.use_gps) {
        let trajectory_in_enu: Vec<[f64; 2]> = run
            .trajectory
            .iter()
            .map(|p| [p.pose.x_m, p.pose.y_m])
            .collect();
        let landmarks: Vec<LandmarkInEnu> = global
            .landmark_info()
            .iter()
            .enumerate()
            .map(|(i, info)| LandmarkInEnu {
                id: Some(i as u64),
                position_in_enu_m: state.landmark(i),
                diameter_m: info.diameter_m,
            })
            .collect();
        let path = options.out.join("map.geojson");
        let file = fs::File::create(&path).map_err(write_error(&path))?;
        write_geojson(BufWriter::new(file), frame, &trajectory_in_enu, &landmarks)?;
        let path = options.out.join("map.kml");
        let file = fs::File::create(&path).map_err(write_error(&path))?;
        write_kml(BufWriter::new(file), frame, &trajectory_in_enu, &landmarks)?;
    }

    let align = !options.use_gps;
    let fixes: Vec<TimedPosition> = park.gps.iter().map(timed_fix).collect();
    let jumps = receiver_jumps(&fixes, GPS_JUMP_SPEED_MPS);
    let steady: Vec<TimedPosition> = fixes
        .iter()
        .zip(&jumps)
        .filter(|(_, jump)| !**jump)
        .map(|(fix, _)| *fix)
        .collect();
    let smoothed = positions(&run.trajectory);
    let online = positions(&run.online_trajectory);
    let to_gps = error_to_gps(&smoothed, &fixes, align);
    let online_to_gps = error_to_gps(&online, &fixes, align);
    let summary = VictoriaSlamSummary {
        wall_s: run.wall_s,
        steps: run.steps,
        scans: stats.scans,
        landmarks: global.landmark_info().len(),
        local_maps: stats.joins,
        loop_closures: stats.loop_closures,
        gps_used: options.use_gps,
        gps_fused: run.gps_fused,
        gps_rejected: run.gps_rejected,
        gps_compared: to_gps.compared,
        rms_to_gps_m: to_gps.rms_m,
        median_to_gps_m: to_gps.median_m,
        gps_jumps: jumps.iter().filter(|&&jump| jump).count(),
        rms_to_gps_without_jumps_m: error_to_gps(&smoothed, &steady, align).rms_m,
        online_rms_to_gps_m: online_to_gps.rms_m,
        online_median_to_gps_m: online_to_gps.median_m,
        online_rms_to_gps_without_jumps_m: error_to_gps(&online, &steady, align).rms_m,
        smoothing_s: run.smoothing_s,
        smoother_paired: run.smoother.paired,
        smoother_unpaired: run.smoother.unpaired,
        smoother_fixes_used: run.smoother.fixes_used,
        calibration,
        filter: stats.into(),
        step_time_by_map_size: step_time_classes(&run.step_times),
    };
    let path = options.out.join("summary.json");
    let json = serde_json::to_string_pretty(&summary).map_err(|e| VictoriaSlamError::Write {
        path: path.clone(),
        source: io::Error::other(e),
    })?;
    fs::write(&path, json + "\n").map_err(write_error(&path))?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lone_far_fix_is_a_jump_and_a_gap_is_not() {
        let fix = |t_s: f64, x_m: f64| LocalGpsFix { t_s, x_m, y_m: 0.0 };
        let gps = [
            fix(0.0, 0.0),
            fix(0.2, 0.6),
            fix(0.4, 140.0), // 700 m/s from both neighbours
            fix(0.6, 1.8),
            fix(40.0, 120.0), // 40 s outage at 3 m/s: plausible
            fix(40.2, 120.6),
        ];
        let fixes: Vec<TimedPosition> = gps.iter().map(timed_fix).collect();
        assert_eq!(
            receiver_jumps(&fixes, GPS_JUMP_SPEED_MPS),
            [false, false, true, false, false, false]
        );
    }
}
