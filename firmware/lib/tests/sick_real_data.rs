//! The SICK receiver against real LMS200 sessions (AtlasBuggy, CMU, 2017; 180° at 0.5°, mm,
//! 38 400 Bd): every `*.lms-to-host.bin` in `benchmark/lms200` must yield exactly the scans
//! of its `*.scans.jsonl` (count word, raw values, status; same order and count), including
//! the three sessions with real mis-synchronised reads whose checksums fail.
//!
//! Byte times are reconstructed as byte index × 10 bit / 38 400 Bd (the logs keep no
//! timing), so no inter-byte timeout fires.

use std::path::Path;

use firmware::sick::{Event, Receiver, ReceiverStats, ScanRepr};

/// Sessions whose capture holds mis-synchronised reads (dataset notes).
const DAMAGED: [&str; 3] = [
    "2017_Aug_05_19-07-55",
    "2017_Aug_05_19-09-36",
    "2017_Aug_05_19-10-47",
];

/// µs per byte at 38 400 Bd, 10 bits per byte, ×1000 to stay in integers.
const BYTE_NS: u64 = 10 * 1_000_000_000 / 38_400;

#[derive(Debug, PartialEq, Eq)]
struct Scan {
    count_word: u16,
    values: Vec<u16>,
    status: u8,
}

fn decode(bytes: &[u8]) -> (Vec<Scan>, ReceiverStats) {
    let mut receiver = Receiver::new();
    let mut scans = Vec::new();
    let mut keep = |event: Event<'_>| {
        if let Event::Telegram { telegram, .. } = event {
            if telegram.command() == 0xB0 {
                let scan = ScanRepr::parse(&telegram).expect("valid B0");
                scans.push(Scan {
                    count_word: scan.count_word(),
                    values: scan.values.to_vec(),
                    status: scan.status,
                });
            }
        }
    };
    let mut now_us = 0;
    for (i, &byte) in bytes.iter().enumerate() {
        now_us = i as u64 * BYTE_NS / 1_000;
        if let Some(event) = receiver.push(byte, now_us) {
            keep(event);
        }
    }
    while let Some(event) = receiver.poll(now_us + 1_000_000) {
        keep(event);
    }
    (scans, receiver.stats())
}

fn expected(path: &Path) -> Vec<Scan> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .filter(|line| !line.trim().is_empty())
        .map(|line| {
            let v: serde_json::Value = serde_json::from_str(line).unwrap();
            Scan {
                count_word: v["count_word"].as_u64().unwrap() as u16,
                values: v["values"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_u64().unwrap() as u16)
                    .collect(),
                status: v["status"].as_u64().unwrap() as u8,
            }
        })
        .collect()
}

#[test]
fn lms200_sessions_reproduce_scans() {
    let Some(dir) = datasets::require("benchmark/lms200", "lms200_sessions_reproduce_scans") else {
        return;
    };
    let mut sessions: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".lms-to-host.bin"))
        .collect();
    sessions.sort();
    assert!(!sessions.is_empty(), "no sessions in {}", dir.display());
    let mut total = ReceiverStats::default();
    let mut total_scans = 0;
    let mut damaged_seen = 0;
    for path in &sessions {
        let name = path
            .file_name()
            .unwrap()
            .to_string_lossy()
            .replace(".lms-to-host.bin", "");
        let bytes = std::fs::read(path).unwrap();
        let (scans, stats) = decode(&bytes);
        let want = expected(&dir.join(format!("{name}.scans.jsonl")));
        assert_eq!(scans.len(), want.len(), "{name}: scan count");
        for (k, (got, want)) in scans.iter().zip(&want).enumerate() {
            assert_eq!(got, want, "{name}: scan {k}");
        }
        assert_eq!(stats.bytes as usize, bytes.len());
        assert_eq!(
            stats.bytes,
            stats.telegram_bytes + stats.acks + stats.naks + stats.garbage_bytes,
            "{name}: every byte accounted"
        );
        if DAMAGED.contains(&name.as_str()) {
            damaged_seen += 1;
            assert!(
                stats.crc_errors > 0 && stats.resyncs > 0,
                "{name}: {stats:?}"
            );
        } else {
            assert_eq!(stats.crc_errors, 0, "{name}: {stats:?}");
        }
        println!(
            "{name}: {} bytes, {} telegrams ({} scans), {} CRC errors, {} bad lengths, {} bad \
             addresses, {} timeouts, {} resyncs, {} ACK, {} NAK, {} garbage bytes",
            stats.bytes,
            stats.telegrams_ok,
            scans.len(),
            stats.crc_errors,
            stats.bad_length,
            stats.bad_address,
            stats.timeouts,
            stats.resyncs,
            stats.acks,
            stats.naks,
            stats.garbage_bytes
        );
        total_scans += scans.len();
        total.bytes += stats.bytes;
        total.telegrams_ok += stats.telegrams_ok;
        total.crc_errors += stats.crc_errors;
        total.bad_length += stats.bad_length;
        total.bad_address += stats.bad_address;
        total.resyncs += stats.resyncs;
        total.acks += stats.acks;
        total.garbage_bytes += stats.garbage_bytes;
    }
    assert_eq!(damaged_seen, DAMAGED.len());
    println!(
        "total: {} sessions, {} bytes, {} telegrams, {} scans, {} CRC errors, {} bad lengths, {} \
         bad addresses, {} resyncs, {} ACK, {} garbage bytes",
        sessions.len(),
        total.bytes,
        total.telegrams_ok,
        total_scans,
        total.crc_errors,
        total.bad_length,
        total.bad_address,
        total.resyncs,
        total.acks,
        total.garbage_bytes
    );
}

#[test]
fn damaged_sessions_keep_the_replies_after_the_fragments() {
    // In these sessions a host request cut a scan short; the ACK and the type reply `BAh`
    // that follow the fragment lie inside its announced 732 bytes and must not be lost.
    for name in DAMAGED {
        let rel = format!("benchmark/lms200/{name}.lms-to-host.bin");
        let Some(path) = datasets::require(
            &rel,
            "damaged_sessions_keep_the_replies_after_the_fragments",
        ) else {
            return;
        };
        let bytes = std::fs::read(path).unwrap();
        let mut receiver = Receiver::new();
        let mut codes = Vec::new();
        let mut now_us = 0;
        for (i, &byte) in bytes.iter().enumerate() {
            now_us = i as u64 * BYTE_NS / 1_000;
            if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                codes.push(telegram.command());
            }
        }
        // The last fragment ends the capture: its re-examination happens when the line is
        // quiet.
        while let Some(event) = receiver.poll(now_us + 1_000_000) {
            if let Event::Telegram { telegram, .. } = event {
                codes.push(telegram.command());
            }
        }
        assert!(codes.contains(&0xBA), "{name}: {codes:02x?}");
        assert!(codes.contains(&0xA0), "{name}: {codes:02x?}");
    }
}
