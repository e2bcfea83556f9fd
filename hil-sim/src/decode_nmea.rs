//! `hil-sim decode-nmea FILE`: decodes an NMEA 0183 receiver log with the firmware's
//! [`GpsReceiver`] and prints what each position sentence says.
//!
//! * Lines starting with `#` (gpsd log metadata) are skipped; everything else goes through
//!   the firmware's line assembler and checksum check unchanged.
//! * stdout: one JSON object per decoded GGA, RMC and GLL sentence, with that sentence's own
//!   content and `null` for what it does not carry (a date only from RMC, altitude,
//!   satellites and HDOP only from GGA, speed and course only from RMC):
//!   `{"sentence":"GGA","time_utc":"hh:mm:ss.sss","date":"YYYY-MM-DD","lat_deg":…,
//!   "lon_deg":…,"alt_m":…,"fix_quality":…,"num_sats":…,"hdop":…,"speed_mps":…,
//!   "course_deg":…}`. `fix_quality` is the GGA quality digit (0 no fix … 8 simulator; for
//!   RMC/GLL the digit their status and mode imply). Without a fix (§9 of the protocol doc)
//!   latitude, longitude, altitude, speed and course are `null`, as in the firmware's
//!   reports. Latitude and longitude are printed with 9 decimals, exactly as the firmware
//!   holds them (nanodegrees); every number is printed from its fixed-point integer.
//! * stderr: a JSON summary of the receiver's counters.

use std::error::Error;
use std::fmt::Write as _;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use firmware::nmea::{GgaRepr, GllRepr, GpsReceiver, NmeaStats, RmcRepr, Sentence, SentenceKind};
use protocol::{Date, FixQuality, Position, TimeOfDay};

/// Runs the command on `file`.
///
/// # Errors
/// When the file cannot be read (the message names the path) or stdout fails.
pub fn run(file: &Path) -> Result<(), Box<dyn Error>> {
    let raw = fs::read(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let stdout = io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let summary = decode(&strip_comments(&raw), &mut out)?;
    out.flush()?;
    eprintln!("{}", summary_json(&summary));
    Ok(())
}

/// What [`decode`] saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Summary {
    /// The receiver's counters.
    pub stats: NmeaStats,
    /// Position sentences printed.
    pub position_sentences: u32,
}

/// The log without lines starting with `#`.
fn strip_comments(bytes: &[u8]) -> Vec<u8> {
    let mut kept = Vec::with_capacity(bytes.len());
    for line in bytes.split_inclusive(|&b| b == b'\n') {
        if line.first() != Some(&b'#') {
            kept.extend_from_slice(line);
        }
    }
    kept
}

/// Decodes `stream` and writes one JSON line per position sentence to `out`.
///
/// # Errors
/// When writing to `out` fails.
pub fn decode(stream: &[u8], out: &mut impl Write) -> io::Result<Summary> {
    let mut receiver = GpsReceiver::new();
    let mut rest = stream;
    let mut printed = 0u32;
    let mut line = String::new();
    while let Some(result) = receiver.next_sentence(&mut rest, 0) {
        let Ok(received) = result else {
            continue;
        };
        line.clear();
        if position_json(&received.sentence, &mut line) {
            writeln!(out, "{line}")?;
            printed += 1;
        }
    }
    Ok(Summary {
        stats: receiver.stats(),
        position_sentences: printed,
    })
}

/// The sentence's own content, fix-dependent fields blanked without a fix.
struct Row {
    sentence: &'static str,
    time: Option<TimeOfDay>,
    date: Option<Date>,
    position: Option<Position>,
    alt_mm: Option<i32>,
    quality: Option<FixQuality>,
    num_sats: Option<u8>,
    hdop_centi: Option<u16>,
    speed_mm_s: Option<u32>,
    course_cdeg: Option<u32>,
}

impl Row {
    fn gga(gga: &GgaRepr) -> Self {
        let fix = gga.fix_position().is_some();
        Row {
            sentence: "GGA",
            time: gga.time,
            date: None,
            position: gga.fix_position(),
            alt_mm: gga.alt_msl_mm.filter(|_| fix),
            quality: gga.quality,
            num_sats: gga.num_sats,
            hdop_centi: gga.hdop_centi,
            speed_mm_s: None,
            course_cdeg: None,
        }
    }

    fn rmc(rmc: &RmcRepr) -> Self {
        let fix = rmc.quality() != FixQuality::Invalid;
        Row {
            sentence: "RMC",
            time: rmc.time,
            date: rmc.date,
            position: rmc.fix_position(),
            alt_mm: None,
            quality: Some(rmc.quality()),
            num_sats: None,
            hdop_centi: None,
            speed_mm_s: rmc.speed_mm_s.filter(|_| fix),
            course_cdeg: rmc.course_cdeg.filter(|_| fix),
        }
    }

    fn gll(gll: &GllRepr) -> Self {
        Row {
            sentence: "GLL",
            time: gll.time,
            date: None,
            position: gll.fix_position(),
            alt_mm: None,
            quality: Some(gll.quality()),
            num_sats: None,
            hdop_centi: None,
            speed_mm_s: None,
            course_cdeg: None,
        }
    }
}

/// Writes the JSON object of a GGA, RMC or GLL sentence into `out`; `false` for other
/// sentences (and for ones that do not decode, which the receiver has already rejected).
fn position_json(sentence: &Sentence<&[u8]>, out: &mut String) -> bool {
    let row = match sentence.kind() {
        SentenceKind::Gga => GgaRepr::parse(sentence).map(|r| Row::gga(&r)),
        SentenceKind::Rmc => RmcRepr::parse(sentence).map(|r| Row::rmc(&r)),
        SentenceKind::Gll => GllRepr::parse(sentence).map(|r| Row::gll(&r)),
        _ => return false,
    };
    let Ok(row) = row else {
        return false;
    };
    let time = row.time.map(|t| {
        format!(
            "\"{:02}:{:02}:{:02}.{:03}\"",
            t.hour,
            t.minute,
            t.second,
            t.micros / 1000
        )
    });
    let date = row
        .date
        .map(|d| format!("\"{:04}-{:02}-{:02}\"", d.year, d.month, d.day));
    let _ = write!(
        out,
        "{{\"sentence\":\"{}\",\"time_utc\":{},\"date\":{},\"lat_deg\":{},\"lon_deg\":{},\
         \"alt_m\":{},\"fix_quality\":{},\"num_sats\":{},\"hdop\":{},\"speed_mps\":{},\
         \"course_deg\":{}}}",
        row.sentence,
        or_null(time),
        or_null(date),
        or_null(row.position.map(|p| fixed(p.lat_ndeg, 9))),
        or_null(row.position.map(|p| fixed(p.lon_ndeg, 9))),
        or_null(row.alt_mm.map(|v| fixed(v.into(), 3))),
        or_null(row.quality.map(|q| q.gga_digit().to_string())),
        or_null(row.num_sats.map(|n| n.to_string())),
        or_null(row.hdop_centi.map(|v| fixed(v.into(), 2))),
        or_null(row.speed_mm_s.map(|v| fixed(v.into(), 3))),
        or_null(row.course_cdeg.map(|v| fixed(v.into(), 2))),
    );
    true
}

/// `value` × 10^−`decimals` as decimal text, exactly (`-93750571901`, 9 → `-93.750571901`).
fn fixed(value: i64, decimals: u32) -> String {
    let scale = 10u64.pow(decimals);
    let magnitude = value.unsigned_abs();
    let sign = if value < 0 { "-" } else { "" };
    format!(
        "{sign}{}.{:0width$}",
        magnitude / scale,
        magnitude % scale,
        width = decimals as usize
    )
}

/// The JSON text of an optional value.
fn or_null(value: Option<String>) -> String {
    value.unwrap_or_else(|| "null".to_owned())
}

/// The summary line printed on stderr.
fn summary_json(summary: &Summary) -> String {
    let s = &summary.stats;
    format!(
        "{{\"bytes\":{},\"lines\":{},\"accepted\":{},\"unsupported\":{},\"bad_checksum\":{},\
         \"missing_checksum\":{},\"malformed\":{},\"truncated\":{},\"too_long\":{},\
         \"non_printable\":{},\"fixes\":{},\"duplicates\":{},\"position_sentences\":{}}}",
        s.bytes,
        s.lines,
        s.accepted,
        s.unsupported,
        s.bad_checksum,
        s.missing_checksum,
        s.malformed,
        s.truncated,
        s.too_long,
        s.non_printable,
        s.fixes,
        s.duplicates,
        summary.position_sentences
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::Value;

    const LOG: &[u8] = b"# Name: test receiver\r\n\
        $GNGGA,132819.60,4134.49795459,N,09345.03431408,W,2,10,0.9,278.161,M,-31.442,M,6.6,0133*6A\r\n\
        $GNRMC,132819.60,A,4134.49795459,N,09345.03431408,W,0.148,124.888,180320,11.5985,E,D*3F\r\n\
        $GPGGA,,,,,,0,,,,,,,,*66\r\n\
        $GPGGA,,,,,,0,,,,,,,,*67\r\n\
        $GPGSV,1,1,00*79\r\n\
        $GPGLL,4916.45,N,12311.12,W,225444,A*31\r\n";

    fn decode_to_json(log: &[u8]) -> (Vec<Value>, Summary) {
        let mut out = Vec::new();
        let summary = decode(&strip_comments(log), &mut out).unwrap();
        let rows = String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        (rows, summary)
    }

    #[test]
    fn one_object_per_position_sentence() {
        let (rows, summary) = decode_to_json(LOG);
        assert_eq!(rows.len(), 4);
        assert_eq!(summary.position_sentences, 4);
        assert_eq!(summary.stats.bad_checksum, 1);
        assert_eq!(summary.stats.unsupported, 1);
        let gga = &rows[0];
        assert_eq!(gga["sentence"], "GGA");
        assert_eq!(gga["time_utc"], "13:28:19.600");
        assert_eq!(gga["date"], Value::Null);
        assert_eq!(gga["fix_quality"], 2);
        assert_eq!(gga["num_sats"], 10);
        assert_eq!(gga["speed_mps"], Value::Null);
        let rmc = &rows[1];
        assert_eq!(rmc["date"], "2020-03-18");
        assert_eq!(rmc["alt_m"], Value::Null);
        let no_fix = &rows[2];
        assert_eq!(no_fix["lat_deg"], Value::Null);
        assert_eq!(no_fix["fix_quality"], 0);
        assert_eq!(no_fix["time_utc"], Value::Null);
        assert_eq!(rows[3]["sentence"], "GLL");
    }

    #[test]
    fn numbers_are_printed_exactly() {
        let mut out = Vec::new();
        decode(&LOG[23..], &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let first = text.lines().next().unwrap();
        assert!(
            first.contains("\"lat_deg\":41.574965910,\"lon_deg\":-93.750571901"),
            "{first}"
        );
        assert!(first.contains("\"alt_m\":278.161"), "{first}");
        assert!(first.contains("\"hdop\":0.90"), "{first}");
        let rmc = text.lines().nth(1).unwrap();
        assert!(
            rmc.contains("\"speed_mps\":0.076,\"course_deg\":124.89"),
            "{rmc}"
        );
        assert_eq!(fixed(-5, 9), "-0.000000005");
    }

    #[test]
    fn missing_file_error_names_the_path() {
        let err = run(Path::new("/no/such/nmea.log")).unwrap_err();
        assert!(err.to_string().contains("/no/such/nmea.log"), "{err}");
    }

    #[test]
    fn summary_is_json() {
        let (_, summary) = decode_to_json(LOG);
        let v: Value = serde_json::from_str(&summary_json(&summary)).unwrap();
        assert_eq!(v["accepted"], 4);
        assert_eq!(v["bad_checksum"], 1);
        assert_eq!(v["missing_checksum"], 0);
        assert_eq!(v["malformed"], 0);
    }
}
