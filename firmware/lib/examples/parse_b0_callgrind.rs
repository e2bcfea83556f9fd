//! Parses one 732-byte `B0h` telegram N times through the receiver and `ScanRepr::parse`, for
//! counting instructions with callgrind:
//!
//! ```text
//! cargo build --release -p firmware --example parse_b0_callgrind
//! valgrind --tool=callgrind target/release/examples/parse_b0_callgrind 0
//! valgrind --tool=callgrind target/release/examples/parse_b0_callgrind 1000
//! ```
//!
//! (difference of the two totals) / 1000 = instructions per telegram. The telegram is the
//! real capture `sick-real/dtu-usick-b0-361-mm.bin` when the datasets are present, otherwise
//! a 361-value scan built with `ScanRepr::emit`.

use std::hint::black_box;

use firmware::sick::{Event, Receiver, ScanRepr, Telegram};
use protocol::RangeUnit;

fn telegram_bytes() -> Vec<u8> {
    let path = datasets::path("sick-real/dtu-usick-b0-361-mm.bin");
    if let Ok(bytes) = std::fs::read(&path) {
        return bytes;
    }
    eprintln!("{} not found; using a synthetic scan", path.display());
    let scan = ScanRepr {
        unit: RangeUnit::Mm,
        partial_raster: None,
        values: (0..361u16).map(|i| 1000 + i * 7).collect(),
        indices: None,
        status: 0x10,
    };
    let mut bytes = vec![0u8; scan.buffer_len()];
    scan.emit(&mut Telegram::new_unchecked(&mut bytes[..]))
        .expect("buffer_len bytes");
    bytes
}

fn main() {
    let n: u32 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1000);
    let bytes = telegram_bytes();
    let mut receiver = Receiver::new();
    let mut now_us = 0u64;
    let mut values = 0usize;
    for _ in 0..n {
        for &byte in black_box(&bytes[..]) {
            now_us += 20;
            if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                if let Ok(scan) = ScanRepr::parse(&telegram) {
                    values += black_box(&scan).values.len();
                }
            }
        }
    }
    println!(
        "{n} telegrams, {values} values, {} ok",
        receiver.stats().telegrams_ok
    );
}
