//! `hil-sim decode-nmea`: an NMEA 0183 receiver log decoded with the firmware's sentence
//! parser.

use std::path::PathBuf;

use super::CliResult;

/// Decode an NMEA 0183 receiver log with the firmware's sentence parser.
///
/// Lines starting with `#` are comments. Prints one JSON object per position-bearing
/// sentence (GGA, RMC, GLL) on stdout and a summary of accepted, bad-checksum,
/// missing-checksum and malformed sentences on stderr.
#[derive(Debug, clap::Args)]
pub struct DecodeNmeaArgs {
    /// The receiver log.
    file: PathBuf,
}

/// Decodes the log (see [`hil_sim::decode_nmea::run`]).
pub fn run(args: DecodeNmeaArgs) -> CliResult {
    hil_sim::decode_nmea::run(&args.file)
}
