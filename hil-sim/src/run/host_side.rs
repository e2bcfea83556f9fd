//! The robot computer's side of a run: reads the host link through the same
//! [`LinkSession`] as `robot-host` (decoding, counters, clock sync by pings), feeds every
//! sensor event to the host library's pipeline ([`Estimator`]), and tells each scan that
//! arrives apart from the ones the sensor sent (intact, or not the same: damaged and yet
//! accepted).

use std::collections::VecDeque;
use std::io;

use host::link::{LinkSession, SensorEvent};
use host::slam::SlamTimings;
use protocol::{GpsFixMsg, MeasuringMode, Message, ScanMsg, StatusMsg};

use super::camera_feed::CameraFrame;
use super::estimator::Estimator;
use crate::world::RobotState;

/// A camera frame the pipeline was given, and the camera's truth then.
#[derive(Debug, Clone, Copy)]
pub struct CameraRecord {
    /// Host time of the frame, s.
    pub t_s: f64,
    /// The camera's true position, world frame, m.
    pub position_m: nalgebra::Vector3<f64>,
    /// The camera's true `world_from_camera`.
    pub orientation: nalgebra::UnitQuaternion<f64>,
}

/// A scan telegram the sensor sent, as the sim saw it leave.
#[derive(Debug, Clone)]
pub struct SentScan {
    /// The range words as the firmware would forward them.
    pub values: Vec<u16>,
    /// The robot's true state when the scan was measured.
    pub truth: RobotState,
}

/// One scan the host received and matched to what the sensor sent.
#[derive(Debug, Clone, Copy)]
pub struct ScanRecord {
    /// Host time of the scan, s.
    pub t_s: f64,
    /// The host's estimate `[x_m, y_m, theta_rad]`, once [`HostSide::finish`] ran.
    pub estimate: [f64; 3],
    /// Scans the pipeline had placed when this one was fed (its pose is the last of them), or,
    /// for a pipeline that places scans later, up to this one's host time.
    placed: usize,
    /// The truth.
    pub truth: RobotState,
}

/// A scan as the host decoded it, without the board's time stamp.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DecodedScan {
    /// The board's count of valid scans.
    pub scan_counter: u32,
    /// The range words.
    pub values: Vec<u16>,
}

/// What the host has seen so far.
pub struct HostSide {
    session: LinkSession,
    estimator: Estimator,
    /// Scans sent and not yet seen by the host, oldest first.
    sent: VecDeque<SentScan>,
    /// Every scan received intact, in order.
    pub records: Vec<ScanRecord>,
    /// Every scan received, in order.
    pub scans: Vec<DecodedScan>,
    /// Every GPS fix message received, in order, with its board time stamp set to 0.
    pub fixes: Vec<GpsFixMsg>,
    /// Scans received that match nothing the sensor sent.
    pub scans_not_sent: u64,
    /// Gaps in the board's scan counter: scans the board accepted that did not arrive.
    pub scan_counter_gaps: u64,
    last_scan_counter: u32,
    /// GPS epochs with a position received.
    pub fixes_with_position: u64,
    last_fix_time: Option<protocol::TimeOfDay>,
    /// The latest status report.
    pub status: Option<StatusMsg>,
    /// Whether the estimates are in the local frame at the datum (aligned to GPS), once
    /// [`HostSide::finish`] ran; else in the frame of the robot's first pose.
    pub geo_referenced: bool,
    /// Bytes thrown away while the link was unplugged.
    pub bytes_while_unplugged: u64,
    /// Wall time the pipeline took over each scan, in order, microseconds.
    pub scan_step_us: Vec<u32>,
    /// Every camera frame the pipeline took, in order (the camera method).
    pub camera_records: Vec<CameraRecord>,
    /// Wall time the pipeline took over each camera frame, in order, microseconds.
    pub frame_step_us: Vec<u32>,
    /// The grid method's time by part once the first [`TIMING_WINDOW`] scans were handed
    /// over (or fewer, while there were fewer).
    pub slam_parts_after_first_scans: Option<SlamTimings>,
    /// The same after each of the last [`TIMING_WINDOW`] + 1 scans, oldest first: the
    /// front, subtracted from the back, is the time the last scans took by part.
    slam_parts_after_last_scans: VecDeque<SlamTimings>,
}

/// Scans in the first and last windows whose time `performance.json` compares.
pub const TIMING_WINDOW: usize = 1000;

impl core::fmt::Debug for HostSide {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HostSide")
            .field("stats", &self.session.link_stats())
            .field("records", &self.records.len())
            .finish_non_exhaustive()
    }
}

impl HostSide {
    /// Where the grid method's SLAM spent its time so far ([`Estimator::slam_timings`]).
    pub fn slam_timings(&self) -> Option<SlamTimings> {
        self.estimator.slam_timings()
    }

    /// Where the grid method's SLAM spent its time over the last [`TIMING_WINDOW`] scans
    /// (all of them while there were fewer), by part.
    pub fn slam_timings_of_last_scans(&self) -> Option<SlamTimings> {
        let last = self.slam_parts_after_last_scans.back()?;
        let before = if self.scan_step_us.len() > TIMING_WINDOW {
            *self.slam_parts_after_last_scans.front()?
        } else {
            SlamTimings::default()
        };
        Some(last.since(&before))
    }

    /// What the grid method's SLAM did so far ([`Estimator::slam_stats`]).
    pub fn slam_stats(&self) -> Option<host::slam::SlamStats> {
        self.estimator.slam_stats()
    }

    /// What the EKF method did so far ([`Estimator::ekf_stats`]).
    pub fn ekf_stats(&self) -> Option<host::ekf_slam::EkfPipelineStats> {
        self.estimator.ekf_stats()
    }

    /// The landmarks the EKF method mapped ([`Estimator::mapped_landmarks`]).
    pub fn mapped_landmarks(&self) -> Vec<host::ekf_slam::MappedLandmark> {
        self.estimator.mapped_landmarks()
    }

    /// A host that has received nothing, estimating with `estimator`.
    pub fn new(estimator: Estimator) -> HostSide {
        HostSide {
            session: LinkSession::new(MeasuringMode::DEFAULT),
            estimator,
            sent: VecDeque::new(),
            records: Vec::new(),
            scans: Vec::new(),
            fixes: Vec::new(),
            scans_not_sent: 0,
            scan_counter_gaps: 0,
            last_scan_counter: 0,
            fixes_with_position: 0,
            last_fix_time: None,
            status: None,
            geo_referenced: false,
            bytes_while_unplugged: 0,
            scan_step_us: Vec::new(),
            camera_records: Vec::new(),
            frame_step_us: Vec::new(),
            slam_parts_after_first_scans: None,
            slam_parts_after_last_scans: VecDeque::new(),
        }
    }

    /// The sensor sent a scan.
    pub fn scan_sent(&mut self, scan: SentScan) {
        self.sent.push_back(scan);
    }

    /// Bytes from the board arrived at host time `now_s`.
    pub fn feed(&mut self, bytes: &[u8], now_s: f64) {
        let decoded = self.session.feed(bytes, now_s);
        // The session makes one event per scan and fix message, in the same order.
        let mut events = decoded.events.into_iter();
        for (received, _) in decoded.messages {
            match received.message {
                Message::Scan(scan) => {
                    if let Some(event) = events.next() {
                        self.on_scan(&scan, &event);
                    }
                }
                Message::GpsFix(fix) => {
                    // A receiver reports one epoch in several sentences (RMC, GGA, …).
                    if fix.position.is_some() && fix.time != self.last_fix_time {
                        self.fixes_with_position += 1;
                        self.last_fix_time = fix.time;
                    }
                    if let Some(event) = events.next() {
                        self.estimator.on_event(&event);
                    }
                    self.fixes.push(GpsFixMsg { stamp_us: 0, ..fix });
                }
                Message::Status(status) => self.status = Some(status),
                _ => {}
            }
        }
    }

    /// The robot computer's camera took `frame` (stamped on the host clock): the camera
    /// method takes it; the others have no camera.
    pub fn camera_frame(&mut self, frame: CameraFrame) {
        let started = std::time::Instant::now();
        if self.estimator.on_camera_frame(frame.t_s, &frame.image) {
            let step_us = started.elapsed().as_micros();
            self.frame_step_us
                .push(u32::try_from(step_us).unwrap_or(u32::MAX));
            self.camera_records.push(CameraRecord {
                t_s: frame.t_s,
                position_m: frame.position_m,
                orientation: frame.orientation,
            });
        }
    }

    /// The camera method, when it runs.
    pub fn camera_pipeline(&self) -> Option<&host::camera::CameraPipeline> {
        self.estimator.camera_pipeline()
    }

    /// The link was unplugged and plugged back in: a partial frame is forgotten.
    pub fn reconnected(&mut self) {
        self.session.reconnected();
    }

    /// A time-sync ping to send at host time `now_s`, encoded for the wire.
    pub fn ping(&mut self, now_s: f64) -> Vec<u8> {
        self.session.ping(now_s)
    }

    /// A status request, encoded for the wire.
    pub fn status_request(&mut self) -> Vec<u8> {
        self.session
            .encode(&Message::RequestStatus(protocol::RequestStatusCmd))
    }

    /// Counters of the link reader.
    pub fn link_stats(&self) -> host::link::LinkStats {
        self.session.link_stats()
    }

    /// Ends the run: the pipeline finishes, and each scan record takes its pose as the
    /// pipeline holds it at the end: the pose of the scan itself, or of the newest one placed
    /// before it when the pipeline skipped it.
    ///
    /// # Errors
    /// The pipeline's trajectory cannot be read back.
    pub fn finish(&mut self) -> io::Result<()> {
        self.estimator.finish();
        self.geo_referenced = self.estimator.is_geo_referenced();
        let trajectory = self.estimator.trajectory()?;
        if let Some(times_s) = self.estimator.placed_times_s()? {
            // Placed later than fed: a scan's pose is the newest placed at its host time.
            for record in &mut self.records {
                record.placed = times_s.partition_point(|&t| t <= record.t_s);
            }
        }
        for record in &mut self.records {
            record.estimate = record
                .placed
                .checked_sub(1)
                .and_then(|last| trajectory.get(last))
                .copied()
                .unwrap_or_default();
        }
        Ok(())
    }

    /// A scan message and the session's event for it.
    fn on_scan(&mut self, scan: &ScanMsg, event: &SensorEvent) {
        let t_s = event.host_time_s();
        // Every scan the link delivers goes to the pipeline, as in the daemon.
        let started = std::time::Instant::now();
        self.estimator.on_event(event);
        let step_us = started.elapsed().as_micros();
        self.scan_step_us
            .push(u32::try_from(step_us).unwrap_or(u32::MAX));
        if let Some(parts) = self.estimator.slam_timings() {
            if self.scan_step_us.len() <= TIMING_WINDOW {
                self.slam_parts_after_first_scans = Some(parts);
            }
            if self.slam_parts_after_last_scans.len() > TIMING_WINDOW {
                self.slam_parts_after_last_scans.pop_front();
            }
            self.slam_parts_after_last_scans.push_back(parts);
        }
        self.scans.push(DecodedScan {
            scan_counter: scan.scan_counter,
            values: scan.values.to_vec(),
        });
        let expected = self.last_scan_counter.wrapping_add(1);
        self.scan_counter_gaps += u64::from(scan.scan_counter.wrapping_sub(expected));
        self.last_scan_counter = scan.scan_counter;
        let Some(index) = self
            .sent
            .iter()
            .position(|sent| sent.values[..] == scan.values[..])
        else {
            self.scans_not_sent += 1;
            return;
        };
        // Everything sent before it did not arrive.
        self.sent.drain(..index);
        let Some(sent) = self.sent.pop_front() else {
            return;
        };
        self.records.push(ScanRecord {
            t_s,
            estimate: [0.0; 3],
            placed: self.estimator.trajectory_len(),
            truth: sent.truth,
        });
    }
}
