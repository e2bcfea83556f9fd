//! Arbitrary text into the Victoria Park readers (drive inputs, GPS, tree detections). Nothing
//! may panic, a refusal must name the file, and what is read must be finite.

#![no_main]

use hil_sim::replay::victoria::{parse_gps, parse_inputs, parse_tree_scans};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match parse_inputs(&text, "inputs.dat") {
        Ok(inputs) => {
            for input in inputs {
                assert!(input.t_s.is_finite(), "{input:?}");
            }
        }
        Err(error) => assert!(error.to_string().contains("inputs.dat"), "{error}"),
    }
    match parse_gps(&text, "gps.dat") {
        Ok(fixes) => {
            for fix in fixes {
                assert!(fix.t_s.is_finite(), "{fix:?}");
            }
        }
        Err(error) => assert!(error.to_string().contains("gps.dat"), "{error}"),
    }
    match parse_tree_scans(&text, "measurements.dat") {
        Ok(scans) => {
            for scan in scans {
                assert!(scan.t_s.is_finite(), "{scan:?}");
            }
        }
        Err(error) => assert!(error.to_string().contains("measurements.dat"), "{error}"),
    }
});
