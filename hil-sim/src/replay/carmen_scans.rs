//! CARMEN laser records as recorded scans for the LMS emulator ([`Lms2xx::replay`]): the
//! ranges, beam geometry and timestamp of each `FLASER`/`ROBOTLASER1` record, in log order.
//!
//! Range values stay as logged. A log's own "no return" value is known for `ROBOTLASER1`
//! (its maximum range) and can be given for `FLASER` logs, which do not record it (81.83 m
//! in Intel, 81.91 m in CSAIL, 50 m in ACES); the emulator codes ranges from that value up,
//! and any range beyond its own maximum range (80 m by default), as no echo.
//!
//! [`Lms2xx::replay`]: crate::emulators::Lms2xx::replay

use super::carmen::{CarmenLog, LaserRecord};
use crate::emulators::RecordedScan;

impl LaserRecord {
    /// This scan as a recorded scan; ranges from `no_return_from_m` up (or, when `None`,
    /// from a `ROBOTLASER1` record's maximum range up) are "no return".
    pub fn to_recorded_scan(&self, no_return_from_m: Option<f64>) -> RecordedScan {
        RecordedScan {
            timestamp_s: self.timestamp_s,
            first_beam_rad: self.start_angle_rad,
            resolution_rad: self.resolution_rad,
            ranges_m: self.ranges_m.clone(),
            no_return_from_m: no_return_from_m.or(self.max_range_m),
            telegram: None,
        }
    }
}

/// Every laser record of `log` as a recorded scan, in log order; a [`ScanSource`] as
/// `recorded_scans(..).into_iter()`. See [`LaserRecord::to_recorded_scan`] for
/// `no_return_from_m`.
///
/// [`ScanSource`]: crate::emulators::ScanSource
pub fn recorded_scans(log: &CarmenLog, no_return_from_m: Option<f64>) -> Vec<RecordedScan> {
    log.lasers()
        .map(|laser| laser.to_recorded_scan(no_return_from_m))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::lms2xx::POWER_ON_BAUD;
    use crate::emulators::{BeamMapping, Lms2xx, Lms2xxOptions, ReplayPace, garble};
    use firmware::sick::bringup::Action;
    use firmware::sick::{
        BringUp, BringUpConfig, Event, Input, RangeDecoder, Receiver, ScanRepr, StreamingSetup,
    };
    use protocol::LaserState;

    /// The first `count` scans of `benchmark/intel.clf`.
    fn intel_scans(count: usize, test: &str) -> Option<(CarmenLog, Vec<RecordedScan>)> {
        let path = datasets::require("benchmark/intel.clf", test)?;
        let mut log = CarmenLog::read(path).unwrap();
        let lasers: Vec<_> = log.records.drain(..count).collect();
        log.records = lasers;
        let scans = recorded_scans(&log, Some(81.83));
        Some((log, scans))
    }

    /// Brings `lms` up with the firmware's bring-up state machine over an emulated serial
    /// line, then runs until `until_us`; returns (arrival time, scan) of every streamed scan
    /// and the streaming setup.
    fn run_with_firmware(
        lms: &mut Lms2xx,
        until_us: u64,
    ) -> (Vec<(u64, ScanRepr)>, StreamingSetup) {
        let mut bringup = BringUp::new(BringUpConfig::default());
        let mut receiver = Receiver::new();
        let mut uart_baud = POWER_ON_BAUD;
        let mut deadline_us: Option<u64> = None;
        let mut scans = Vec::new();
        let mut pending: Vec<Action> = bringup.handle(Input::Start).into_iter().collect();
        let mut now_us = 0;
        loop {
            for action in pending.drain(..) {
                match action {
                    Action::Send(request) => lms.receive(request.as_bytes(), uart_baud, now_us),
                    Action::SetBaud(baud) => {
                        uart_baud = baud;
                        receiver.clear();
                    }
                    Action::StartTimer { duration_ms } => {
                        deadline_us = Some(now_us + u64::from(duration_ms) * 1_000);
                    }
                    _ => {}
                }
            }
            if now_us >= until_us {
                break;
            }
            now_us += 100;
            let mut inputs = Vec::new();
            for run in lms.poll_output_runs(now_us) {
                for byte in garble(&run.bytes, run.baud, uart_baud) {
                    if let Some(event) = receiver.push(byte, now_us) {
                        if let Event::Telegram { telegram, .. } = &event {
                            if telegram.command() == 0xB0
                                && bringup.state() == LaserState::Streaming
                            {
                                scans.push((now_us, ScanRepr::parse(telegram).unwrap()));
                            }
                        }
                        inputs.push(bringup.handle(event.into()));
                    }
                }
            }
            if let Some(event) = receiver.poll(now_us) {
                inputs.push(bringup.handle(event.into()));
            }
            if deadline_us.is_some_and(|d| now_us >= d) {
                deadline_us = None;
                inputs.push(bringup.handle(Input::Timeout));
            }
            pending = inputs.into_iter().flatten().collect();
        }
        (scans, bringup.setup().unwrap())
    }

    #[test]
    fn intel_scans_round_trip_through_the_emulator() {
        let Some((log, recorded)) = intel_scans(5, "intel_scans_round_trip_through_the_emulator")
        else {
            return;
        };
        let mut lms = Lms2xx::new(Lms2xxOptions::default());
        lms.replay(
            recorded.clone().into_iter(),
            ReplayPace::AsFastAsPossible,
            BeamMapping::Exact,
        );
        let (scans, setup) = run_with_firmware(&mut lms, 8_000_000);
        // Five scans, then the log is exhausted and the stream falls silent.
        assert_eq!(scans.len(), 5);
        let progress = lms.replay_progress().unwrap();
        assert!(progress.finished);
        assert_eq!(progress.scans_sent, 5);
        assert!(lms.is_streaming());
        // One scan per complete scan (37.5/s at 0.5°).
        for pair in scans.windows(2) {
            assert!(pair[1].0 - pair[0].0 < 28_000, "{pair:?}");
        }
        let decoder = RangeDecoder::new(setup.measuring_mode, setup.unit).unwrap();
        let mut exact = 0;
        for ((_, scan), laser) in scans.iter().zip(log.lasers()) {
            assert_eq!(scan.values.len(), 361);
            for (j, &word) in scan.values.iter().enumerate() {
                let decoded = decoder.range_mm(word);
                if j % 2 == 1 || j == 360 {
                    // Half-degree values and the 180° value have no recorded beam.
                    assert_eq!(decoded, None, "value {j}");
                    continue;
                }
                let range_mm = (laser.ranges_m[j / 2] * 1_000.0).round() as u32;
                // Mode 0 in mm codes up to 8.182 m; farther is "no return".
                if range_mm < 8_183 {
                    assert_eq!(decoded, Some(range_mm), "value {j}");
                    exact += 1;
                } else {
                    assert_eq!(decoded, None, "value {j}");
                }
            }
        }
        assert!(exact > 400, "{exact}");
    }

    #[test]
    fn intel_scans_at_the_recorded_pace() {
        let Some((log, recorded)) = intel_scans(3, "intel_scans_at_the_recorded_pace") else {
            return;
        };
        let mut lms = Lms2xx::new(Lms2xxOptions::default());
        lms.replay(
            recorded.into_iter(),
            ReplayPace::Recorded,
            BeamMapping::Nearest,
        );
        let stamps: Vec<f64> = log.lasers().map(|l| l.timestamp_s).collect();
        let span_s = stamps[2] - stamps[0];
        let (scans, _) = run_with_firmware(&mut lms, 6_000_000 + (span_s * 1e6) as u64);
        assert_eq!(scans.len(), 3);
        // Each scan leaves at the first scan end after its log-relative time: at most one
        // scan period (26.7 ms) late.
        for i in 1..3 {
            let log_us = (stamps[i] - stamps[0]) * 1e6;
            let sent_us = (scans[i].0 - scans[0].0) as f64;
            assert!(
                (0.0..27_000.0).contains(&(sent_us - log_us)),
                "scan {i}: {sent_us} vs {log_us}"
            );
        }
        // Nearest: every value has a range; the half-degree ones repeat a neighbour.
        let (_, first) = &scans[0];
        assert_eq!(first.values[1], first.values[2]);
        assert_eq!(first.values[360], first.values[358]);
    }
}
