//! `hil-sim decode-sick`: a raw SICK LMS2xx -> host capture decoded with the firmware's
//! telegram receiver.

use std::path::PathBuf;

use super::CliResult;

/// Decode a raw SICK LMS2xx -> host byte stream with the firmware's telegram receiver.
///
/// Prints one JSON object per valid scan telegram on stdout
/// (`{"count_word":…,"values":[…],"status":…}`, values are the raw 16-bit words) and a JSON
/// summary of bytes, accepted telegrams, CRC errors and resynchronisations on stderr.
#[derive(Debug, clap::Args)]
pub struct DecodeSickArgs {
    /// The capture: raw bytes exactly as they came from the sensor.
    file: PathBuf,
}

/// Decodes the capture (see [`hil_sim::decode_sick::run`]).
pub fn run(args: DecodeSickArgs) -> CliResult {
    hil_sim::decode_sick::run(&args.file)
}
