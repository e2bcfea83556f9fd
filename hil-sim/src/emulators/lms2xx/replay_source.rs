//! The recorded scans the emulated LMS2xx can stream instead of measuring its world
//! ([`Lms2xx::replay`](super::Lms2xx::replay)): a recorded scan ([`RecordedScan`]), where
//! they come from ([`ScanSource`]), when they go out ([`ReplayPace`]), how their beams are
//! placed on the sensor's values ([`BeamMapping`], [`recorded_words`]), and the replay state
//! the emulator keeps (`Replay`, with its progress, [`ReplayProgress`]).

use firmware::sick::MeasuringMode;
use protocol::RangeUnit;

use crate::emulators::lms_variant::Variant;
use crate::emulators::range_model::{beam_bearing_rad, encode_range};

/// One recorded scan to stream instead of a measured one
/// ([`Lms2xx::replay`](super::Lms2xx::replay)).
///
/// Beam `i` points at bearing `first_beam_rad + i · resolution_rad` from the sensor's
/// forward axis, counter-clockwise positive (the laser-frame angle of the LMS is that
/// bearing plus 90°).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedScan {
    /// When it was recorded, seconds on the log's clock (only differences matter).
    pub timestamp_s: f64,
    /// Bearing of beam 0, radians.
    pub first_beam_rad: f64,
    /// Bearing step from one beam to the next, radians.
    pub resolution_rad: f64,
    /// One range per beam, metres. A negative or non-finite range means no echo.
    pub ranges_m: Vec<f64>,
    /// Ranges at or above this are the recorder's "no return" marker, metres (e.g. the
    /// maximum range of a `ROBOTLASER1` message).
    pub no_return_from_m: Option<f64>,
    /// The exact bytes of a captured telegram, sent verbatim in place of one built from
    /// the ranges, whatever its variant, unit or CRC (a raw capture's scans).
    pub telegram: Option<Vec<u8>>,
}

/// Where recorded scans come from, in the order they were recorded.
pub trait ScanSource {
    /// The next recorded scan, or `None` when the log is exhausted.
    fn next_scan(&mut self) -> Option<RecordedScan>;
}

impl<I: Iterator<Item = RecordedScan>> ScanSource for I {
    fn next_scan(&mut self) -> Option<RecordedScan> {
        self.next()
    }
}

/// When recorded scans go out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReplayPace {
    /// At the first scan end at or after each scan's log time, relative to the first scan.
    #[default]
    Recorded,
    /// One per scan end, as fast as the mirror (and the line) allows.
    AsFastAsPossible,
}

/// How the beams of a recorded scan are placed on the values of the active variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BeamMapping {
    /// A value takes the recorded beam at its exact angle (within 0.01°); a value without
    /// one is "no echo". 180 recorded beams at 1° (−90° … +89°) fill values 0–179 of the
    /// 181-value 180°/1° variant, and value 180 (the sensor's far left) is no echo; in the
    /// 361-value 180°/0.5° variant they fill the even values 0–358, and the odd values and
    /// value 360 are no echo. 361 beams at 0.5° into 181 values take every other beam.
    #[default]
    Exact,
    /// A value takes the recorded beam nearest to its angle if that beam is at most one
    /// recorded step away, else no echo: 180 beams at 1° fill the 181-value variant with
    /// value 180 repeating beam 179, and the 361-value variant with each half-degree value
    /// repeating the beam half a degree counter-clockwise of it (ties go that way), and
    /// values 359 and 360 repeating beam 179.
    Nearest,
}

/// How far a replay has come ([`Lms2xx::replay_progress`](super::Lms2xx::replay_progress)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplayProgress {
    /// Recorded scans sent so far.
    pub scans_sent: u32,
    /// Whether the source is exhausted and every scan of it sent.
    pub finished: bool,
}

/// The range words of one complete scan of `variant` carrying the recorded `scan`.
///
/// Each value takes a recorded range as [`BeamMapping`] says. A range is coded exactly as a
/// measured one ([`encode_range`]): no echo (all distance bits set) for values without a
/// recorded beam, negative or non-finite ranges, ranges at or above the recording's
/// `no_return_from_m`, and ranges beyond `max_range_m` (the sensor's maximum range); a
/// range the unit and measuring mode cannot express gives "measured value > maximum" (…F7h).
/// A receiver decodes both codes as "no return".
pub fn recorded_words(
    scan: &RecordedScan,
    variant: Variant,
    unit: RangeUnit,
    mode: MeasuringMode,
    max_range_m: f64,
    mapping: BeamMapping,
) -> Vec<u16> {
    /// Angular tolerance of [`BeamMapping::Exact`]: 0.01°.
    const EXACT_TOLERANCE_RAD: f64 = 0.01 * std::f64::consts::PI / 180.0;
    /// Fraction of a beam step that settles ties of [`BeamMapping::Nearest`].
    const TIE_BIAS: f64 = 1e-6;
    let count = scan.ranges_m.len();
    let beam_of = |index: u16| -> Option<usize> {
        let step = scan.resolution_rad;
        if count == 0 || !step.is_finite() || step == 0.0 {
            // Without a step only beam 0 has an angle.
            let offset = beam_bearing_rad(variant.beam_angle_cdeg(index)) - scan.first_beam_rad;
            return (count > 0 && offset.abs() <= EXACT_TOLERANCE_RAD).then_some(0);
        }
        let position =
            (beam_bearing_rad(variant.beam_angle_cdeg(index)) - scan.first_beam_rad) / step;
        let last = (count - 1) as f64;
        let nearest = match mapping {
            BeamMapping::Exact => position.round(),
            // Ties (a value halfway between two beams) go to the higher index, whatever
            // the rounding of `position`.
            BeamMapping::Nearest => (position + TIE_BIAS).round().clamp(0.0, last),
        };
        let off_rad = (position - nearest).abs() * step.abs();
        let close = match mapping {
            BeamMapping::Exact => off_rad <= EXACT_TOLERANCE_RAD,
            BeamMapping::Nearest => off_rad <= step.abs() + EXACT_TOLERANCE_RAD,
        };
        (close && (0.0..=last).contains(&nearest)).then_some(nearest as usize)
    };
    (0..variant.values_per_scan())
        .map(|index| {
            let range_m = beam_of(index)
                .and_then(|beam| scan.ranges_m.get(beam).copied())
                .filter(|r| r.is_finite() && *r >= 0.0 && *r <= max_range_m)
                .filter(|r| scan.no_return_from_m.is_none_or(|limit| *r < limit));
            encode_range(range_m, unit, mode)
        })
        .collect()
}

/// A [`ScanSource`] the emulator can clone with itself.
trait BoxedScanSource: ScanSource + Send {
    fn clone_boxed(&self) -> Box<dyn BoxedScanSource>;
}

impl<S: ScanSource + Clone + Send + 'static> BoxedScanSource for S {
    fn clone_boxed(&self) -> Box<dyn BoxedScanSource> {
        Box::new(self.clone())
    }
}

/// The replay state: the source, the scan waiting to go out, and the log clock's anchor.
pub(super) struct Replay {
    source: Box<dyn BoxedScanSource>,
    pace: ReplayPace,
    mapping: BeamMapping,
    /// The next scan, taken from the source but not sent yet.
    pending: Option<RecordedScan>,
    /// The last scan sent.
    last: Option<RecordedScan>,
    /// (emulator time, log time) of the first scan sent.
    anchor: Option<(u64, f64)>,
    /// The source returned `None`.
    exhausted: bool,
    sent: u32,
}

impl Clone for Replay {
    fn clone(&self) -> Self {
        Replay {
            source: self.source.clone_boxed(),
            pace: self.pace,
            mapping: self.mapping,
            pending: self.pending.clone(),
            last: self.last.clone(),
            anchor: self.anchor,
            exhausted: self.exhausted,
            sent: self.sent,
        }
    }
}

impl std::fmt::Debug for Replay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Replay")
            .field("pace", &self.pace)
            .field("mapping", &self.mapping)
            .field("anchor", &self.anchor)
            .field("exhausted", &self.exhausted)
            .field("sent", &self.sent)
            .finish_non_exhaustive()
    }
}

impl Replay {
    /// A replay of `source` from its first scan.
    pub(super) fn new<S>(source: S, pace: ReplayPace, mapping: BeamMapping) -> Self
    where
        S: ScanSource + Clone + Send + 'static,
    {
        Replay {
            source: Box::new(source),
            pace,
            mapping,
            pending: None,
            last: None,
            anchor: None,
            exhausted: false,
            sent: 0,
        }
    }

    /// How the recorded beams are placed on the variant's values.
    pub(super) fn mapping(&self) -> BeamMapping {
        self.mapping
    }

    /// The last scan sent.
    pub(super) fn last(&self) -> Option<&RecordedScan> {
        self.last.as_ref()
    }

    /// How far the replay has come.
    pub(super) fn progress(&self) -> ReplayProgress {
        ReplayProgress {
            scans_sent: self.sent,
            finished: self.is_finished(),
        }
    }

    /// Whether every scan of the source has been sent.
    pub(super) fn is_finished(&self) -> bool {
        self.exhausted && self.pending.is_none()
    }

    /// The recorded scan to send at the scan end `at_us`, if one is due.
    pub(super) fn take_due(&mut self, at_us: u64) -> Option<RecordedScan> {
        if self.pending.is_none() && !self.exhausted {
            self.pending = self.source.next_scan();
            self.exhausted = self.pending.is_none();
        }
        let scan = self.pending.as_ref()?;
        let due = match (self.pace, self.anchor) {
            (ReplayPace::Recorded, Some((anchor_us, anchor_s))) => {
                let after_s = scan.timestamp_s - anchor_s;
                // A stamp before the anchor (or not a number) is due at once.
                let after_us = if after_s > 0.0 {
                    (after_s * 1e6).round() as u64
                } else {
                    0
                };
                at_us >= anchor_us.saturating_add(after_us)
            }
            _ => true,
        };
        if !due {
            return None;
        }
        let scan = self.pending.take()?;
        if self.anchor.is_none() {
            self.anchor = Some((at_us, scan.timestamp_s));
        }
        self.sent += 1;
        self.last = Some(scan.clone());
        Some(scan)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::lms2xx::tests::{bytes_of, exchange, hex, running};
    use crate::emulators::lms2xx::{Lms2xx, Lms2xxOptions};
    use firmware::sick::{Event, Receiver, ScanRepr, Telegram};

    /// A recorded scan of `count` beams at 1° from −90°, beam `i` at `1 + i / 100` m.
    fn recorded(timestamp_s: f64, count: usize) -> RecordedScan {
        RecordedScan {
            timestamp_s,
            first_beam_rad: -std::f64::consts::FRAC_PI_2,
            resolution_rad: 1f64.to_radians(),
            ranges_m: (0..count).map(|i| 1.0 + i as f64 / 100.0).collect(),
            no_return_from_m: None,
            telegram: None,
        }
    }

    #[test]
    fn recorded_words_map_beams_explicitly() {
        let mm = RangeUnit::Mm;
        let words = |scan: &RecordedScan, variant, mode, mapping| {
            recorded_words(scan, variant, mm, MeasuringMode(mode), 80.0, mapping)
        };
        // 180 beams into 180°/1°: value 180 has no beam.
        let scan = recorded(0.0, 180);
        let w = words(&scan, Variant::new(180, 100), 0, BeamMapping::Exact);
        assert_eq!((w.len(), w[0], w[179], w[180]), (181, 1_000, 2_790, 0x1FFF));
        let w = words(&scan, Variant::new(180, 100), 0, BeamMapping::Nearest);
        assert_eq!(w[180], 2_790);
        // Into 180°/0.5°: even values only; Nearest fills the odd ones counter-clockwise.
        let w = words(&scan, Variant::new(180, 50), 0, BeamMapping::Exact);
        assert_eq!((w[2], w[3], w[360]), (1_010, 0x1FFF, 0x1FFF));
        let w = words(&scan, Variant::new(180, 50), 0, BeamMapping::Nearest);
        assert_eq!((w[2], w[3], w[359], w[360]), (1_010, 1_020, 2_790, 2_790));
        // 100° at 1° takes beams 40–140.
        let w = words(&scan, Variant::new(100, 100), 0, BeamMapping::Exact);
        assert_eq!((w.len(), w[0], w[100]), (101, 1_400, 2_400));
        // 361 beams at 0.5° into 181 values: every other beam.
        let fine = RecordedScan {
            resolution_rad: 0.5f64.to_radians(),
            ranges_m: (0..361).map(|i| 1.0 + i as f64 / 1_000.0).collect(),
            ..recorded(0.0, 0)
        };
        let w = words(&fine, Variant::new(180, 100), 0, BeamMapping::Exact);
        assert_eq!((w[1], w[180]), (1_002, 1_360));
        // No return: the log's marker, beyond the sensor's maximum, negative, not a number;
        // too far for mode 0 in mm is "> maximum" (1FF7h), fine in mode 0Fh.
        let mut odd = recorded(0.0, 6);
        odd.ranges_m = vec![81.83, 80.5, -1.0, f64::NAN, 9.0, 0.0];
        odd.no_return_from_m = Some(81.83);
        let w = words(&odd, Variant::new(180, 100), 0, BeamMapping::Exact);
        assert_eq!(&w[..6], [0x1FFF, 0x1FFF, 0x1FFF, 0x1FFF, 0x1FF7, 0]);
        let w = words(&odd, Variant::new(180, 100), 0x0F, BeamMapping::Exact);
        assert_eq!(&w[..6], [0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF, 9_000, 0]);
        // An empty or degenerate scan is all no echo.
        let w = words(&recorded(0.0, 0), Variant::DEFAULT, 0, BeamMapping::Nearest);
        assert!(w.iter().all(|&v| v == 0x1FFF));
    }

    /// A sensor at 500 kBd in mm, streaming from time 0 (the `A0h` has left by 110 ms).
    fn streaming_replay(scans: Vec<RecordedScan>, pace: ReplayPace) -> Lms2xx {
        let mut lms = running(Lms2xxOptions {
            baud: 500_000,
            variant: Variant::new(180, 50),
            unit: RangeUnit::Mm,
            ..Lms2xxOptions::default()
        });
        lms.replay(scans.into_iter(), pace, BeamMapping::Exact);
        lms.receive(&hex("02 00 02 00 20 24 34 08"), 500_000, 0);
        lms
    }

    /// Arrival times and scans of every `B0h` until `until_us`, polled every 100 µs.
    fn collect_scans(lms: &mut Lms2xx, until_us: u64) -> Vec<(u64, ScanRepr)> {
        let mut receiver = Receiver::new();
        let mut out = Vec::new();
        let mut now_us = 0;
        while now_us < until_us {
            now_us += 100;
            for byte in lms.poll_output(now_us) {
                if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                    if telegram.command() == 0xB0 {
                        out.push((now_us, ScanRepr::parse(&telegram).unwrap()));
                    }
                }
            }
        }
        out
    }

    #[test]
    fn replay_as_fast_as_possible_then_silence() {
        let scans: Vec<_> = (0..4).map(|i| recorded(100.0 * i as f64, 180)).collect();
        let mut lms = streaming_replay(scans, ReplayPace::AsFastAsPossible);
        let got = collect_scans(&mut lms, 1_000_000);
        // One per scan end (26.7 ms at 0.5°) regardless of the log's 100 s spacing.
        assert_eq!(got.len(), 4);
        for pair in got.windows(2) {
            assert!(
                (26_000..=27_500).contains(&(pair[1].0 - pair[0].0)),
                "{}",
                pair[1].0
            );
        }
        assert_eq!(got[0].1.values[0], 1_000);
        assert_eq!(got[3].1.values[358], 2_790);
        assert_eq!(
            lms.replay_progress(),
            Some(ReplayProgress {
                scans_sent: 4,
                finished: true
            })
        );
        assert!(lms.is_streaming());
        assert_eq!(lms.next_output_us(), None);
        assert_eq!(lms.counters().scans_sent, 4);
        // A clone carries on from the same place; a requested scan repeats the last one.
        let mut clone = lms.clone();
        let runs = exchange(
            &mut clone,
            &hex("02 00 02 00 30 01 31 18"),
            500_000,
            1_000_000,
            1_100_000,
        );
        let bytes = bytes_of(&runs);
        let scan = ScanRepr::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap();
        assert_eq!(scan.values, got[3].1.values);
        // Without the replay the world is measured again.
        lms.stop_replay();
        assert_eq!(collect_scans(&mut lms, 1_100_000).len(), 3);
    }

    #[test]
    fn replay_at_the_recorded_pace() {
        // 0.1 s, 0.1 s, then two scans at the same time, then 0.5 s.
        let stamps = [50.0, 50.1, 50.2, 50.2, 50.7];
        let scans = stamps.iter().map(|&t| recorded(t, 180)).collect();
        let mut lms = streaming_replay(scans, ReplayPace::Recorded);
        let got = collect_scans(&mut lms, 2_000_000);
        assert_eq!(got.len(), 5);
        let first_us = got[0].0;
        let offsets: Vec<u64> = got.iter().map(|(t, _)| t - first_us).collect();
        // First scan end at or after each log-relative time; a second scan due at the same
        // time goes out one scan later.
        for (offset, expected) in offsets.iter().zip([0, 100_000, 200_000, 226_667, 700_000]) {
            assert!(
                (expected..expected + 26_667 + 100).contains(offset),
                "{offsets:?}"
            );
        }
        assert!(lms.replay_progress().unwrap().finished);
    }
}
