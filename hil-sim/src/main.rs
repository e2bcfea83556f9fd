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
    /// Run the whole chain on built-in defaults: emulated LMS200 and GPS → firmware tasks →
    /// host link, all over pseudo-terminals. Prints laser state changes on stderr and a JSON
    /// report (every scan and fix accounted for) on stdout.
    Demo {
        /// How long to run, seconds.
        #[arg(long, default_value_t = 8.0)]
        seconds: f64,
        /// GPS epochs per second (1-10).
        #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=10))]
        gps_rate_hz: u32,
        /// Power-cycle the emulated laser this many seconds into the run (it comes back at
        /// 9600 Bd, not streaming, and announces itself; the firmware must bring it up again).
        #[arg(long)]
        laser_restart_s: Option<f64>,
        /// Seed of the emulators' measurement noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
}

fn demo(options: hil_sim::demo::DemoOptions) -> Result<(), Box<dyn std::error::Error>> {
    if !(options.seconds.is_finite() && options.seconds > 0.0) {
        return Err("--seconds must be a positive number".into());
    }
    let report = hil_sim::demo::run(options)?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    // The firmware tasks run forever, as on the board; the process ends them.
    std::process::exit(0);
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::DecodeSick { file } => hil_sim::decode_sick::run(&file),
        Command::DecodeNmea { file } => hil_sim::decode_nmea::run(&file),
        Command::Demo {
            seconds,
            gps_rate_hz,
            laser_restart_s,
            seed,
        } => demo(hil_sim::demo::DemoOptions {
            seconds,
            gps_rate_hz,
            laser_restart_s,
            seed,
            progress: true,
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hil-sim: {e}");
            ExitCode::FAILURE
        }
    }
}
