//! `summary.json` of a run: what was emitted, what arrived, what the system counted as lost,
//! what was injected, and how far the host's estimate is from the truth.

use host::geometry::{Pose2, wrap_angle_rad};
use serde::Serialize;

use super::RunOptions;
use super::engine::{Engine, EventsInjected};
use super::pipeline_timing::PipelineTiming;
use crate::emulators::StreamStart;
use crate::faults::InjectedFaults;
use crate::world::{RobotState, World};

/// The summary of one run. The first seven fields are the accounting.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// Scan telegrams that left the laser (whole, or cut short by a power cycle).
    pub telegrams_emitted: u64,
    /// Scans the host received with exactly the values the laser sent.
    pub telegrams_delivered_intact: u64,
    /// Scans counted as lost by the firmware (`missed`) and the host (scan-counter gaps).
    pub telegrams_counted_rejected: u64,
    /// GPS epochs the receiver sent with a fix.
    pub gps_fixes_emitted: u64,
    /// GPS fixes with a position the host received.
    pub gps_fixes_delivered: u64,
    /// Frames missing on the host link (sequence gaps).
    pub frames_lost_on_link: u64,
    /// Panics in the firmware.
    pub panics: u32,
    /// Whether `telegrams_delivered_intact + telegrams_counted_rejected == telegrams_emitted`.
    pub accounting_balanced: bool,
    /// World kind.
    pub world: String,
    /// Seed.
    pub seed: u64,
    /// Virtual seconds of sensor output.
    pub duration_s: f64,
    /// The faults asked for, in `--faults` syntax.
    pub faults: String,
    /// What was injected.
    pub injected: Injected,
    /// What the firmware and host counted.
    pub counted: Counted,
    /// The host's estimate against the truth.
    pub estimate: EstimateError,
    /// The EKF method's landmark map against the world's trees (a simulated outdoor world).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub map: Option<super::map_quality::MapQuality>,
    /// The camera method's path against the camera's truth (`--method camera`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera: Option<super::camera_outcome::CameraOutcome>,
    /// Each stream of scans the laser began: when, and when its first scan went out.
    pub laser_streams: Vec<StreamStart>,
    /// Wall-clock seconds the run took; not written, as everything written is deterministic.
    #[serde(skip)]
    pub wall_s: f64,
    /// How long the pipeline took per scan; written to `performance.json` instead.
    #[serde(skip)]
    pub pipeline: PipelineTiming,
}

/// What the faults did.
#[derive(Debug, Clone, Serialize)]
pub struct Injected {
    /// Byte faults on the laser line.
    pub laser: InjectedFaults,
    /// Byte faults on the GPS line.
    pub gps: InjectedFaults,
    /// Scan telegrams cut short by a power cycle.
    pub scan_telegrams_cut_by_restart: u64,
    /// Scan telegrams the laser cut short because the board sent a request (not a fault:
    /// the sensor's own behaviour, §5).
    pub scan_telegrams_interrupted: u64,
    /// Events.
    pub events: EventsInjected,
}

/// What the system counted.
#[derive(Debug, Clone, Serialize)]
pub struct Counted {
    /// Firmware: scans missed (scan periods between valid scans, or with bytes but no valid
    /// scan).
    pub firmware_scans_missed: u32,
    /// Firmware: laser telegrams whose CRC failed.
    pub firmware_laser_crc_errors: u32,
    /// Firmware: laser receiver resynchronisations.
    pub firmware_laser_resyncs: u32,
    /// Firmware: frames dropped for a full outbox (all sources).
    pub firmware_frames_dropped: u32,
    /// Firmware: GPS lines rejected.
    pub firmware_gps_lines_rejected: u32,
    /// Host: gaps in the board's scan counter.
    pub host_scan_counter_gaps: u64,
    /// Host: scans that match nothing the laser sent (damaged yet accepted).
    pub host_scans_not_sent: u64,
    /// Host: frames received.
    pub host_frames: u64,
    /// Host: frames rejected (CRC, COBS, size, malformed).
    pub host_bad_frames: u64,
    /// Host: bytes discarded while the link was unplugged.
    pub host_bytes_while_unplugged: u64,
    /// The laser's final state, as the board reported it.
    pub final_laser_state: String,
    /// Whether the board's final status report arrived.
    pub final_status_received: bool,
}

/// Position and heading error of the estimate, the truth expressed in the same `map` frame.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct EstimateError {
    /// Scans with an estimate.
    pub scans: usize,
    /// Root mean square position error, m.
    pub rms_position_m: f64,
    /// Position error at the last scan, m.
    pub final_position_m: f64,
    /// Root mean square heading error, rad.
    pub rms_heading_rad: f64,
    /// Distance travelled, m.
    pub travelled_m: f64,
}

/// `truth` in the map frame whose origin is `origin` (the truth at the first scan).
pub fn in_map(origin: Option<RobotState>, truth: &RobotState) -> [f64; 3] {
    let truth_in_world = Pose2::new(truth.x_m, truth.y_m, truth.theta_rad);
    let truth_in_map = match origin {
        Some(o) => Pose2::new(o.x_m, o.y_m, o.theta_rad)
            .inverse()
            .compose(truth_in_world),
        None => truth_in_world,
    };
    [truth_in_map.x_m, truth_in_map.y_m, truth_in_map.theta_rad]
}

/// The world position of `point_in_map`, a position in the map frame whose origin is
/// `origin` (the truth at the first scan; `None`: the map frame is the world frame).
pub fn world_from_map(origin: Option<RobotState>, point_in_map: [f64; 2]) -> [f64; 2] {
    origin.map_or(point_in_map, |o| {
        Pose2::new(o.x_m, o.y_m, o.theta_rad).transform_point(point_in_map)
    })
}

impl RunSummary {
    /// The summary of a finished run.
    pub fn new<W: World>(options: &RunOptions, engine: &Engine<'_, W>, wall_s: f64) -> Self {
        let host = &engine.host;
        let status = host.status;
        let laser = status.map(|s| s.laser).unwrap_or_default();
        let gps = status.map(|s| s.gps).unwrap_or_default();
        let link = host.link_stats();
        let emitted = engine.sent.scan_telegrams;
        let intact = host.records.len() as u64;
        let rejected = u64::from(laser.missed) + host.scan_counter_gaps;
        let (laser_injected, gps_injected) = engine.injected();
        let dropped = laser
            .dropped_frames
            .wrapping_add(gps.dropped_frames)
            .wrapping_add(status.map_or(0, |s| s.host.dropped_frames));
        RunSummary {
            telegrams_emitted: emitted,
            telegrams_delivered_intact: intact,
            telegrams_counted_rejected: rejected,
            gps_fixes_emitted: u64::from(engine.sensors().gps.counters().fixes),
            gps_fixes_delivered: host.fixes_with_position,
            frames_lost_on_link: link.lost,
            panics: engine.panics(),
            accounting_balanced: intact + rejected == emitted,
            world: options.world.to_string(),
            seed: options.seed,
            duration_s: options.duration_s,
            faults: options.faults.to_string(),
            injected: Injected {
                laser: laser_injected,
                gps: gps_injected,
                scan_telegrams_cut_by_restart: engine.sent.scan_telegrams_cut,
                scan_telegrams_interrupted: engine.sent.scan_telegrams_interrupted,
                events: engine.events,
            },
            counted: Counted {
                firmware_scans_missed: laser.missed,
                firmware_laser_crc_errors: laser.crc_errors,
                firmware_laser_resyncs: laser.resyncs,
                firmware_frames_dropped: dropped,
                firmware_gps_lines_rejected: gps.missed,
                host_scan_counter_gaps: host.scan_counter_gaps,
                host_scans_not_sent: host.scans_not_sent,
                host_frames: link.frames,
                host_bad_frames: link.crc_errors
                    + link.cobs_errors
                    + link.oversize
                    + link.truncated
                    + link.malformed,
                host_bytes_while_unplugged: host.bytes_while_unplugged,
                final_laser_state: status
                    .map_or("unknown".into(), |s| format!("{:?}", s.laser_state)),
                final_status_received: status.is_some(),
            },
            estimate: estimate_error(&host.records, host.geo_referenced),
            map: None,
            camera: host.camera_pipeline().map(|pipeline| {
                super::camera_outcome::CameraOutcome::new(pipeline, &host.camera_records)
            }),
            laser_streams: engine.sensors().lms.stream_starts().to_vec(),
            wall_s,
            pipeline: PipelineTiming {
                peak_resident_mib: super::pipeline_timing::peak_resident_mib(),
                slam_parts_s: host.slam_timings(),
                slam_parts_first_1000_s: host.slam_parts_after_first_scans,
                slam_parts_last_1000_s: host.slam_timings_of_last_scans(),
                slam_work: host.slam_stats(),
                ekf_work: host.ekf_stats(),
                camera_frames: (!host.frame_step_us.is_empty())
                    .then(|| Box::new(PipelineTiming::from_step_times(&host.frame_step_us))),
                ..PipelineTiming::from_step_times(&host.scan_step_us)
            },
        }
    }
}

/// The error of `records`' estimates, in the frame of the first scan's true pose, or in the
/// world frame (the local frame at its datum) when the estimates are `geo_referenced`.
fn estimate_error(records: &[super::host_side::ScanRecord], geo_referenced: bool) -> EstimateError {
    let origin = records.first().map(|r| r.truth).filter(|_| !geo_referenced);
    let mut sum_sq_m = 0.0;
    let mut sum_sq_rad = 0.0;
    let mut final_position_m = 0.0;
    let mut travelled_m = 0.0;
    let mut previous: Option<[f64; 3]> = None;
    for record in records {
        let truth = in_map(origin, &record.truth);
        let [x, y, theta] = record.estimate;
        let error_m = (x - truth[0]).hypot(y - truth[1]);
        sum_sq_m += error_m * error_m;
        sum_sq_rad += wrap_angle_rad(theta - truth[2]).powi(2);
        final_position_m = error_m;
        if let Some(p) = previous {
            travelled_m += (truth[0] - p[0]).hypot(truth[1] - p[1]);
        }
        previous = Some(truth);
    }
    let n = records.len().max(1) as f64;
    EstimateError {
        scans: records.len(),
        rms_position_m: (sum_sq_m / n).sqrt(),
        final_position_m,
        rms_heading_rad: (sum_sq_rad / n).sqrt(),
        travelled_m,
    }
}
