//! `hil-sim decode-sick FILE`: runs a raw SICK LMS2xx → host byte stream through the
//! firmware's [`Receiver`] and prints every valid measured-value telegram `B0h`.
//!
//! * stdout: one JSON object per scan, `{"count_word":…,"values":[…],"status":…}`, with the
//!   raw 16-bit range words as sent (flag bits included), in stream order.
//! * stderr: a JSON object with the receiver's counters (bytes, accepted telegrams, CRC
//!   errors, resynchronisations, …) and the number of scans.
//!
//! Captures carry no timing, so byte i is taken to arrive at i × 10 bit / 38 400 Bd (the
//! rate of the public LMS200 sessions): bytes follow each other without pause and the
//! inter-byte timeout only drops a fragment left at the end of the file.

use std::error::Error;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use firmware::sick::{Event, Receiver, ReceiverStats, ScanRepr, reply};
use serde::Serialize;

/// Nanoseconds per byte at 38 400 Bd, 10 bits per byte.
const BYTE_NS: u64 = 10 * 1_000_000_000 / 38_400;

/// Runs the command on `file`.
///
/// # Errors
/// When the file cannot be read (the message names the path) or stdout fails.
pub fn run(file: &Path) -> Result<(), Box<dyn Error>> {
    let bytes = fs::read(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let stdout = io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let summary = decode(&bytes, &mut out)?;
    out.flush()?;
    eprintln!("{}", serde_json::to_string(&SummaryJson::from(&summary))?);
    Ok(())
}

/// What [`decode`] saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Summary {
    /// The receiver's counters.
    pub stats: ReceiverStats,
    /// Scans printed.
    pub scans: u32,
    /// `B0h` telegrams with a valid checksum that [`ScanRepr::parse`] refused.
    pub bad_scans: u32,
}

/// One output line.
#[derive(Serialize)]
struct ScanJson<'a> {
    count_word: u16,
    values: &'a [u16],
    status: u8,
}

/// The summary line.
#[derive(Serialize)]
struct SummaryJson {
    bytes: u32,
    telegrams_ok: u32,
    crc_errors: u32,
    resyncs: u32,
    bad_length: u32,
    bad_address: u32,
    timeouts: u32,
    acks: u32,
    naks: u32,
    garbage_bytes: u32,
    scans: u32,
    bad_scans: u32,
}

impl From<&Summary> for SummaryJson {
    fn from(summary: &Summary) -> Self {
        let s = &summary.stats;
        SummaryJson {
            bytes: s.bytes,
            telegrams_ok: s.telegrams_ok,
            crc_errors: s.crc_errors,
            resyncs: s.resyncs,
            bad_length: s.bad_length,
            bad_address: s.bad_address,
            timeouts: s.timeouts,
            acks: s.acks,
            naks: s.naks,
            garbage_bytes: s.garbage_bytes,
            scans: summary.scans,
            bad_scans: summary.bad_scans,
        }
    }
}

/// Decodes `bytes` and writes one JSON line per scan to `out`.
///
/// # Errors
/// When writing to `out` fails.
pub fn decode(bytes: &[u8], out: &mut impl Write) -> Result<Summary, Box<dyn Error>> {
    let mut receiver = Receiver::new();
    let mut summary = Summary::default();
    let mut now_us = 0;
    for (i, &byte) in bytes.iter().enumerate() {
        now_us = i as u64 * BYTE_NS / 1_000;
        if let Some(event) = receiver.push(byte, now_us) {
            print_scan(event, out, &mut summary)?;
        }
    }
    // End of capture: the line goes quiet; release what is still buffered.
    while let Some(event) = receiver.poll(now_us.saturating_add(1_000_000)) {
        print_scan(event, out, &mut summary)?;
    }
    summary.stats = receiver.stats();
    Ok(summary)
}

fn print_scan(
    event: Event<'_>,
    out: &mut impl Write,
    summary: &mut Summary,
) -> Result<(), Box<dyn Error>> {
    let Event::Telegram { telegram, .. } = event else {
        return Ok(());
    };
    if telegram.command() != reply::code::SCAN {
        return Ok(());
    }
    match ScanRepr::parse(&telegram) {
        Ok(scan) => {
            let line = ScanJson {
                count_word: scan.count_word(),
                values: &scan.values,
                status: scan.status,
            };
            serde_json::to_writer(&mut *out, &line)?;
            out.write_all(b"\n")?;
            summary.scans += 1;
        }
        Err(_) => summary.bad_scans += 1,
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The synthetic 3-value scan of the protocol notes §11, an ACK, and noise.
    const STREAM: [u8; 19] = [
        0x33, 0x06, 0x02, 0x80, 0x0A, 0x00, 0xB0, 0x03, 0x40, 0xE8, 0x03, 0xD0, 0x07, 0xFF, 0x1F,
        0x10, 0x16, 0xB1, 0x99,
    ];

    #[test]
    fn prints_scans_and_counts() {
        let mut out = Vec::new();
        let summary = decode(&STREAM, &mut out).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "{\"count_word\":16387,\"values\":[1000,2000,8191],\"status\":16}\n"
        );
        assert_eq!(summary.scans, 1);
        assert_eq!(summary.stats.bytes, 19);
        assert_eq!((summary.stats.acks, summary.stats.garbage_bytes), (1, 2));
    }

    #[test]
    fn missing_file_names_the_path() {
        let err = run(Path::new("/no/such/capture.bin")).unwrap_err();
        assert!(err.to_string().contains("/no/such/capture.bin"), "{err}");
    }

    #[test]
    fn lms200_session_matches_scans_jsonl() {
        let name = "2017_Aug_04_23-25-00";
        let Some(bin) = datasets::require(
            &format!("benchmark/lms200/{name}.lms-to-host.bin"),
            "lms200_session_matches_scans_jsonl",
        ) else {
            return;
        };
        let bytes = fs::read(bin).unwrap();
        let mut out = Vec::new();
        decode(&bytes, &mut out).unwrap();
        let expected = fs::read_to_string(datasets::path(&format!(
            "benchmark/lms200/{name}.scans.jsonl"
        )))
        .unwrap();
        let got: Vec<serde_json::Value> = String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        let want: Vec<serde_json::Value> = expected
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(got, want);
    }
}
