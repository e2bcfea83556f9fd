//! `hil-sim`: runs the firmware logic on the host against real captures and emulated sensors.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Hardware-in-the-loop simulator and decode tools for the sensor interface board.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Decode a raw SICK LMS2xx -> host byte stream with the firmware's telegram receiver.
    ///
    /// Prints one JSON object per valid scan telegram on stdout
    /// (`{"count_word":…,"values":[…],"status":…}`, values are the raw 16-bit words) and a JSON
    /// summary of bytes, accepted telegrams, CRC errors and resynchronisations on stderr.
    DecodeSick {
        /// The capture: raw bytes exactly as they came from the sensor.
        file: PathBuf,
    },
    /// Decode an NMEA 0183 receiver log with the firmware's sentence parser.
    ///
    /// Lines starting with `#` are comments. Prints one JSON object per position-bearing
    /// sentence (GGA, RMC, GLL) on stdout and a summary of accepted, bad-checksum,
    /// missing-checksum and malformed sentences on stderr.
    DecodeNmea {
        /// The receiver log.
        file: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::DecodeSick { file } => hil_sim::decode_sick::run(&file),
        Command::DecodeNmea { file } => hil_sim::decode_nmea::run(&file),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hil-sim: {e}");
            ExitCode::FAILURE
        }
    }
}
