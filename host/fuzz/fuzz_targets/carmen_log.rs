//! Arbitrary text into the CARMEN readers: a laser log (`FLASER`, `ROBOTLASER1`, `ODOM`), read
//! whole and record by record, a reference trajectory and Kümmerle relations. Nothing may
//! panic; a refusal must name the file; the two ways of reading a log must agree.

#![no_main]

use std::io::Cursor;

use hil_sim::replay::reference::parse_reference;
use hil_sim::replay::{CarmenLog, CarmenReader, parse_relations};
use libfuzzer_sys::fuzz_target;

const NAME: &str = "fuzzed.clf";

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let whole = CarmenLog::parse(&text, NAME);
    let streamed: Result<Vec<_>, _> =
        CarmenReader::new(Cursor::new(text.as_bytes()), NAME).collect();
    match (&whole, &streamed) {
        (Ok(log), Ok(records)) => assert_eq!(log.records.len(), records.len()),
        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
        _ => panic!("read whole: {whole:?}; record by record: {streamed:?}"),
    }
    if let Err(error) = &whole {
        assert!(error.to_string().contains(NAME), "{error}");
    }
    if let Err(error) = parse_relations(&text, "fuzzed.relations") {
        assert!(error.to_string().contains("fuzzed.relations"), "{error}");
    }
    if let Err(error) = parse_reference(&text, "fuzzed.reference.tsv") {
        assert!(
            error.to_string().contains("fuzzed.reference.tsv"),
            "{error}"
        );
    }
});
