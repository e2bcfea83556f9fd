//! Arbitrary bytes into the stream decoder and straight into the frame view and message
//! parser: nothing may panic, every byte is counted, and whatever decodes re-encodes to a
//! frame that decodes to the same message.

#![no_main]

use libfuzzer_sys::fuzz_target;
use protocol::{Decoder, Encoder, Frame, MAX_WIRE_LEN, Message};

fuzz_target!(|data: &[u8]| {
    let mut decoder = Decoder::new();
    let mut decoded = Vec::new();
    decoder.feed(data, |r| decoded.push(r.message));
    assert_eq!(decoder.stats().bytes, data.len() as u64);

    if let Ok(frame) = Frame::new_checked(data) {
        let _ = frame.check_crc();
        let _ = Message::parse(&frame);
    }

    let mut encoder = Encoder::new();
    let mut out = [0u8; MAX_WIRE_LEN];
    for message in decoded {
        let wire = encoder
            .encode(&message, &mut out)
            .expect("a decoded message always re-encodes");
        let mut again = Decoder::new();
        let mut back = None;
        again.feed(wire, |r| back = Some(r.message));
        assert_eq!(back.as_ref(), Some(&message));
    }
});
