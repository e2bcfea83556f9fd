//! Throughput of the whole NMEA path on real receiver output: line assembly, checksum,
//! field decoding, exact latitude/longitude and fix reports ([`GpsReceiver`]).
//!
//! Input: the concatenation of every log in `nmea-real/` (gpsd comment lines removed),
//! pushed in 64-byte chunks as a UART DMA buffer would deliver them. Without the dataset the
//! bench prints why and does nothing.
//!
//! Run: `cargo bench -p firmware --bench nmea_throughput`.

use std::fs;
use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use firmware::nmea::GpsReceiver;

/// Bytes per push, like a UART DMA half-buffer.
const CHUNK_LEN: usize = 64;

/// Every `.log` under `dir` (recursively), comment lines removed, concatenated.
fn collect_logs(dir: &Path, out: &mut Vec<u8>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<_> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for path in paths {
        if path.is_dir() {
            collect_logs(&path, out);
        } else if path.extension().is_some_and(|e| e == "log") {
            let Ok(bytes) = fs::read(&path) else {
                continue;
            };
            for line in bytes.split_inclusive(|&b| b == b'\n') {
                if line.first() != Some(&b'#') {
                    out.extend_from_slice(line);
                }
            }
        }
    }
}

/// Runs the receiver over `stream` and returns the number of reports (so that nothing is
/// optimised away).
fn decode(stream: &[u8]) -> u32 {
    let mut receiver = GpsReceiver::new();
    let mut reports = 0u32;
    for (i, chunk) in stream.chunks(CHUNK_LEN).enumerate() {
        receiver.push(chunk, i as u64, |s| {
            if let Some(fix) = s.fix {
                black_box(&fix);
                reports += 1;
            }
        });
    }
    reports + receiver.stats().accepted
}

fn nmea_throughput(c: &mut Criterion) {
    let dir = datasets::path("nmea-real");
    let mut stream = Vec::new();
    collect_logs(&dir, &mut stream);
    if stream.is_empty() {
        eprintln!(
            "SKIPPED nmea_throughput: no logs under {} (set {} to the shared datasets)",
            dir.display(),
            datasets::ENV_VAR
        );
        return;
    }
    let mut group = c.benchmark_group("nmea");
    group.throughput(Throughput::Bytes(stream.len() as u64));
    group.bench_function("gps_receiver_real_logs", |b| {
        b.iter(|| decode(black_box(&stream)))
    });
    group.finish();
}

criterion_group!(benches, nmea_throughput);
criterion_main!(benches);
