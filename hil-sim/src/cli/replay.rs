//! `hil-sim replay`: a recording (CARMEN log, Victoria Park, raw capture) streamed by the
//! emulated sensors through the whole chain.

use std::path::PathBuf;

use super::CliResult;
use super::hardware::HardwareArgs;
use super::report::report;

/// Replay a recording through the whole chain: the emulated LMS is brought up by the
/// firmware as usual, then streams the recording's scans over the serial line (and the
/// GPS emulator its fixes); the host's estimate and accounting are written as for `run`.
/// ground_truth.tsv holds the recording's own truth: the pose a CARMEN log records with
/// each scan (raw odometry in benchmark/*.clf, zero when the log has none), the GPS
/// position for Victoria Park, zero for a raw capture.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["carmen", "victoria", "capture"])))]
pub struct ReplayArgs {
    /// A CARMEN log (FLASER / ROBOTLASER1 lines; `.gz` is read too).
    #[arg(long)]
    carmen: Option<PathBuf>,
    /// The Victoria Park directory holding measurements.dat, gps.dat and inputs.dat
    /// (rfs_slam_ascii): scans rebuilt from the tree detections, GPS fixes as NMEA.
    #[arg(long)]
    victoria: Option<PathBuf>,
    /// A raw sensor -> host capture (e.g. benchmark/lms200/*.lms-to-host.bin): its scan
    /// telegrams go out byte for byte, damaged ones too.
    #[arg(long)]
    capture: Option<PathBuf>,
    /// The baud rate the capture was recorded at (it times the recorded pace).
    #[arg(long, default_value_t = 38_400)]
    capture_baud: u32,
    /// Send the scans at the recording's pace instead of one per scan period (26.7 ms).
    #[arg(long)]
    recorded_pace: bool,
    /// The range a CARMEN log writes for "no return", m (e.g. 81.83 for Intel, 50 for
    /// ACES) [default: read from the log: just below its largest range when many ranges
    /// pile up there, as a sensor's saturated readings do].
    #[arg(long)]
    no_return_from_m: Option<f64>,
    /// Faults to inject (syntax as for `run`).
    #[arg(long, default_value = "")]
    faults: hil_sim::faults::FaultSpec,
    /// Seed of the faults and the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (created if missing).
    #[arg(long, default_value = "hil-replay")]
    out: PathBuf,
    /// Pace the run at the wall clock instead of running as fast as possible.
    #[arg(long)]
    realtime: bool,
    #[command(flatten)]
    hardware: HardwareArgs,
}

/// Replays the recording and reports the summary as `run` does.
pub fn run(args: ReplayArgs) -> CliResult {
    use hil_sim::run::ReplaySource;
    let source = match (args.carmen, args.victoria, args.capture) {
        (Some(log), _, _) => ReplaySource::Carmen(log),
        (_, Some(dir), _) => ReplaySource::Victoria(dir),
        (_, _, Some(path)) => ReplaySource::Capture {
            path,
            baud: args.capture_baud,
        },
        // clap requires exactly one of the three.
        (None, None, None) => {
            return Err("one of --carmen, --victoria, --capture is required".into());
        }
    };
    let options = hil_sim::run::ReplayOptions {
        source,
        pace: if args.recorded_pace {
            hil_sim::emulators::ReplayPace::Recorded
        } else {
            hil_sim::emulators::ReplayPace::AsFastAsPossible
        },
        no_return_from_m: args.no_return_from_m,
        seed: args.seed,
        faults: args.faults,
        out: args.out,
        realtime: args.realtime,
        hardware: args.hardware.ports(),
    };
    let summary = hil_sim::run::replay(&options)?;
    report(&summary, &options.out)
}
