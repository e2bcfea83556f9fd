//! One board link as the host sees it: bytes in, sensor events out, with the clock mapping
//! and the counters. The live reader and the replay of a recording drive the same session,
//! so a replay decodes, times and counts exactly what the live run did.
//!
//! A board that restarts (a brown-out, a watchdog, a reflash) starts its clock again at zero.
//! The session notices a stamp far behind the newest it has seen, counts the restart, drops
//! the old boot's clock mapping, and carries the board time on: the events' `board_time_s`
//! continue from the last boot's newest stamp by the host time that passed, so a filter that
//! steps by board time never sees it go back.

use std::sync::Arc;

use protocol::{Decoder, Encoder, MAX_WIRE_LEN, MeasuringMode, Message, Received, StatusMsg};

use super::LinkCounters;
use super::{GpsFix, LaserScan, LinkReader, TimeSync};

/// A sensor reading for the SLAM pipelines, in SI units and host time.
#[derive(Debug, Clone)]
pub enum SensorEvent {
    /// One laser scan.
    Scan {
        /// Host time of the scan's first byte, seconds.
        host_time_s: f64,
        /// Board time of the scan's first byte, seconds since the board started (continued
        /// across restarts, see the [module documentation](self)): what the pipelines take time
        /// differences of (it does not depend on when the host read it).
        board_time_s: f64,
        /// The board's scan counter.
        scan_counter: u32,
        /// The ranges in the sensor frame.
        scan: Arc<LaserScan>,
    },
    /// One GPS fix.
    Fix {
        /// Host time of the fix's first byte, seconds.
        host_time_s: f64,
        /// Board time, seconds since the board started (continued across restarts).
        board_time_s: f64,
        /// The fix as the board parsed it, in SI units.
        fix: GpsFix,
    },
}

impl SensorEvent {
    /// The event's board time, seconds.
    pub fn board_time_s(&self) -> f64 {
        match self {
            SensorEvent::Scan { board_time_s, .. } | SensorEvent::Fix { board_time_s, .. } => {
                *board_time_s
            }
        }
    }

    /// The event's host time, seconds.
    pub fn host_time_s(&self) -> f64 {
        match self {
            SensorEvent::Scan { host_time_s, .. } | SensorEvent::Fix { host_time_s, .. } => {
                *host_time_s
            }
        }
    }
}

/// What one read of bytes gave.
#[derive(Debug, Default)]
pub struct Decoded {
    /// Every message decoded, for the recording, with its host time when the clock is
    /// synchronised.
    pub messages: Vec<(Received, Option<f64>)>,
    /// The sensor readings among them.
    pub events: Vec<SensorEvent>,
}

/// The decoding side of one board link. See the [module documentation](self).
#[derive(Debug)]
pub struct LinkSession {
    reader: LinkReader,
    sync: TimeSync,
    encoder: Encoder,
    mode: MeasuringMode,
    counters: LinkCounters,
    last_status: Option<StatusMsg>,
    /// The newest board stamp of the current boot, µs, and the host time it was read at.
    newest_stamp: Option<(u64, f64)>,
    /// What the current boot's stamps are shifted by to continue the earlier boots', µs.
    boot_offset_us: u64,
}

/// A stamp this far behind the newest of the boot means the board restarted its clock, µs:
/// far beyond the board's own reordering (a scan is sent up to 0.2 s after its stamp, a
/// status report at once), and short enough to see a board that restarted after 2 s.
const RESTART_BEHIND_US: u64 = 2_000_000;

impl LinkSession {
    /// A session for a laser whose range words are coded in measuring `mode`.
    pub fn new(mode: MeasuringMode) -> LinkSession {
        LinkSession {
            reader: LinkReader::new(),
            sync: TimeSync::new(),
            encoder: Encoder::new(),
            mode,
            counters: LinkCounters::default(),
            last_status: None,
            newest_stamp: None,
            boot_offset_us: 0,
        }
    }

    /// Feeds bytes read at host time `recv_s`.
    pub fn feed(&mut self, bytes: &[u8], recv_s: f64) -> Decoded {
        let mut decoded = Decoded::default();
        for received in self.reader.feed(bytes) {
            if let Some(stamp_us) = board_clock_us(&received.message) {
                self.note_board_clock(stamp_us, recv_s);
            }
            let boot_offset_us = self.boot_offset_us;
            let board_time_s =
                |stamp_us: u64| boot_offset_us.saturating_add(stamp_us) as f64 * 1e-6;
            self.sync.observe(&received.message, recv_s);
            let clock = self.sync.clock();
            let host_time = |stamp_us: u64| {
                if clock.is_synchronised() {
                    clock.to_host_s(stamp_us)
                } else {
                    recv_s
                }
            };
            match &received.message {
                Message::Scan(msg) => {
                    self.counters.telegrams += 1;
                    decoded.events.push(SensorEvent::Scan {
                        host_time_s: host_time(msg.stamp_us),
                        board_time_s: board_time_s(msg.stamp_us),
                        scan_counter: msg.scan_counter,
                        scan: Arc::new(LaserScan::from_msg(msg, self.mode)),
                    });
                }
                Message::GpsFix(fix) => {
                    self.counters.gps_fixes += 1;
                    self.counters.gps_fix_quality = fix.quality.gga_digit();
                    // RMC and GLL fixes carry no satellite count: the last GGA's stands.
                    if let Some(satellites) = fix.num_sats {
                        self.counters.gps_satellites = satellites;
                    }
                    decoded.events.push(SensorEvent::Fix {
                        host_time_s: host_time(fix.stamp_us),
                        board_time_s: board_time_s(fix.stamp_us),
                        fix: GpsFix::from_msg(fix),
                    });
                }
                Message::Status(status) => {
                    self.counters.telegram_crc_errors = u64::from(status.laser.crc_errors);
                    self.last_status = Some(*status);
                }
                _ => {}
            }
            let stamp = message_stamp_us(&received.message)
                .filter(|_| clock.is_synchronised())
                .map(|us| clock.to_host_s(us));
            decoded.messages.push((received, stamp));
        }
        let stats = self.reader.stats();
        self.counters.frames = stats.frames;
        self.counters.frames_lost = stats.lost;
        self.counters.crc_errors = stats.crc_errors;
        self.counters.clock_synchronised = self.sync.clock().is_synchronised();
        decoded
    }

    /// Follows the board's clock through `stamp_us`, read at host time `recv_s`: a stamp far
    /// behind the newest is a restart (see the [module documentation](self)).
    fn note_board_clock(&mut self, stamp_us: u64, recv_s: f64) {
        match self.newest_stamp {
            Some((newest_us, newest_recv_s))
                if stamp_us.saturating_add(RESTART_BEHIND_US) < newest_us =>
            {
                // The new boot's stamp comes after the old boot's newest by the host time
                // between them (at least 1 µs).
                let elapsed_us = ((recv_s - newest_recv_s).max(0.0) * 1e6).round() as u64;
                self.boot_offset_us = self
                    .boot_offset_us
                    .saturating_add(newest_us)
                    .saturating_add(elapsed_us.saturating_sub(stamp_us).max(1));
                self.newest_stamp = Some((stamp_us, recv_s));
                self.sync = TimeSync::new();
                self.counters.board_restarts += 1;
            }
            Some((newest_us, _)) if stamp_us <= newest_us => {}
            _ => self.newest_stamp = Some((stamp_us, recv_s)),
        }
    }

    /// The time-sync ping to send at host time `now_s`, encoded as a frame.
    pub fn ping(&mut self, now_s: f64) -> Vec<u8> {
        let ping = self.sync.ping(self.encoder.next_seq(), now_s);
        self.encode(&ping)
    }

    /// Encodes a command to the board as a frame.
    pub fn encode(&mut self, message: &Message) -> Vec<u8> {
        let mut out = [0u8; MAX_WIRE_LEN];
        match self.encoder.encode(message, &mut out) {
            Ok(frame) => frame.to_vec(),
            // Commands are small and fixed: a failure is a bug in the command, not input.
            Err(_) => Vec::new(),
        }
    }

    /// Registers frames this host sent at `sent_s`, read back from a recording: a replayed
    /// session matches the board's acknowledgements to the same pings as the live one.
    pub fn replay_sent(&mut self, frames: &[u8], sent_s: f64) {
        let mut decoder = Decoder::new();
        for &b in frames {
            if let Some(Ok(received)) = decoder.push(b)
                && matches!(received.message, Message::TimeSyncPing(_))
            {
                self.sync.ping(received.header.seq, sent_s);
            }
        }
    }

    /// Forgets a partial frame after the port was reopened; counts the reconnect.
    pub fn reconnected(&mut self) {
        self.reader.reconnected();
        self.counters.reconnects += 1;
    }

    /// The counters so far.
    pub fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// The board's last status report.
    pub fn last_status(&self) -> Option<&StatusMsg> {
        self.last_status.as_ref()
    }

    /// The link reader's full accounting.
    pub fn link_stats(&self) -> super::LinkStats {
        self.reader.stats()
    }
}

/// The board clock's reading a message carries, µs: its stamp, or the board time of an
/// acknowledgement.
fn board_clock_us(message: &Message) -> Option<u64> {
    match message {
        Message::Ack(ack) => Some(ack.board_time_us),
        other => message_stamp_us(other),
    }
}

/// The board time a message carries, µs.
fn message_stamp_us(message: &Message) -> Option<u64> {
    match message {
        Message::Scan(s) => Some(s.stamp_us),
        Message::GpsFix(f) => Some(f.stamp_us),
        Message::Nmea(n) => Some(n.stamp_us),
        Message::Pps(p) => Some(p.edge_us),
        Message::Heartbeat(h) => Some(h.uptime_us),
        Message::Status(s) => Some(s.uptime_us),
        Message::Log(l) => Some(l.stamp_us),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use protocol::{HeartbeatMsg, RangeUnit, ScanMsg};

    use super::*;

    /// Frames as the board sends them.
    fn board_frames(messages: &[Message]) -> Vec<u8> {
        let mut encoder = Encoder::new();
        let mut bytes = Vec::new();
        for m in messages {
            let mut out = [0u8; MAX_WIRE_LEN];
            bytes.extend_from_slice(encoder.encode(m, &mut out).expect("encodes"));
        }
        bytes
    }

    fn scan(stamp_us: u64, counter: u32) -> Message {
        Message::Scan(ScanMsg {
            stamp_us,
            scan_counter: counter,
            start_angle_cdeg: 0,
            step_angle_cdeg: 100,
            unit: RangeUnit::Cm,
            count_word: 181,
            values: (0..181).map(|_| 500u16).collect(),
            status: 0,
            sensor_indices: None,
        })
    }

    #[test]
    fn scans_become_events_in_metres_with_board_time() {
        let mut session = LinkSession::new(MeasuringMode::DEFAULT);
        let bytes = board_frames(&[scan(1_000_000, 1), scan(1_013_333, 2)]);
        let decoded = session.feed(&bytes, 5.0);
        assert_eq!(decoded.events.len(), 2);
        assert_eq!(decoded.messages.len(), 2);
        let SensorEvent::Scan {
            board_time_s, scan, ..
        } = &decoded.events[1]
        else {
            panic!("a scan")
        };
        assert!((board_time_s - 1.013_333).abs() < 1e-9);
        assert_eq!(scan.ranges_m[0], 5.0);
        assert_eq!(session.counters().telegrams, 2);
        assert_eq!(session.counters().frames, 2);
    }

    #[test]
    fn a_restarted_board_clock_carries_on_from_the_last_boot() {
        let mut session = LinkSession::new(MeasuringMode::DEFAULT);
        let times = |decoded: Decoded| -> Vec<f64> {
            decoded
                .events
                .iter()
                .map(SensorEvent::board_time_s)
                .collect()
        };
        let first = times(session.feed(&board_frames(&[scan(10_000_000, 1)]), 100.0));
        let late = times(session.feed(&board_frames(&[scan(9_990_000, 2)]), 100.1));
        // Restarted: 0.5 s into its new boot, read 0.6 s of host time after the newest stamp
        // (10 s), so it comes at 10.6 s.
        let after =
            times(session.feed(&board_frames(&[scan(500_000, 1), scan(526_667, 2)]), 100.6));
        assert_eq!(first, [10.0]);
        // A stamp a little behind the newest is no restart.
        assert_eq!(late, [9.99]);
        assert!((after[0] - 10.6).abs() < 1e-9, "{after:?}");
        assert!((after[1] - after[0] - 0.026_667).abs() < 1e-9, "{after:?}");
        assert_eq!(session.counters().board_restarts, 1);
    }

    fn fix(source: protocol::FixSource, num_sats: Option<u8>) -> Message {
        Message::GpsFix(protocol::GpsFixMsg {
            stamp_us: 1,
            source,
            talker: *b"GP",
            date: None,
            time: None,
            quality: protocol::FixQuality::Gps,
            position: Some(protocol::Position {
                lat_ndeg: 48_000_000_000,
                lon_ndeg: 11_000_000_000,
            }),
            alt_msl_mm: None,
            geoid_sep_mm: None,
            num_sats,
            hdop_centi: None,
            speed_mm_s: None,
            course_cdeg: None,
            gst: None,
        })
    }

    #[test]
    fn a_fix_without_a_satellite_count_keeps_the_last_one() {
        use protocol::FixSource::{Gga, Rmc};
        let mut session = LinkSession::new(MeasuringMode::DEFAULT);
        session.feed(&board_frames(&[fix(Gga, Some(9)), fix(Rmc, None)]), 0.0);
        let counters = session.counters();
        assert_eq!(counters.gps_fixes, 2);
        assert_eq!(counters.gps_satellites, 9);
        session.feed(&board_frames(&[fix(Gga, Some(7))]), 1.0);
        assert_eq!(session.counters().gps_satellites, 7);
    }

    #[test]
    fn a_damaged_frame_is_counted_and_the_rest_still_decode() {
        let mut session = LinkSession::new(MeasuringMode::DEFAULT);
        let mut bytes = board_frames(&[scan(1, 1), scan(2, 2), scan(3, 3)]);
        let one = bytes.len() / 3;
        bytes[one + 10] ^= 0x55;
        let decoded = session.feed(&bytes, 0.0);
        assert_eq!(decoded.events.len(), 2);
        let counters = session.counters();
        assert_eq!(
            counters.crc_errors + counters.frames_lost,
            2,
            "{counters:?}"
        );
    }

    #[test]
    fn a_replayed_ping_is_awaited_like_the_live_one() {
        let mut session = LinkSession::new(MeasuringMode::DEFAULT);
        let beats: Vec<Message> = (0..5)
            .map(|i| {
                Message::Heartbeat(HeartbeatMsg {
                    uptime_us: 1_000_000 * i,
                })
            })
            .collect();
        for (i, beat) in beats.iter().enumerate() {
            session.feed(&board_frames(std::slice::from_ref(beat)), 10.0 + i as f64);
        }
        let ping = session.ping(20.0);
        assert!(!ping.is_empty());
        let mut replayed = LinkSession::new(MeasuringMode::DEFAULT);
        replayed.replay_sent(&ping, 20.0);
        assert_eq!(replayed.sync.pending_pings(), 1);
    }
}
