//! Stream behaviour of the decoder: corrupt, foreign and lost frames are counted, never fatal,
//! and never cost the frame after them.

mod samples;

use protocol::*;

fn wire(enc: &mut Encoder, m: &Message) -> Vec<u8> {
    let mut out = [0u8; MAX_WIRE_LEN];
    enc.encode(m, &mut out).unwrap().to_vec()
}

fn decode_all(dec: &mut Decoder, bytes: &[u8]) -> Vec<Received> {
    let mut got = Vec::new();
    dec.feed(bytes, |r| got.push(r));
    got
}

/// Re-frames a raw frame (header + payload + CRC) for the wire.
fn frame_raw(raw: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; cobs::max_encoding_length(raw.len()) + 1];
    let n = cobs::encode(raw, &mut out);
    out.truncate(n);
    out.push(0);
    out
}

#[test]
fn corrupt_frame_costs_only_itself() {
    let mut enc = Encoder::new();
    let mut stream = wire(&mut enc, &Message::Heartbeat(samples::heartbeat()));
    let mut bad = wire(&mut enc, &Message::Scan(samples::scan()));
    bad[5] ^= 0x01;
    stream.extend(bad);
    stream.extend(wire(&mut enc, &Message::Status(samples::status())));
    let mut dec = Decoder::new();
    let got = decode_all(&mut dec, &stream);
    assert_eq!(got.len(), 2);
    assert_eq!(
        got[1].lost_before, 1,
        "the corrupted frame shows up as a sequence gap"
    );
    let stats = dec.stats();
    assert_eq!(stats.crc_errors, 1);
    assert_eq!(stats.lost, 1);
    assert_eq!(stats.bytes, stream.len() as u64);
}

#[test]
fn unknown_kind_and_newer_version_are_skipped_and_counted() {
    let mut raw = [0u8; 64];
    let n = Message::Heartbeat(samples::heartbeat())
        .emit(0, &mut raw)
        .unwrap();
    // Same frame, kind 0x7e.
    let mut unknown = raw[..n].to_vec();
    unknown[1] = 0x7e;
    let mut f = Frame::new_unchecked(&mut unknown[..]);
    f.fill_crc();
    // Same frame, version 2, seq 1.
    let mut newer = raw[..n].to_vec();
    newer[0] = PROTOCOL_VERSION + 1;
    newer[2] = 1;
    let mut f = Frame::new_unchecked(&mut newer[..]);
    f.fill_crc();
    // Then a good frame with seq 2.
    let mut good = raw[..n].to_vec();
    good[2] = 2;
    let mut f = Frame::new_unchecked(&mut good[..]);
    f.fill_crc();

    let mut stream = frame_raw(&unknown);
    stream.extend(frame_raw(&newer));
    stream.extend(frame_raw(&good));
    let mut dec = Decoder::new();
    let got = decode_all(&mut dec, &stream);
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].lost_before, 0);
    let s = dec.stats();
    assert_eq!(
        (s.unknown_kind, s.unsupported_version, s.lost, s.frames),
        (1, 1, 0, 1)
    );
}

#[test]
fn malformed_payload_is_counted() {
    let mut raw = [0u8; 64];
    let n = Message::Heartbeat(samples::heartbeat())
        .emit(0, &mut raw)
        .unwrap();
    let mut extra = raw[..n - 4].to_vec();
    extra.push(0x00); // a trailing byte after the message
    extra.extend([0; 4]);
    let mut f = Frame::new_unchecked(&mut extra[..]);
    f.fill_crc();
    let mut dec = Decoder::new();
    assert!(decode_all(&mut dec, &frame_raw(&extra)).is_empty());
    assert_eq!(dec.stats().malformed, 1);
}

#[test]
fn oversize_and_garbage_are_counted_and_recovered_from() {
    let mut enc = Encoder::new();
    let mut stream = vec![0x55u8; MAX_WIRE_LEN + 10];
    stream.push(0);
    stream.extend([0x01, 0x02, 0x00]); // too short to be a frame
    stream.extend([0x00, 0x00]); // idle delimiters
    stream.extend(wire(&mut enc, &Message::Heartbeat(samples::heartbeat())));
    let mut dec = Decoder::new();
    let got = decode_all(&mut dec, &stream);
    assert_eq!(got.len(), 1);
    let s = dec.stats();
    assert_eq!(s.oversize, 1);
    assert_eq!(s.truncated + s.cobs_errors, 1);
}

#[test]
fn dropped_frames_are_counted_as_lost() {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_WIRE_LEN];
    let mut stream = Vec::new();
    for i in 0..10 {
        let bytes = enc
            .encode(&Message::Heartbeat(HeartbeatMsg { uptime_us: i }), &mut out)
            .unwrap();
        if i % 3 != 1 {
            stream.extend_from_slice(bytes);
        }
    }
    let mut dec = Decoder::new();
    let got = decode_all(&mut dec, &stream);
    assert_eq!(got.len(), 7);
    assert_eq!(dec.stats().lost, 3);
}

#[test]
fn largest_scan_fits_the_documented_maximum() {
    let mut scan = samples::scan();
    scan.stamp_us = u64::MAX;
    scan.scan_counter = u32::MAX;
    scan.start_angle_cdeg = u16::MAX;
    scan.step_angle_cdeg = u16::MAX;
    scan.count_word = u16::MAX;
    scan.sensor_indices = Some((255, 255));
    scan.values = heapless::Vec::from_slice(&[u16::MAX; MAX_SCAN_VALUES]).unwrap();
    let m = Message::Scan(scan);
    assert!(m.payload_len() <= MAX_PAYLOAD_LEN, "{}", m.payload_len());
    let mut out = [0u8; MAX_WIRE_LEN];
    let wire = Encoder::new().encode(&m, &mut out).unwrap().to_vec();
    assert!(wire.len() <= MAX_WIRE_LEN);
    let mut dec = Decoder::new();
    let got = decode_all(&mut dec, &wire);
    assert_eq!(got[0].message, m);
}
