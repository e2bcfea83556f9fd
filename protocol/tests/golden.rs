//! Golden wire bytes for every message kind: a change to any of them is a protocol change and
//! must come with a new `PROTOCOL_VERSION`.
//!
//! The expected bytes were produced by encoding `samples::all()` with sequence numbers 0, 1, 2…
//! and checked by hand against the frame layout (version, kind, seq, postcard, CRC-32, COBS, 0).

mod samples;

use protocol::*;

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

const GOLDEN: &[&str] = &[
    "030201010587ad4b2a0e640183800103e807d00fff3f1005f9daeb1300", // Scan
    "0402020105c096b10228475001e80f0309010c2313a0c21e0101c0ec9dc0e602d68c93e75501f0c94201e8dc050108015a0102010101010701b00901840704f2945e0100", // GpsFix
    "0402020208809bee0201474e0101010101010101010105bd9a547700", // GpsFix, no fix
    "040203031f07182447504747412c2c2c2c2c2c302c2c2c2c2c2c2c2c2a3636cd80f28c00", // Nmea
    "040204040b80ade204f0bb04640102060304bc050a01010101010101010101010b03a0c21e02096cea6f1d00", // Status
    "0402050506052b629dfd00",                                   // Heartbeat
    "040206061701020f6c6173657220726573746172746564afcc826600", // Log
    "0402070703034409e807e707a0a3a88900",                       // Ack
    "0402410808010101bf37599100",                               // ConfigureLaser
    "040242090601d23f29f500",                                   // SetStreaming
    "0402430a0584cc7e0300",                                     // RequestStatus
    "0402440b07e707a889230900",                                 // TimeSyncPing
    "0402080c0980897a026c30495b00",                             // Pps
];

#[test]
fn test_emit() {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_WIRE_LEN];
    assert_eq!(samples::all().len(), GOLDEN.len());
    for (m, golden) in samples::all().iter().zip(GOLDEN) {
        assert_eq!(
            hex(enc.encode(m, &mut out).unwrap()),
            *golden,
            "{:?}",
            m.kind()
        );
    }
}

#[test]
fn test_parse() {
    let mut dec = Decoder::new();
    for (i, (m, golden)) in samples::all().into_iter().zip(GOLDEN).enumerate() {
        let bytes = unhex(golden);
        let (last, body) = bytes.split_last().unwrap();
        assert_eq!(*last, 0);
        for &b in body {
            assert!(dec.push(b).is_none());
        }
        let received = dec.push(0).unwrap().unwrap();
        assert_eq!(received.header.seq, i as u16);
        assert_eq!(received.header.kind, m.kind());
        assert_eq!(received.lost_before, 0);
        assert_eq!(received.message, m);
    }
    assert_eq!(dec.stats().frames, GOLDEN.len() as u64);
}

#[test]
fn test_deconstruct() {
    // The heartbeat, by hand: COBS block [02 05 05], block [05 2b 62 9d fd], delimiter.
    let mut raw = unhex(GOLDEN[5]);
    raw.pop();
    let n = cobs::decode_in_place(&mut raw).unwrap();
    let frame = Frame::new_checked(&raw[..n]).unwrap();
    assert_eq!(frame.version(), PROTOCOL_VERSION);
    assert_eq!(frame.kind(), Kind::Heartbeat);
    assert_eq!(frame.seq(), 5);
    assert_eq!(frame.payload(), &[0x05]);
    assert_eq!(frame.crc(), 0xfd9d_622b);
    assert!(frame.check_crc().is_ok());
    assert_eq!(
        Message::parse(&frame),
        Ok(Message::Heartbeat(HeartbeatMsg { uptime_us: 5 }))
    );
}

#[test]
fn buffer_len_matches_emit() {
    for m in samples::all() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        assert_eq!(m.emit(0, &mut buf), Ok(m.buffer_len()));
        assert_eq!(
            m.emit(0, &mut buf[..m.buffer_len() - 1]),
            Err(MessageError::BufferTooSmall)
        );
    }
}

/// Prints the wire bytes of the samples (run with `--ignored --nocapture` after a deliberate change).
#[test]
#[ignore]
fn print_golden() {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_WIRE_LEN];
    for m in samples::all() {
        println!(
            "    \"{}\", // {:?}",
            hex(enc.encode(&m, &mut out).unwrap()),
            m.kind()
        );
    }
}
