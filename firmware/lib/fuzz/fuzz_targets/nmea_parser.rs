//! Arbitrary bytes into the NMEA path: the whole [`GpsReceiver`] (fed in chunks whose size
//! the first byte chooses), and each line as a [`Sentence`] into every `Repr` parser. Nothing
//! may panic, the receiver's counters must add up, and a decoded sentence re-emitted must
//! parse back to the same `Repr`.

#![no_main]

use firmware::nmea::{GgaRepr, GllRepr, GpsReceiver, GsaRepr, GstRepr, RmcRepr, Sentence, VtgRepr};
use libfuzzer_sys::fuzz_target;

/// Emits `repr` and checks that it parses back to itself.
macro_rules! round_trip {
    ($repr:expr, $ty:ty) => {{
        let mut text = String::new();
        if $repr.emit(*b"GP", &mut text).is_ok() {
            let line = text.trim_end_matches("\r\n");
            if line.len() <= protocol::MAX_NMEA_LEN {
                let sentence =
                    Sentence::new_checked(line.as_bytes()).expect("emitted sentence is valid");
                assert_eq!(<$ty>::parse(&sentence).as_ref(), Ok(&$repr), "{line}");
            }
        }
    }};
}

fuzz_target!(|data: &[u8]| {
    let (chunk_len, stream) = match data.split_first() {
        Some((&first, rest)) => (usize::from(first % 64) + 1, rest),
        None => (1, data),
    };

    let mut receiver = GpsReceiver::new();
    for (i, chunk) in stream.chunks(chunk_len).enumerate() {
        receiver.push(chunk, i as u64, |received| {
            let _ = received.to_nmea_msg();
            if let Some(fix) = received.fix {
                assert!(fix.position.is_none() || fix.quality != protocol::FixQuality::Invalid);
            }
        });
    }
    let s = receiver.stats();
    assert_eq!(
        s.lines,
        s.accepted + s.unsupported + s.bad_checksum + s.missing_checksum + s.malformed
    );
    assert_eq!(s.bytes as usize, stream.len());

    for line in stream.split(|&b| b == b'\n' || b == b'\r') {
        let sentence = Sentence::new_unchecked(line);
        let _ = (
            sentence.talker(),
            sentence.formatter(),
            sentence.fields().count(),
        );
        let _ = sentence.check_format();
        let _ = sentence.check_checksum();
        if let Ok(repr) = GgaRepr::parse(&sentence) {
            round_trip!(repr, GgaRepr);
        }
        if let Ok(repr) = RmcRepr::parse(&sentence) {
            round_trip!(repr, RmcRepr);
        }
        if let Ok(repr) = GllRepr::parse(&sentence) {
            round_trip!(repr, GllRepr);
        }
        if let Ok(repr) = GsaRepr::parse(&sentence) {
            round_trip!(repr, GsaRepr);
        }
        if let Ok(repr) = VtgRepr::parse(&sentence) {
            round_trip!(repr, VtgRepr);
        }
        if let Ok(repr) = GstRepr::parse(&sentence) {
            round_trip!(repr, GstRepr);
        }
    }
});
