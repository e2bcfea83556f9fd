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

#[path = "../benches/common/b0_telegram.rs"]
mod b0_telegram;

use std::hint::black_box;

use firmware::sick::{Event, Receiver, ScanRepr};

fn main() {
    let n: u32 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1000);
    let bytes = b0_telegram::telegram_bytes();
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
