//! Arbitrary text as the daemon's TOML configuration. Nothing may panic, a refusal must name
//! the file, and a configuration that reads must write out (`--print-config`) to text that
//! reads back to the same configuration.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use robot_host::config::DaemonConfig;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("fuzzed.toml");
    match DaemonConfig::parse(text, path) {
        Ok(config) => {
            let written = config.to_toml();
            let again = DaemonConfig::parse(&written, path)
                .unwrap_or_else(|error| panic!("{error}\nwritten:\n{written}"));
            assert_eq!(again, config, "written:\n{written}");
        }
        Err(error) => {
            let message = error.to_string();
            assert!(
                message.contains("fuzzed.toml") || message.starts_with("configuration:"),
                "{message}"
            );
        }
    }
});
