//! `hil-sim bringup`: a freshly powered emulated LMS200 brought up by the firmware tasks on
//! the wall clock, over pseudo-terminals.

use super::CliResult;

/// Bring a freshly powered emulated LMS200 up on the wall clock: emulated LMS200 and GPS
/// → firmware tasks → host link, all over pseudo-terminals. Prints laser state changes on
/// stderr and a JSON report (every scan and fix accounted for) on stdout.
#[derive(Debug, clap::Args)]
pub struct BringupArgs {
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
}

/// Runs the bring-up and prints its report; ends the process, whose firmware tasks run
/// forever as on the board.
pub fn run(args: BringupArgs) -> CliResult {
    let options = hil_sim::bringup::BringUpOptions {
        seconds: args.seconds,
        gps_rate_hz: args.gps_rate_hz,
        laser_restart_s: args.laser_restart_s,
        seed: args.seed,
        progress: true,
    };
    if !(options.seconds.is_finite() && options.seconds > 0.0) {
        return Err("--seconds must be a positive number".into());
    }
    let report = hil_sim::bringup::run(options)?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    // The firmware tasks run forever, as on the board; the process ends them.
    std::process::exit(0);
}
