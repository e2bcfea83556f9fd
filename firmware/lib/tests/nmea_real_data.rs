//! The firmware's NMEA receiver against 44 real receiver logs (`nmea-real`, see its
//! `SOURCES.md`).
//!
//! * `positions_and_times_agree_with_gpsd`: every gpsd log with a `.chk` file is replayed
//!   sentence by sentence in the order gpsd echoed them, and every gpsd `TPV` report with a
//!   position is compared with our latest report: latitude/longitude to the nanodegree
//!   (gpsd prints 9 decimals computed in `double`, so its last digit may differ by one), and
//!   the UTC time to the millisecond.
//! * `all_logs_decode_without_panic_and_counters_add_up`: every log, fed in several chunk
//!   sizes, gives the same counters, and every line is counted exactly once.
//! * `checksum_counts_match_the_sources_table`: bad-checksum and missing-checksum counts
//!   against the verification table of `SOURCES.md`.

use std::fs;
use std::path::{Path, PathBuf};

use firmware::nmea::{GpsReceiver, NmeaStats};
use protocol::{Date, FixQuality, GpsFixMsg, TimeOfDay};
use serde_json::Value;

/// The logs of a dataset folder, sorted.
fn logs_in(dir: &Path) -> Vec<PathBuf> {
    let mut logs: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "log"))
        .collect();
    logs.sort();
    logs
}

/// The log without gpsd's `#` comment lines.
fn strip_comments(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len());
    for line in bytes.split_inclusive(|&b| b == b'\n') {
        if line.first() != Some(&b'#') {
            out.extend_from_slice(line);
        }
    }
    out
}

/// Feeds `bytes` in chunks of `chunk` bytes (each chunk stamped with its offset) and returns
/// the reports and the counters.
fn replay(bytes: &[u8], chunk: usize) -> (Vec<GpsFixMsg>, NmeaStats) {
    let mut receiver = GpsReceiver::new();
    let mut fixes = Vec::new();
    for (i, piece) in bytes.chunks(chunk).enumerate() {
        receiver.push(piece, (i * chunk) as u64, |s| fixes.extend(s.fix));
    }
    (fixes, receiver.stats())
}

/// gpsd's decimal degrees as nanodegrees.
fn ndeg(value: &Value) -> i64 {
    (value.as_f64().unwrap() * 1e9).round() as i64
}

/// Our report's time as gpsd prints it (`2020-03-18T13:28:19.600Z`), or only the time of
/// day part when the report has no date.
fn iso_time(date: Option<Date>, time: TimeOfDay) -> String {
    let tod = format!(
        "{:02}:{:02}:{:02}.{:03}Z",
        time.hour,
        time.minute,
        time.second,
        time.micros / 1000
    );
    match date {
        Some(d) => format!("{:04}-{:02}-{:02}T{tod}", d.year, d.month, d.day),
        None => tod,
    }
}

/// Whether the exact value of a `ddmm.mmmm` field lies exactly halfway between two
/// nanodegrees (where gpsd's `double` may round down and we round away from zero).
fn is_half_nanodegree_tie(text: &str) -> bool {
    let (int_part, frac) = text.split_once('.').unwrap_or((text, ""));
    let k = frac.len() as u32;
    let int_part: u128 = int_part.parse().unwrap();
    let frac: u128 = if frac.is_empty() {
        0
    } else {
        frac.parse().unwrap()
    };
    let minutes_scaled = (int_part % 100) * 10u128.pow(k) + frac;
    (minutes_scaled * 1_000_000_000) % (60 * 10u128.pow(k)) == 30 * 10u128.pow(k)
}

/// The latitude and longitude text fields of a GGA, RMC or GLL sentence.
fn lat_lon_text(sentence: &str) -> (String, String) {
    let fields: Vec<&str> = sentence.split(',').collect();
    let first = match &fields[0][3..] {
        "GGA" => 2,
        "RMC" => 3,
        _ => 1,
    };
    (fields[first].to_string(), fields[first + 2].to_string())
}

/// Tallies of the comparison with gpsd's TPV reports.
#[derive(Debug, Default)]
struct Comparison {
    /// TPV reports with a position.
    tpv: usize,
    /// Positions equal to the nanodegree.
    exact: usize,
    /// Positions one nanodegree apart where the exact value is a tie (checked).
    tie_rounding: usize,
    /// gpsd reports a position where our latest report refuses one (§9 no-fix rule).
    refused_no_fix: Vec<String>,
    /// TPV times compared (TPV with `time`, our report with a time).
    times: usize,
    /// Times equal to the millisecond (date included when our report has one).
    times_equal: usize,
    /// Disagreements nothing above explains.
    unexplained: Vec<String>,
}

/// Policy differences with gpsd, one line each (file:line of the `.chk`):
///
/// * gpsd reports the position of sentences that say they have no fix (MTK-3301: GGA
///   quality 0 and RMC status `V` with a position, at the first fix attempt); we never
///   report a position then (§9), so our latest report has `quality: Invalid` and no
///   position.
/// * Latitude/longitude with 8 minute decimals sometimes land exactly halfway between two
///   nanodegrees; we round half away from zero, gpsd's `double` often rounds down. Every
///   such case is checked to be an exact tie; any other difference fails.
#[test]
fn positions_and_times_agree_with_gpsd() {
    let Some(dir) = datasets::require("nmea-real/gpsd", "positions_and_times_agree_with_gpsd")
    else {
        return;
    };
    let mut total = Comparison::default();
    let mut files = 0;
    for log in logs_in(&dir) {
        let Ok(chk_text) = fs::read_to_string(log.with_extension("log.chk")) else {
            continue;
        };
        if chk_text.trim().is_empty() {
            continue;
        }
        files += 1;
        let name = log.file_name().unwrap().to_string_lossy().into_owned();
        let mut receiver = GpsReceiver::new();
        let mut last: Option<(GpsFixMsg, String)> = None;
        let mut c = Comparison::default();
        for (line_no, line) in chk_text.lines().enumerate() {
            let at = format!("{name}.chk:{}", line_no + 1);
            if line.starts_with('$') {
                let bytes = format!("{line}\r\n");
                receiver.push(bytes.as_bytes(), line_no as u64, |s| {
                    if let Some(fix) = s.fix {
                        let text = String::from_utf8(s.sentence.as_bytes().to_vec()).unwrap();
                        last = Some((fix, text));
                    }
                });
                continue;
            }
            let Ok(json) = serde_json::from_str::<Value>(line) else {
                continue;
            };
            if json["class"] != "TPV" || json.get("lat").is_none() || json.get("lon").is_none() {
                continue;
            }
            c.tpv += 1;
            let gpsd = (ndeg(&json["lat"]), ndeg(&json["lon"]));
            let Some((ours, text)) = &last else {
                c.unexplained
                    .push(format!("{at}: gpsd reports before any report of ours"));
                continue;
            };
            match ours.position {
                None if ours.quality == FixQuality::Invalid => {
                    c.refused_no_fix.push(format!("{at}: {text}"));
                }
                None => c.unexplained.push(format!("{at}: no position in {text}")),
                Some(p) => {
                    let (lat_text, lon_text) = lat_lon_text(text);
                    let lat_ok = p.lat_ndeg == gpsd.0
                        || ((p.lat_ndeg - gpsd.0).abs() == 1 && is_half_nanodegree_tie(&lat_text));
                    let lon_ok = p.lon_ndeg == gpsd.1
                        || ((p.lon_ndeg - gpsd.1).abs() == 1 && is_half_nanodegree_tie(&lon_text));
                    if (p.lat_ndeg, p.lon_ndeg) == gpsd {
                        c.exact += 1;
                    } else if lat_ok && lon_ok {
                        c.tie_rounding += 1;
                    } else {
                        c.unexplained.push(format!(
                            "{at}: ours {:?} gpsd {gpsd:?} for {text}",
                            (p.lat_ndeg, p.lon_ndeg)
                        ));
                    }
                }
            }
            if let (Some(Value::String(t)), Some(time)) = (json.get("time"), ours.time) {
                c.times += 1;
                let mine = iso_time(ours.date, time);
                if t.ends_with(&mine) {
                    c.times_equal += 1;
                } else {
                    c.unexplained
                        .push(format!("{at}: time ours {mine} gpsd {t}"));
                }
            }
        }
        eprintln!(
            "{name}: TPV with position {}: exact {}, tie rounding {}, refused (no fix) {}, \
             times equal {}/{}",
            c.tpv,
            c.exact,
            c.tie_rounding,
            c.refused_no_fix.len(),
            c.times_equal,
            c.times
        );
        total.tpv += c.tpv;
        total.exact += c.exact;
        total.tie_rounding += c.tie_rounding;
        total.refused_no_fix.extend(c.refused_no_fix);
        total.times += c.times;
        total.times_equal += c.times_equal;
        total.unexplained.extend(c.unexplained);
    }
    eprintln!("total over {files} files: {total:#?}");
    assert!(files > 0);
    assert!(total.unexplained.is_empty(), "{:#?}", total.unexplained);
    assert_eq!(total.times_equal, total.times);
    assert_eq!(
        total.exact + total.tie_rounding + total.refused_no_fix.len(),
        total.tpv
    );
    // Refusals are the no-fix policy, and rare.
    assert!(
        total.refused_no_fix.len() * 100 <= total.tpv,
        "{:#?}",
        total.refused_no_fix
    );
}

#[test]
fn all_logs_decode_without_panic_and_counters_add_up() {
    let Some(root) = datasets::require(
        "nmea-real",
        "all_logs_decode_without_panic_and_counters_add_up",
    ) else {
        return;
    };
    let mut count = 0;
    for dir in ["gpsd", "rust-nmea", "nmea_navsat_driver"] {
        for log in logs_in(&root.join(dir)) {
            count += 1;
            let bytes = strip_comments(&fs::read(&log).unwrap());
            let (fixes, stats) = replay(&bytes, 4096);
            eprintln!("{}: {stats:?}", log.display());
            assert_eq!(
                stats.lines,
                stats.accepted
                    + stats.unsupported
                    + stats.bad_checksum
                    + stats.missing_checksum
                    + stats.malformed,
                "{}",
                log.display()
            );
            assert_eq!(stats.bytes as usize, bytes.len());
            assert_eq!(stats.fixes as usize, fixes.len());
            assert!(
                fixes
                    .iter()
                    .all(|f| f.position.is_none() || f.quality != FixQuality::Invalid)
            );
            for chunk in [1, 7, 80, 1 << 20] {
                let (other_fixes, other_stats) = replay(&bytes, chunk);
                assert_eq!(other_stats, stats, "{} chunk {chunk}", log.display());
                let strip = |f: &Vec<GpsFixMsg>| -> Vec<GpsFixMsg> {
                    f.iter().map(|f| GpsFixMsg { stamp_us: 0, ..*f }).collect()
                };
                assert_eq!(strip(&other_fixes), strip(&fixes));
            }
        }
    }
    assert_eq!(count, logs_in(&root.join("gpsd")).len() + 4);
}

/// One row of the verification table of `SOURCES.md`.
#[derive(Debug)]
struct TableRow {
    file: String,
    bad: u32,
    missing: u32,
}

/// Reads the verification table of `SOURCES.md`.
fn sources_table(sources: &str) -> Vec<TableRow> {
    sources
        .lines()
        .filter(|l| l.starts_with("| ") && l.contains(".log |"))
        .filter_map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            // | file | bytes | printable | $-sentences | ok | bad | no | …
            Some(TableRow {
                file: cells.get(1)?.to_string(),
                bad: cells.get(6)?.parse().ok()?,
                missing: cells.get(7)?.parse().ok()?,
            })
        })
        .collect()
}

#[test]
fn checksum_counts_match_the_sources_table() {
    let Some(root) = datasets::require("nmea-real", "checksum_counts_match_the_sources_table")
    else {
        return;
    };
    let table = sources_table(&fs::read_to_string(root.join("SOURCES.md")).unwrap());
    assert!(table.len() >= 40, "{} rows", table.len());
    let mut compared = 0;
    for row in &table {
        let Ok(raw) = fs::read(root.join(&row.file)) else {
            continue; // kept aside for independent evaluation
        };
        compared += 1;
        let (_, s) = replay(&strip_comments(&raw), 4096);
        let context = format!(
            "{}: table bad/none {}/{}, ours {s:?}",
            row.file, row.bad, row.missing
        );
        if s.truncated == 0 && s.non_printable == 0 {
            // Every sentence reached the checksum check, as in the table's script.
            assert_eq!(s.bad_checksum, row.bad, "{context}");
            assert_eq!(s.missing_checksum, row.missing, "{context}");
        } else {
            // A corrupted sentence may stop at the line layer (cut by a `$`: isync's
            // injected `$PTNTA`, gp-320fw's merged lines; escape codes in et-332) or fail the
            // grammar before its checksum is looked at.
            eprintln!("{context}");
            assert!(s.bad_checksum <= row.bad, "{context}");
            assert!(
                row.bad <= s.bad_checksum + s.truncated + s.non_printable + s.malformed,
                "{context}"
            );
        }
    }
    assert!(compared >= 30);
}
