//! `hil-sim soak`: the robot-host daemon as its own process through the whole emulated chain
//! for a long simulated time with every kind of fault; memory, threads, accounting and the
//! recording after a `kill -9`.

use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use super::CliResult;

/// Soak the daemon: `robot-host run` as its own process, fed by the emulated laser and GPS
/// through the firmware tasks and a pty for DURATION simulated seconds (as fast as the
/// daemon keeps up), with every kind of fault. Samples its memory and threads from /proc
/// every half second, checks that every frame the board sent reached it and that the
/// simulation's accounting balances, then kills it with SIGKILL at a seeded moment and reads
/// its recording back.
///
/// Passes when the peak memory from the first simulated minute on stays within 10 % of the
/// memory after that minute, taken as the peak over the minute that follows it (the peak of
/// the start, before it, is reported beside), the
/// threads do not grow, every frame is accounted for and the recording reads with at most one
/// flush interval's frames missing. Writes OUT/soak.json (the report, also printed),
/// OUT/soak.tsv (the samples, with the resident memory by kind), OUT/robot-host.toml and
/// OUT/robot-host.log (the daemon's configuration and log), OUT/run.mcap (its recording;
/// OUT/run_1.mcap, … for its further parts) and OUT/simulation/.
#[derive(Debug, clap::Args)]
pub struct SoakArgs {
    /// The world: `outdoor` (EKF SLAM with GPS and an aerial image; every fault kind bites)
    /// or `indoor` (occupancy grid).
    #[arg(long, default_value = "outdoor")]
    world: hil_sim::world::WorldKind,
    /// Seed of the world, the route, the noise, the faults and the moment of the kill.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seconds of simulated time (more than 60: the first minute is the reference).
    #[arg(long, default_value_t = 3600.0)]
    duration: f64,
    /// Faults, as `hil-sim run --faults` takes them. Default: every kind, bit errors, lost
    /// bytes and cut telegrams all along, and in each sixth of the run a laser power cycle,
    /// a GPS outage and a host-link unplug.
    #[arg(long)]
    faults: Option<hil_sim::faults::FaultSpec>,
    /// The robot-host binary. Default: `robot-host` beside this program (build it with
    /// `cargo build --release -p robot-host`).
    #[arg(long)]
    daemon: Option<PathBuf>,
    /// Seconds of the host's clock per part of the daemon's recording (its
    /// `[record] part_length_s`). Default: the daemon's (600), so the soak's hour, minutes of
    /// the host's clock, stays in one part; a shorter one exercises the parts.
    #[arg(long)]
    part_length_s: Option<f64>,
    /// Where the outputs go.
    #[arg(long, default_value = "soak-out")]
    out: PathBuf,
}

/// Runs the soak, shows its progress on stderr and prints the report; fails when a check
/// fails.
pub fn run(args: SoakArgs) -> CliResult {
    let daemon = match args.daemon {
        Some(path) => path,
        None => std::env::current_exe()?.with_file_name("robot-host"),
    };
    let options = hil_sim::soak::SoakOptions {
        world: args.world,
        seed: args.seed,
        duration_s: args.duration,
        faults: args.faults,
        daemon,
        out: args.out,
        sample_interval: Duration::from_millis(500),
        part_length_s: args.part_length_s,
    };
    let duration_s = options.duration_s;
    let report = hil_sim::soak::run(&options, |sample| {
        eprint!(
            "\rsoak ({duration_s} s simulated): {} frames taken in · {:.1} MiB resident \
             (peak {:.1} since the last sample) · {} threads   ",
            sample.frames,
            sample.rss_kib as f64 / 1024.0,
            sample.peak_rss_kib as f64 / 1024.0,
            sample.threads
        );
        let _ = std::io::stderr().flush();
    })?;
    eprintln!();
    println!("{}", serde_json::to_string_pretty(&report)?);
    eprintln!(
        "hil-sim: soak of {} s simulated in {:.0} s; peak memory from the first minute on \
         {:.1} MiB, {:.3}× the peak over simulated {:.0}–{:.0} s ({:.1} MiB) and {:.3}× the \
         sample after the first minute ({:.1} MiB); {:.1} MiB over its whole life, the start \
         included; outputs in {}",
        report.duration_s,
        report.wall_s,
        report.peak_rss_kib as f64 / 1024.0,
        report.peak_over_first_minute,
        report.reference_window_s[0],
        report.reference_window_s[1],
        report.reference_peak_rss_kib as f64 / 1024.0,
        report.peak_over_sample_after_first_minute,
        report.rss_after_first_minute_kib as f64 / 1024.0,
        report.peak_rss_since_start_kib as f64 / 1024.0,
        options.out.display()
    );
    if report.passed() {
        Ok(())
    } else {
        Err(format!("the soak failed: {}", report.failures.join("; ")).into())
    }
}
