//! Arbitrary bytes as an MCAP recording, as `robot-host --replay` reads it. Nothing may panic,
//! a refusal must name the file, and a recording that reads must also read when cut short at
//! any point past its magic (as a `kill -9` leaves it), with no more than it had whole.

#![no_main]

use std::io::Cursor;
use std::path::Path;

use host::recording::read_recording_from;
use libfuzzer_sys::fuzz_target;

/// Bytes of the MCAP magic a file starts with.
const MAGIC_LEN: usize = 8;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzzed.mcap");
    let whole = match read_recording_from(Cursor::new(data), path) {
        Ok(whole) => whole,
        Err(error) => {
            assert!(error.to_string().contains("fuzzed.mcap"), "{error}");
            return;
        }
    };
    if data.len() <= MAGIC_LEN {
        return;
    }
    // Where to cut: chosen by the input itself, so the fuzzer explores it.
    let cut = MAGIC_LEN + usize::from(data[data.len() - 1]) * (data.len() - MAGIC_LEN) / 256;
    let part = read_recording_from(Cursor::new(&data[..cut]), path)
        .unwrap_or_else(|error| panic!("cut at {cut} of {}: {error}", data.len()));
    assert!(part.link.len() <= whole.link.len());
    assert!(part.raw_reads.len() <= whole.raw_reads.len());
});
