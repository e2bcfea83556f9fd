//! Cost of receiving one 732-byte `B0h` telegram (361 values): every byte through
//! `Receiver::push`, then `ScanRepr::parse`. Also the receiver alone, the checksum alone and
//! the conversion to the host message.
//!
//! The telegram is the real capture `sick-real/dtu-usick-b0-361-mm.bin` when the datasets
//! are present, otherwise a 361-value scan built with `ScanRepr::emit`. For instruction
//! counts see `examples/parse_b0_callgrind.rs`.

#[path = "common/b0_telegram.rs"]
mod b0_telegram;

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use firmware::sick::{Event, Receiver, ScanRepr, Telegram, crc16};

fn bench(c: &mut Criterion) {
    let bytes = b0_telegram::telegram_bytes();
    let mut group = c.benchmark_group("sick_parse");
    group.throughput(Throughput::Bytes(bytes.len() as u64));

    group.bench_function("parse one 732-byte B0 telegram", |b| {
        let mut receiver = Receiver::new();
        let mut now_us = 0u64;
        b.iter(|| {
            let mut values = 0;
            for &byte in black_box(&bytes[..]) {
                now_us += 20;
                if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                    if let Ok(scan) = ScanRepr::parse(&telegram) {
                        values = black_box(scan).values.len();
                    }
                }
            }
            values
        })
    });

    group.bench_function("receiver only", |b| {
        let mut receiver = Receiver::new();
        let mut now_us = 0u64;
        b.iter(|| {
            let mut len = 0;
            for &byte in black_box(&bytes[..]) {
                now_us += 20;
                if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                    len = telegram.total_len();
                }
            }
            len
        })
    });

    group.bench_function("crc16 over 730 bytes", |b| {
        b.iter(|| crc16(black_box(&bytes[..bytes.len() - 2])))
    });

    let telegram = Telegram::new_checked(&bytes[..]).expect("a whole telegram");
    let scan = ScanRepr::parse(&telegram).expect("a valid scan");
    group.bench_function("ScanRepr::parse", |b| {
        b.iter(|| ScanRepr::parse(black_box(&telegram)))
    });
    group.bench_function("ScanRepr::to_msg", |b| {
        b.iter(|| black_box(&scan).to_msg(1, 2, 0, 50))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
