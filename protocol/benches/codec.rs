//! Encode and decode cost of the largest frame (a 361-value scan) and of a heartbeat.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use protocol::{Decoder, Encoder, HeartbeatMsg, MAX_WIRE_LEN, Message, RangeUnit, ScanMsg};
use std::hint::black_box;

fn scan_361() -> Message {
    let values: Vec<u16> = (0..361).map(|i| 1000 + (i * 7 % 3000) as u16).collect();
    Message::Scan(ScanMsg {
        stamp_us: 12_345_678,
        scan_counter: 1000,
        start_angle_cdeg: 0,
        step_angle_cdeg: 50,
        unit: RangeUnit::Mm,
        count_word: 0x4169,
        values: heapless::Vec::from_slice(&values).unwrap_or_default(),
        status: 0x10,
        sensor_indices: None,
    })
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("codec");
    for (name, message) in [
        ("scan_361", scan_361()),
        (
            "heartbeat",
            Message::Heartbeat(HeartbeatMsg { uptime_us: 1 }),
        ),
    ] {
        let mut out = [0u8; MAX_WIRE_LEN];
        let wire = Encoder::new()
            .encode(&message, &mut out)
            .map(<[u8]>::to_vec)
            .unwrap_or_default();
        group.throughput(Throughput::Bytes(wire.len() as u64));
        group.bench_function(format!("encode_{name}"), |b| {
            let mut enc = Encoder::new();
            let mut out = [0u8; MAX_WIRE_LEN];
            b.iter(|| {
                enc.encode(black_box(&message), &mut out)
                    .map(|w| w.len())
                    .unwrap_or(0)
            })
        });
        group.bench_function(format!("decode_{name}"), |b| {
            let mut dec = Decoder::new();
            b.iter(|| {
                let mut n = 0;
                dec.feed(black_box(&wire), |_| n += 1);
                n
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
