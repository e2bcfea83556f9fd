//! Arbitrary bytes into the SICK receiver, with arbitrary pauses, and every telegram it
//! delivers through the reply and scan parsers: nothing may panic, every delivered telegram
//! is valid, every byte is accounted for, and a parsed reply or scan re-emits to bytes that
//! parse to the same value. The input bytes are also tried directly as a telegram view.

#![no_main]

use firmware::sick::{Event, Receiver, Reply, Request, ScanRepr, Telegram, reply};
use libfuzzer_sys::fuzz_target;

fn check_telegram(telegram: &Telegram<&[u8]>) {
    if telegram.command() == reply::code::SCAN {
        if let Ok(scan) = ScanRepr::parse(telegram) {
            let mut out = vec![0u8; scan.buffer_len()];
            scan.emit(&mut Telegram::new_unchecked(&mut out[..]))
                .expect("buffer_len bytes");
            let again = Telegram::new_checked(&out[..]).expect("emitted telegram");
            assert_eq!(ScanRepr::parse(&again).as_ref(), Ok(&scan));
        }
    } else if let Ok(reply) = Reply::parse(telegram) {
        let mut out = vec![0u8; reply.buffer_len()];
        reply
            .emit(&mut Telegram::new_unchecked(&mut out[..]))
            .expect("buffer_len bytes");
        let again = Telegram::new_checked(&out[..]).expect("emitted telegram");
        assert_eq!(Reply::parse(&again).as_ref(), Ok(&reply));
    }
}

fuzz_target!(|data: &[u8]| {
    // The first byte chooses the pause pattern: bytes 20 µs apart, with a 40 ms pause
    // before every byte whose index is a multiple of the chosen period.
    let (period, bytes) = match data.split_first() {
        Some((&p, rest)) => (usize::from(p) + 1, rest),
        None => (1, data),
    };
    let mut receiver = Receiver::new();
    let mut now_us = 0u64;
    for (i, &byte) in bytes.iter().enumerate() {
        now_us += if period < 256 && i % period == period - 1 {
            40_000
        } else {
            20
        };
        if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
            assert!(telegram.check_len().is_ok());
            assert!(telegram.check_crc().is_ok());
            assert!(telegram.address() & 0x80 != 0);
            check_telegram(&telegram);
        }
    }
    while let Some(event) = receiver.poll(now_us + 1_000_000) {
        if let Event::Telegram { telegram, .. } = event {
            assert!(telegram.check_crc().is_ok());
            check_telegram(&telegram);
        }
    }
    let stats = receiver.stats();
    assert_eq!(receiver.pending_bytes(), 0);
    assert_eq!(stats.bytes as usize, bytes.len());
    assert_eq!(
        stats.bytes,
        stats.telegram_bytes + stats.acks + stats.naks + stats.garbage_bytes
    );

    if let Ok(telegram) = Telegram::new_checked(bytes) {
        let _ = telegram.check_crc();
        let _ = Request::parse(&telegram);
        check_telegram(&telegram);
    }
});
