//! The GPS receiver: serial bytes in, [`GpsFixMsg`] reports and validated sentences out.
//!
//! [`GpsReceiver`] chains the [`LineAssembler`], the checksum check of [`Sentence`] and the
//! sentence `Repr`s, keeps the little state needed to merge one epoch's sentences, and counts
//! every line by outcome ([`NmeaStats`]).
//!
//! # Reports
//!
//! Every GGA, RMC and GLL with a valid checksum that decodes produces one [`GpsFixMsg`],
//! with a fix or without one. The report carries the sentence's own fields; fields the
//! sentence lacks are merged from the epoch's other sentences, keyed by UTC time of day:
//!
//! * **date**: RMC's own date. GGA and GLL take the date of the last RMC with status `A`
//!   whose time is not later than theirs (so a GGA just after midnight does not get the date
//!   of the day before; it gets `None`).
//! * **speed and course**: RMC's own, else (and for GGA/GLL) those of the RMC or VTG of the
//!   same epoch, if already received. VTG has no time field: it belongs to the epoch of the
//!   last sentence that had one. VTG with mode `N` is ignored.
//! * **GST sigmas**: the last GST whose time is the fix time or at most
//!   [`GST_MAX_AGE_US`] earlier. Receivers send GST at the end of the epoch (u-blox:
//!   RMC, VTG, GGA, GSA, GSV, GLL, GST), so fixes usually carry the previous epoch's
//!   sigmas; sigmas change slowly, and a GST that old or older is never used.
//!
//! No-fix rule (§9 of `shared/protocols/nmea0183.md`): RMC status `V`, a mode `N` (RMC,
//! GLL), GGA quality 0 or empty, GLL status `V` give `quality: Invalid` and no position,
//! altitude, speed or course, even when the receiver printed a (stale) position.
//!
//! Repeated position sentences: when an epoch repeats a sentence type under another talker
//! (SiRFstarV: `GPGGA` then `GLGGA` with the same time), only the first produces a report;
//! the repeat is still returned (for passthrough) and counted in
//! [`NmeaStats::duplicates`].
//!
//! # Counters
//!
//! Every complete line from the assembler ends up in exactly one of `accepted`,
//! `unsupported`, `bad_checksum`, `missing_checksum` and `malformed`; lines the assembler
//! drops are in `truncated`, `too_long` and `non_printable`.

use protocol::{
    Date, FixQuality, FixSource, GpsFixMsg, GstSigmas, MAX_NMEA_LEN, NmeaMsg, Position, TimeOfDay,
};

use super::{
    Error, GgaRepr, GllRepr, GsaRepr, GstRepr, LineAssembler, RmcRepr, Sentence, SentenceKind,
    Talker, VtgRepr,
};

/// How much older than a fix a GST may be and still be merged into it, µs.
pub const GST_MAX_AGE_US: u64 = 1_000_000;

/// Microseconds in a day.
const DAY_US: u64 = 86_400_000_000;

/// Counters of a [`GpsReceiver`]. All counts wrap at 2³².
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NmeaStats {
    /// Bytes pushed.
    pub bytes: u32,
    /// Complete lines (candidate sentences) out of the line assembler.
    pub lines: u32,
    /// Lines dropped because a `$` arrived before their end.
    pub truncated: u32,
    /// Lines dropped for exceeding [`MAX_NMEA_LEN`].
    pub too_long: u32,
    /// Lines dropped for a non-printable byte.
    pub non_printable: u32,
    /// Sentences decoded (GGA, RMC, GLL, GSA, VTG, GST with a valid checksum).
    pub accepted: u32,
    /// Sentences with a valid checksum and a formatter this module does not decode,
    /// proprietary ones included.
    pub unsupported: u32,
    /// Sentences whose checksum does not match.
    pub bad_checksum: u32,
    /// Sentences without `*hh`.
    pub missing_checksum: u32,
    /// Lines that are not sentences, and decoded sentences whose fields do not decode.
    pub malformed: u32,
    /// Fix reports produced.
    pub fixes: u32,
    /// Position sentences repeated under another talker in the same epoch (no report).
    pub duplicates: u32,
}

/// A sentence that passed the checksum, with the fix report it produced, if any.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReceivedSentence<'a> {
    /// The `now_us` given with the bytes that contained the `$`.
    pub stamp_us: u64,
    /// The sentence, `$` through `*hh`.
    pub sentence: Sentence<&'a [u8]>,
    /// The report of a GGA, RMC or GLL sentence.
    pub fix: Option<GpsFixMsg>,
}

impl ReceivedSentence<'_> {
    /// The raw sentence as a passthrough message for recording.
    pub fn to_nmea_msg(&self) -> NmeaMsg {
        let mut sentence = heapless::String::<MAX_NMEA_LEN>::new();
        // Lines are printable ASCII and at most MAX_NMEA_LEN long (LineAssembler), so every
        // push succeeds; a failure could only shorten the text.
        for &b in self.sentence.as_bytes() {
            let _ = sentence.push(char::from(b));
        }
        NmeaMsg {
            stamp_us: self.stamp_us,
            sentence,
        }
    }
}

/// Speed and course of one epoch.
#[derive(Debug, Clone, Copy)]
struct Motion {
    time_us: u64,
    speed_mm_s: Option<u32>,
    course_cdeg: Option<u32>,
}

/// What the receiver remembers between sentences to merge an epoch.
#[derive(Debug, Clone, Copy, Default)]
struct Epoch {
    /// Time of day of the last sentence that had one, µs.
    time_us: Option<u64>,
    /// Date of the last valid RMC, and its time of day (µs) if it had one.
    date: Option<(Date, Option<u64>)>,
    motion: Option<Motion>,
    gst: Option<(u64, GstSigmas)>,
    /// Per source (GGA, RMC, GLL): time and talker of the last report.
    last_report: [Option<(u64, [u8; 2])>; 3],
}

/// Microseconds since midnight.
fn micros_of_day(t: TimeOfDay) -> u64 {
    (u64::from(t.hour) * 3600 + u64::from(t.minute) * 60 + u64::from(t.second)) * 1_000_000
        + u64::from(t.micros)
}

/// How far `earlier` lies before `later` on the clock, wrapping at midnight, µs.
fn age_us(later: u64, earlier: u64) -> u64 {
    (later + DAY_US - earlier % DAY_US) % DAY_US
}

impl Epoch {
    fn note_time(&mut self, time: Option<TimeOfDay>) {
        if let Some(t) = time {
            self.time_us = Some(micros_of_day(t));
        }
    }

    fn date_for(&self, time_us: Option<u64>) -> Option<Date> {
        match (self.date?, time_us) {
            ((date, None), _) => Some(date),
            ((date, Some(rmc_us)), Some(t)) if t >= rmc_us => Some(date),
            _ => None,
        }
    }

    fn motion_for(&self, time_us: Option<u64>) -> (Option<u32>, Option<u32>) {
        match (self.motion, time_us) {
            (Some(m), Some(t)) if m.time_us == t => (m.speed_mm_s, m.course_cdeg),
            _ => (None, None),
        }
    }

    fn gst_for(&self, time_us: Option<u64>) -> Option<GstSigmas> {
        let (gst_us, sigmas) = self.gst?;
        (age_us(time_us?, gst_us) <= GST_MAX_AGE_US).then_some(sigmas)
    }

    /// Records a report of `source` at `time_us` from `talker`; `false` if this is a repeat
    /// of the epoch's report under another talker.
    fn claim_report(&mut self, source: FixSource, time_us: Option<u64>, talker: [u8; 2]) -> bool {
        let slot = match source {
            FixSource::Gga => 0,
            FixSource::Rmc => 1,
            FixSource::Gll => 2,
        };
        let Some(t) = time_us else {
            return true;
        };
        let Some(last) = self.last_report.get_mut(slot) else {
            return true;
        };
        if matches!(*last, Some((last_t, last_talker)) if last_t == t && last_talker != talker) {
            return false;
        }
        *last = Some((t, talker));
        true
    }
}

/// The fields of a report that differ by sentence.
struct FixFields {
    source: FixSource,
    time: Option<TimeOfDay>,
    date: Option<Date>,
    quality: FixQuality,
    position: Option<Position>,
    alt_msl_mm: Option<i32>,
    geoid_sep_mm: Option<i32>,
    num_sats: Option<u8>,
    hdop_centi: Option<u16>,
    speed_mm_s: Option<u32>,
    course_cdeg: Option<u32>,
}

/// NMEA byte stream → fix reports, passthrough sentences and counters. `no_std`, no
/// allocation, about 420 bytes of state (a 126-byte line buffer, the epoch
/// state and the counters).
///
/// ```
/// # use firmware::nmea::GpsReceiver;
/// let mut receiver = GpsReceiver::new();
/// let mut rest: &[u8] = b"$GPGGA,,,,,,0,,,,,,,,*66\r\n";
/// while let Some(result) = receiver.next_sentence(&mut rest, 42) {
///     let Ok(received) = result else { continue }; // errors are counted
///     let fix = received.fix.unwrap();
///     assert_eq!((fix.stamp_us, fix.position), (42, None));
/// }
/// assert_eq!(receiver.stats().accepted, 1);
/// ```
#[derive(Debug, Clone, Default)]
pub struct GpsReceiver {
    lines: LineAssembler,
    epoch: Epoch,
    stats: NmeaStats,
}

impl GpsReceiver {
    /// A receiver with no history.
    pub fn new() -> Self {
        Self::default()
    }

    /// The counters so far.
    pub fn stats(&self) -> NmeaStats {
        let lines = self.lines.stats();
        NmeaStats {
            bytes: lines.bytes,
            lines: lines.lines,
            truncated: lines.truncated,
            too_long: lines.too_long,
            non_printable: lines.non_printable,
            ..self.stats
        }
    }

    /// Drops a partial line (e.g. after a UART overrun) and forgets the epoch state.
    pub fn reset(&mut self) {
        self.lines.reset();
        self.epoch = Epoch::default();
    }

    /// Consumes bytes from the front of `input` up to the end of the next line and returns
    /// that line's outcome, or consumes all of `input` and returns `None`. `now_us` is when
    /// the bytes arrived (board time); it stamps the sentences whose `$` is among them.
    ///
    /// Call until it returns `None`. Every error is already counted in [`NmeaStats`];
    /// it is returned for logging only.
    ///
    /// # Errors
    /// The [`Error`] of a line that is not a valid, decodable sentence.
    pub fn next_sentence<'s, 'b: 's>(
        &'s mut self,
        input: &mut &'b [u8],
        now_us: u64,
    ) -> Option<Result<ReceivedSentence<'s>, Error>> {
        let line = self.lines.next_line(input, now_us)?;
        let result = Sentence::new_checked(line.bytes).and_then(|sentence| {
            let fix = self
                .epoch
                .decode(&sentence, line.stamp_us, &mut self.stats)?;
            Ok(ReceivedSentence {
                stamp_us: line.stamp_us,
                sentence,
                fix,
            })
        });
        let counter = match result {
            Ok(_) => None,
            Err(Error::BadChecksum) => Some(&mut self.stats.bad_checksum),
            Err(Error::MissingChecksum) => Some(&mut self.stats.missing_checksum),
            Err(Error::Malformed | Error::TooLong | Error::WrongFormatter) => {
                Some(&mut self.stats.malformed)
            }
        };
        if let Some(counter) = counter {
            *counter = counter.wrapping_add(1);
        }
        Some(result)
    }

    /// Pushes `bytes` received at `now_us` and calls `on_sentence` for every valid sentence
    /// (with its report, if any). Errors are only counted.
    pub fn push(
        &mut self,
        bytes: &[u8],
        now_us: u64,
        mut on_sentence: impl FnMut(&ReceivedSentence<'_>),
    ) {
        let mut rest = bytes;
        while let Some(result) = self.next_sentence(&mut rest, now_us) {
            if let Ok(received) = result {
                on_sentence(&received);
            }
        }
    }
}

impl Epoch {
    /// Decodes a checksummed sentence, updates the epoch and the counters, and builds the
    /// report of a position sentence.
    fn decode(
        &mut self,
        sentence: &Sentence<&[u8]>,
        stamp_us: u64,
        stats: &mut NmeaStats,
    ) -> Result<Option<GpsFixMsg>, Error> {
        let talker = match sentence.talker() {
            Some(Talker::Standard(id)) => id,
            Some(Talker::Proprietary(_)) | None => {
                stats.unsupported = stats.unsupported.wrapping_add(1);
                return Ok(None);
            }
        };
        let fields = match sentence.kind() {
            SentenceKind::Gga => Some(self.gga(GgaRepr::parse(sentence)?)),
            SentenceKind::Rmc => Some(self.rmc(RmcRepr::parse(sentence)?)),
            SentenceKind::Gll => Some(self.gll(GllRepr::parse(sentence)?)),
            SentenceKind::Gsa => {
                GsaRepr::parse(sentence)?;
                None
            }
            SentenceKind::Vtg => {
                self.vtg(VtgRepr::parse(sentence)?);
                None
            }
            SentenceKind::Gst => {
                let gst = GstRepr::parse(sentence)?;
                self.note_time(gst.time);
                if let Some(t) = gst.time {
                    self.gst = Some((micros_of_day(t), gst.sigmas));
                }
                None
            }
            SentenceKind::Other | SentenceKind::Proprietary => {
                stats.unsupported = stats.unsupported.wrapping_add(1);
                return Ok(None);
            }
        };
        stats.accepted = stats.accepted.wrapping_add(1);
        let Some(f) = fields else {
            return Ok(None);
        };
        let time_us = f.time.map(micros_of_day);
        if !self.claim_report(f.source, time_us, talker) {
            stats.duplicates = stats.duplicates.wrapping_add(1);
            return Ok(None);
        }
        stats.fixes = stats.fixes.wrapping_add(1);
        let valid = f.quality != FixQuality::Invalid;
        let (speed_mm_s, course_cdeg) = if valid {
            let (speed, course) = self.motion_for(time_us);
            (f.speed_mm_s.or(speed), f.course_cdeg.or(course))
        } else {
            (None, None)
        };
        Ok(Some(GpsFixMsg {
            stamp_us,
            source: f.source,
            talker,
            date: f.date,
            time: f.time,
            quality: f.quality,
            position: f.position.filter(|_| valid),
            alt_msl_mm: f.alt_msl_mm.filter(|_| valid),
            geoid_sep_mm: f.geoid_sep_mm.filter(|_| valid),
            num_sats: f.num_sats,
            hdop_centi: f.hdop_centi,
            speed_mm_s,
            course_cdeg,
            gst: self.gst_for(time_us),
        }))
    }

    fn gga(&mut self, gga: GgaRepr) -> FixFields {
        self.note_time(gga.time);
        let time_us = gga.time.map(micros_of_day);
        FixFields {
            source: FixSource::Gga,
            time: gga.time,
            date: self.date_for(time_us),
            quality: gga.quality.unwrap_or(FixQuality::Invalid),
            position: gga.fix_position(),
            alt_msl_mm: gga.alt_msl_mm,
            geoid_sep_mm: gga.geoid_sep_mm,
            num_sats: gga.num_sats,
            hdop_centi: gga.hdop_centi,
            speed_mm_s: None,
            course_cdeg: None,
        }
    }

    fn rmc(&mut self, rmc: RmcRepr) -> FixFields {
        self.note_time(rmc.time);
        let time_us = rmc.time.map(micros_of_day);
        let quality = rmc.quality();
        if quality != FixQuality::Invalid {
            if let Some(date) = rmc.date {
                self.date = Some((date, time_us));
            }
            if let Some(t) = time_us {
                let (speed, course) = self.motion_for(time_us);
                self.motion = Some(Motion {
                    time_us: t,
                    speed_mm_s: rmc.speed_mm_s.or(speed),
                    course_cdeg: rmc.course_cdeg.or(course),
                });
            }
        }
        FixFields {
            source: FixSource::Rmc,
            time: rmc.time,
            date: rmc.date,
            quality,
            position: rmc.fix_position(),
            alt_msl_mm: None,
            geoid_sep_mm: None,
            num_sats: None,
            hdop_centi: None,
            speed_mm_s: rmc.speed_mm_s,
            course_cdeg: rmc.course_cdeg,
        }
    }

    fn gll(&mut self, gll: GllRepr) -> FixFields {
        self.note_time(gll.time);
        let time_us = gll.time.map(micros_of_day);
        FixFields {
            source: FixSource::Gll,
            time: gll.time,
            date: self.date_for(time_us),
            quality: gll.quality(),
            position: gll.fix_position(),
            alt_msl_mm: None,
            geoid_sep_mm: None,
            num_sats: None,
            hdop_centi: None,
            speed_mm_s: None,
            course_cdeg: None,
        }
    }

    fn vtg(&mut self, vtg: VtgRepr) {
        if vtg
            .mode
            .is_some_and(|m| m.fix_quality() == FixQuality::Invalid)
        {
            return;
        }
        let Some(t) = self.time_us else {
            return;
        };
        let (speed, course) = self.motion_for(Some(t));
        self.motion = Some(Motion {
            time_us: t,
            speed_mm_s: speed.or(vtg.speed_mm_s),
            course_cdeg: course.or(vtg.course_cdeg),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pushes `text` (lines separated by `\n`) and returns the reports.
    fn run(receiver: &mut GpsReceiver, text: &str) -> Vec<GpsFixMsg> {
        let mut fixes = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let bytes = format!("{line}\r\n");
            receiver.push(bytes.as_bytes(), i as u64 * 1000, |s| fixes.extend(s.fix));
        }
        fixes
    }

    /// An epoch in u-blox order: RMC, VTG, GGA, GSA, GLL, GST.
    const UBLOX_EPOCHS: &str = "\
$GNRMC,223746.00,A,3806.62966,N,12237.61384,W,0.097,,110720,,,D*79
$GNVTG,,T,,M,0.097,N,0.180,K,D*3F
$GNGGA,223746.00,3806.62966,N,12237.61384,W,2,12,0.56,83.1,M,-29.9,M,,0131*4E
$GNGLL,3806.62966,N,12237.61384,W,223746.00,A,D*6B
$GNGST,223746.00,837,2.5,2.4,127,0.98,1.0,3.0*75
$GNRMC,223747.00,A,3806.62968,N,12237.61386,W,0.084,,110720,,,D*76
$GNVTG,,T,,M,0.084,N,0.155,K,D*35
$GNGGA,223747.00,3806.62968,N,12237.61386,W,2,12,0.56,83.0,M,-29.9,M,,0131*42";

    #[test]
    fn merges_an_epoch() {
        let mut rx = GpsReceiver::new();
        let fixes = run(&mut rx, UBLOX_EPOCHS);
        let stats = rx.stats();
        assert_eq!(stats.bad_checksum + stats.malformed, 0, "{stats:?}");
        assert_eq!(fixes.len(), 5);
        let gga = fixes[1];
        assert_eq!(gga.source, FixSource::Gga);
        assert_eq!(gga.talker, *b"GN");
        assert_eq!(gga.quality, FixQuality::Dgps);
        assert_eq!(
            gga.date,
            Some(Date {
                year: 2020,
                month: 7,
                day: 11
            })
        );
        assert_eq!(gga.speed_mm_s, Some(50));
        assert_eq!(gga.course_cdeg, None);
        assert_eq!(gga.alt_msl_mm, Some(83_100));
        assert_eq!(gga.num_sats, Some(12));
        assert_eq!(gga.gst, None, "the GST of this epoch comes later");
        assert_eq!(gga.stamp_us, 2000);
        // The next epoch's GGA carries the previous GST.
        let next_gga = fixes[4];
        assert_eq!(next_gga.gst.unwrap().lat_sigma_mm, Some(980));
        assert_eq!(next_gga.speed_mm_s, Some(43));
        assert_eq!(stats.accepted, 8);
        assert_eq!(stats.fixes, 5);
    }

    #[test]
    fn no_fix_never_has_a_position() {
        let mut rx = GpsReceiver::new();
        let fixes = run(
            &mut rx,
            "$GPGGA,,,,,,0,,,,,,,,*66\n$GPRMC,,V,,,,,,,,,,N,V*29\n$GNGGA,181604.00,,,,,0,00,99.99,,,,,,*72",
        );
        assert_eq!(fixes.len(), 3);
        assert!(
            fixes
                .iter()
                .all(|f| f.quality == FixQuality::Invalid && f.position.is_none())
        );
        assert_eq!(fixes[2].hdop_centi, Some(9999));
        // A V RMC with a stale position (Telit SL869).
        let mut line = String::new();
        super::super::emit::write_sentence(&mut line, b"GPRMC", |w| {
            core::fmt::Write::write_str(
                w,
                ",102136.000,V,3340.8472,S,15057.3804,E,0.00,0.00,180512,,",
            )
        })
        .unwrap();
        let fixes = run(&mut rx, line.trim_end());
        assert_eq!(fixes[0].position, None);
        assert_eq!(fixes[0].speed_mm_s, None);
        assert_eq!(
            fixes[0].date,
            Some(Date {
                year: 2012,
                month: 5,
                day: 18
            })
        );
    }

    #[test]
    fn repeated_gga_under_another_talker_is_not_reported_twice() {
        let mut rx = GpsReceiver::new();
        let fixes = run(
            &mut rx,
            "$GPGGA,020935.000,4404.1351,N,12118.8556,W,1,08,0.9,1123.9,M,-19.6,M,,0000*5E\n\
             $GLGGA,020935.000,4404.1351,N,12118.8556,W,1,02,0.9,1123.9,M,-19.6,M,,0000*48\n\
             $GPGGA,020936.000,4404.1351,N,12118.8557,W,1,08,0.9,1123.9,M,-19.6,M,,0000*5C",
        );
        assert_eq!(fixes.len(), 2);
        assert!(fixes.iter().all(|f| f.talker == *b"GP"));
        assert_eq!(rx.stats().duplicates, 1);
        assert_eq!(rx.stats().accepted, 3);
    }

    #[test]
    fn date_is_not_carried_over_midnight() {
        let mut rx = GpsReceiver::new();
        let mut text = String::new();
        let rmc = RmcRepr {
            time: Some(TimeOfDay {
                hour: 23,
                minute: 59,
                second: 59,
                micros: 0,
            }),
            valid: Some(true),
            position: Some(Position {
                lat_ndeg: 1,
                lon_ndeg: 2,
            }),
            speed_mm_s: None,
            course_cdeg: None,
            date: Some(Date {
                year: 2024,
                month: 2,
                day: 28,
            }),
            mag_var_cdeg: None,
            mode: None,
            nav_status: None,
        };
        rmc.emit(*b"GP", &mut text).unwrap();
        let mut gga = GgaRepr {
            time: Some(TimeOfDay {
                hour: 23,
                minute: 59,
                second: 59,
                micros: 500_000,
            }),
            position: Some(Position {
                lat_ndeg: 1,
                lon_ndeg: 2,
            }),
            quality: Some(FixQuality::Gps),
            num_sats: None,
            hdop_centi: None,
            alt_msl_mm: None,
            geoid_sep_mm: None,
            dgps_age_ms: None,
            dgps_station: None,
        };
        gga.emit(*b"GP", &mut text).unwrap();
        gga.time = Some(TimeOfDay {
            hour: 0,
            minute: 0,
            second: 0,
            micros: 0,
        });
        gga.emit(*b"GP", &mut text).unwrap();
        let fixes = run(&mut rx, &text);
        assert_eq!(fixes.len(), 3);
        assert_eq!(fixes[1].date, rmc.date);
        assert_eq!(fixes[2].date, None);
    }

    #[test]
    fn counters_add_up_and_passthrough_sees_valid_sentences() {
        let mut rx = GpsReceiver::new();
        let stream = b"$GPGGA,,,,,,0,,,,,,,,*67\r\n$GPGGA,,,,,,0,,,,,,,,\r\n$GPGSV,1,1,00*79\r\n\
            $PGRMZ,93,f,3*21\r\n$GPGGA,,,,,,7x,,,,,,,,*19\r\n$GPGGA,,,$GPGGA,,,,,,0,,,,,,,,*66\r\n\
            $GP\x00GGA\r\n$ABC\r\n";
        let mut passthrough = Vec::new();
        rx.push(stream, 7, |s| passthrough.push(s.to_nmea_msg()));
        let s = rx.stats();
        assert_eq!(s.bad_checksum, 1);
        assert_eq!(s.missing_checksum, 2);
        assert_eq!(s.malformed, 1);
        assert_eq!(s.unsupported, 2);
        assert_eq!(s.accepted, 1);
        assert_eq!(s.truncated, 1);
        assert_eq!(s.non_printable, 1);
        assert_eq!(
            s.lines,
            s.accepted + s.unsupported + s.bad_checksum + s.missing_checksum + s.malformed
        );
        assert_eq!(s.bytes as usize, stream.len());
        let texts: Vec<&str> = passthrough.iter().map(|m| m.sentence.as_str()).collect();
        assert_eq!(
            texts,
            [
                "$GPGSV,1,1,00*79",
                "$PGRMZ,93,f,3*21",
                "$GPGGA,,,,,,0,,,,,,,,*66"
            ]
        );
        assert!(passthrough.iter().all(|m| m.stamp_us == 7));
    }

    #[test]
    fn never_panics_on_arbitrary_bytes() {
        use proptest::prelude::*;
        proptest!(|(bytes in proptest::collection::vec(any::<u8>(), 0..600), cut in 1usize..64)| {
            let mut rx = GpsReceiver::new();
            for chunk in bytes.chunks(cut) {
                rx.push(chunk, 0, |_| {});
            }
            let s = rx.stats();
            prop_assert_eq!(s.lines, s.accepted + s.unsupported + s.bad_checksum + s.missing_checksum + s.malformed);
        });
    }
}
