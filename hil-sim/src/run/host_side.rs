//! The robot computer's side of a run: reads the host link as `robot-host` does, keeps the
//! clock in sync with pings, feeds every scan and fix to the host library's pipeline
//! ([`Estimator`]), and tells each scan that arrives apart from the ones the sensor sent
//! (intact, or not the same: damaged and yet accepted).

use std::collections::VecDeque;

use std::sync::Arc;

use host::link::{GpsFix, LaserScan, LinkReader, SensorEvent, TimeSync};
use protocol::{Encoder, GpsFixMsg, MAX_WIRE_LEN, MeasuringMode, Message, ScanMsg, StatusMsg};

use super::estimator::Estimator;
use crate::world::RobotState;

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
    /// Scans the pipeline had placed when this one was fed (its pose is the last of them).
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
    reader: LinkReader,
    sync: TimeSync,
    encoder: Encoder,
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
}

impl core::fmt::Debug for HostSide {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HostSide")
            .field("stats", &self.reader.stats())
            .field("records", &self.records.len())
            .finish_non_exhaustive()
    }
}

impl HostSide {
    /// A host that has received nothing, estimating with `estimator`.
    pub fn new(estimator: Estimator) -> HostSide {
        HostSide {
            reader: LinkReader::new(),
            sync: TimeSync::new(),
            encoder: Encoder::new(),
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
        }
    }

    /// The sensor sent a scan.
    pub fn scan_sent(&mut self, scan: SentScan) {
        self.sent.push_back(scan);
    }

    /// Bytes from the board arrived at host time `now_s`.
    pub fn feed(&mut self, bytes: &[u8], now_s: f64) {
        for received in self.reader.feed(bytes) {
            self.sync.observe(&received.message, now_s);
            match received.message {
                Message::Scan(scan) => self.on_scan(&scan),
                Message::GpsFix(fix) => {
                    // A receiver reports one epoch in several sentences (RMC, GGA, …).
                    if fix.position.is_some() && fix.time != self.last_fix_time {
                        self.fixes_with_position += 1;
                        self.last_fix_time = fix.time;
                    }
                    self.estimator.on_event(&SensorEvent::Fix {
                        host_time_s: self.sync.clock().to_host_s(fix.stamp_us),
                        board_time_s: fix.stamp_us as f64 * 1e-6,
                        fix: GpsFix::from_msg(&fix),
                    });
                    self.fixes.push(GpsFixMsg { stamp_us: 0, ..fix });
                }
                Message::Status(status) => self.status = Some(status),
                _ => {}
            }
        }
    }

    /// The link was unplugged and plugged back in: a partial frame is forgotten.
    pub fn reconnected(&mut self) {
        self.reader.reconnected();
    }

    /// A time-sync ping to send at host time `now_s`, encoded for the wire.
    pub fn ping(&mut self, now_s: f64) -> Vec<u8> {
        let seq = self.encoder.next_seq();
        let ping = self.sync.ping(seq, now_s);
        self.encode(&ping)
    }

    /// A status request, encoded for the wire.
    pub fn status_request(&mut self) -> Vec<u8> {
        self.encode(&Message::RequestStatus(protocol::RequestStatusCmd))
    }

    /// Counters of the link reader.
    pub fn link_stats(&self) -> host::link::LinkStats {
        self.reader.stats()
    }

    fn encode(&mut self, message: &Message) -> Vec<u8> {
        let mut out = [0u8; MAX_WIRE_LEN];
        self.encoder
            .encode(message, &mut out)
            .map(<[u8]>::to_vec)
            .unwrap_or_default()
    }

    /// Ends the run: the pipeline finishes, and each scan record takes its pose as the
    /// pipeline holds it at the end.
    pub fn finish(&mut self) {
        self.estimator.finish();
        self.geo_referenced = self.estimator.is_geo_referenced();
        let trajectory = self.estimator.trajectory();
        for record in &mut self.records {
            record.estimate = record
                .placed
                .checked_sub(1)
                .and_then(|last| trajectory.get(last))
                .copied()
                .unwrap_or_default();
        }
    }

    fn on_scan(&mut self, scan: &ScanMsg) {
        let t_s = self.sync.clock().to_host_s(scan.stamp_us);
        // Every scan the link delivers goes to the pipeline, as in the daemon.
        self.estimator.on_event(&SensorEvent::Scan {
            host_time_s: t_s,
            board_time_s: scan.stamp_us as f64 * 1e-6,
            scan_counter: scan.scan_counter,
            scan: Arc::new(LaserScan::from_msg(scan, MeasuringMode::DEFAULT)),
        });
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
