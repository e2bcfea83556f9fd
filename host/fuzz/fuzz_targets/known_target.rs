//! Arbitrary bytes into the known-target file reader (`replay-camera --target`). Nothing may
//! panic; a refusal names the line it refused or the count it fell short by; an accepted
//! target has at least two corners, every number finite and every corner in front of the
//! camera; and the target written back in the same format reads back the same.

#![no_main]

use host::camera::known_target::{MIN_TARGET_CORNERS, TargetError, parse_known_target};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match parse_known_target(&text) {
        Err(TargetError::Line { line, .. }) => {
            assert!(line >= 1 && line <= text.lines().count().max(1));
        }
        Err(TargetError::TooFewCorners(found)) => assert!(found < MIN_TARGET_CORNERS),
        Err(error @ TargetError::Corner { .. }) => panic!("a parser refusal about images: {error}"),
        Ok(target) => {
            assert!(target.corners.len() >= MIN_TARGET_CORNERS);
            let mut written = String::new();
            for c in &target.corners {
                assert!(c.pixel.iter().chain(&c.position_m).all(|v| v.is_finite()));
                assert!(c.position_m[2] > 0.0);
                let [u, v] = c.pixel;
                let [x, y, z] = c.position_m;
                // `{:?}` writes an f64 so that it parses back to the same value.
                written += &format!("{u:?} {v:?} {x:?} {y:?} {z:?}\n");
            }
            assert_eq!(parse_known_target(&written), Ok(target));
        }
    }
});
