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
    /// The whole system, no hardware and no data files: a seeded world with a generated,
    /// geo-referenced aerial image; emulated laser and GPS → the firmware tasks on the host →
    /// a pty → the robot-host daemon, which maps (EKF with GPS outdoors, occupancy grid
    /// indoors), records to MCAP and serves the web view, whose address it prints. At the end
    /// OUT holds the map PNG, the map over the image, the trajectory, GeoJSON/KML, the MCAP
    /// recording and a summary; the report is printed as JSON.
    Demo {
        /// The world: `outdoor` (a park with trees and a building, GPS, aerial image) or
        /// `indoor` (rooms and corridors, occupancy grid).
        #[arg(long, default_value = "outdoor")]
        world: hil_sim::world::WorldKind,
        /// Seed of the world, its route and the sensor noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Seconds of driving.
        #[arg(long, default_value_t = 60.0)]
        duration: f64,
        /// Address of the web view (port 0 picks a free one).
        #[arg(long, default_value = "127.0.0.1:8080")]
        serve: std::net::SocketAddr,
        /// Also stream the live state to Foxglove on this WebSocket address.
        #[arg(long)]
        foxglove: Option<std::net::SocketAddr>,
        /// Where the outputs go.
        #[arg(long, default_value = "demo-out")]
        out: PathBuf,
        /// Run as fast as the machine allows instead of at the wall clock.
        #[arg(long)]
        fast: bool,
        /// After the drive, keep the web view up this many seconds.
        #[arg(long, default_value_t = 0.0)]
        linger: f64,
    },
    /// Run the whole chain on a seeded world: emulated LMS2xx laser and NMEA GPS → pseudo-
    /// terminals → the firmware tasks → host link → the host's pose estimate, lock-step on a
    /// virtual clock (byte-identical outputs for the same arguments).
    ///
    /// Writes OUT/trajectory.tsv (the host's estimate per scan: `timestamp_s x_m y_m
    /// theta_rad`), OUT/ground_truth.tsv (the truth at the same timestamps, same frame),
    /// OUT/summary.json (every telegram accounted for, faults injected beside what was
    /// counted), OUT/landmarks.tsv and OUT/world.tsv. Prints the summary on stdout.
    Run {
        /// The kind of world: `indoor` (rooms and corridors) or `outdoor` (a park with trees
        /// and a building; GPS has a fix).
        #[arg(long, default_value = "indoor")]
        world: hil_sim::world::WorldKind,
        /// Seed of the world, the route, the sensor noise and the faults.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Seconds of sensor output (virtual time).
        #[arg(long, default_value_t = 20.0)]
        duration: f64,
        /// Faults to inject, comma-separated: `ber=RATE` (bit errors per bit), `drop=RATE`
        /// (bytes lost), `truncate=RATE` (laser telegrams cut short), `laser-restart=T_S`
        /// (power cycle at T seconds), `gps-outage=T_S:DUR_S` (no fix for DUR seconds),
        /// `link-replug=T_S` (host link unplugged for 0.3 s). Times may repeat.
        #[arg(long, default_value = "")]
        faults: hil_sim::faults::FaultSpec,
        /// Output directory (created if missing).
        #[arg(long, default_value = "hil-run")]
        out: PathBuf,
        /// Pace the run at the wall clock instead of running as fast as possible.
        #[arg(long)]
        realtime: bool,
        #[command(flatten)]
        hardware: HardwareArgs,
        /// Boot the firmware image for QEMU's netduinoplus2 machine (the thumbv7em build of
        /// firmware/qemu) in qemu-system-arm and drive it instead of the firmware in this
        /// process, on the wall clock as with --hardware. Writes OUT/qemu.json: the image's
        /// stack high-water mark and its worst telegram-to-frame time in emulated cycles.
        #[arg(
            long,
            value_name = "ELF",
            num_args = 0..=1,
            default_missing_value = hil_sim::qemu::DEFAULT_ELF,
            conflicts_with = "hardware"
        )]
        qemu: Option<PathBuf>,
        /// Bring the laser up as the QEMU image does (38 400 Bd instead of 500 kBd, millimetres
        /// in every world), with the firmware in this process: the reference a --qemu run of
        /// the same seed is compared with.
        #[arg(long, conflicts_with_all = ["qemu", "hardware"])]
        qemu_config: bool,
    },
    /// Replay a recording through the whole chain: the emulated LMS is brought up by the
    /// firmware as usual, then streams the recording's scans over the serial line (and the
    /// GPS emulator its fixes); the host's estimate and accounting are written as for `run`.
    /// ground_truth.tsv holds the recording's own truth: the pose a CARMEN log records with
    /// each scan (raw odometry in benchmark/*.clf, zero when the log has none), the GPS
    /// position for Victoria Park, zero for a raw capture.
    #[command(group(clap::ArgGroup::new("source").required(true).args(["carmen", "victoria", "capture"])))]
    Replay {
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
        /// ACES).
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
    },
    /// Occupancy-grid SLAM over a CARMEN laser log: local tracking against submaps, loop
    /// closure with the exact raster matcher, a pose graph; the map exported.
    ///
    /// Writes OUT/trajectory.tsv (one line per scan: the log's timestamp as printed, then
    /// `x_m y_m theta_rad`), OUT/map.pgm + OUT/map.yaml (ROS map_server) and OUT/map.png, and
    /// OUT/summary.json (`scans`, `wall_s`, `scans_per_second`, and the error on the relations
    /// given, Kümmerle et al. 2009). LOG.relations and LOG.reference.tsv beside the log (LOG
    /// without its extension) are used when present. For a relations file it also names the
    /// relations the log's own scans dispute (the two scans line up far worse at the true
    /// relative pose than at the estimate) and gives the error without them.
    ReplayCarmen {
        /// The CARMEN log (FLASER / ROBOTLASER1; `.gz` is read too).
        log: PathBuf,
        /// Output directory (created if missing).
        #[arg(long, default_value = "slam-out")]
        out: PathBuf,
        /// `none` ignores every pose in the log (laser only); `log` uses them as odometry.
        /// Laser-only logs (every pose zero) must be run with `none`.
        #[arg(long, default_value = "log", value_parser = ["log", "none"])]
        odometry: String,
        /// Ranges at or above this are "no return", m (the logs write their maximum).
        #[arg(long, default_value_t = 80.0)]
        no_return_from_m: f64,
        /// Ground-truth relations (`t1 t2 x y z roll pitch yaw`) to measure the error on
        /// [default: LOG.relations when present].
        #[arg(long)]
        relations: Option<PathBuf>,
        /// A reference trajectory (`timestamp x y theta`) for consecutive and revisit
        /// relations [default: LOG.reference.tsv when present].
        #[arg(long)]
        reference: Option<PathBuf>,
        /// Only the log's first N scans (a short run; the relations beyond them are not
        /// covered).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
        first_scans: Option<u64>,
        /// Disable loop closure (local tracking only).
        #[arg(long)]
        no_loop_closure: bool,
        /// Disable the loop closure against chains of earlier scans (±10 m) for scans no
        /// submap took.
        #[arg(long)]
        no_chain_closure: bool,
        /// Skip the final refinement (every scan aligned on the submaps near it once the run
        /// is over).
        #[arg(long)]
        no_refinement: bool,
        /// Local tracking: below this share of the scanned surface (end points weighted by
        /// range) on the submap after alignment, the wide search runs.
        #[arg(long, default_value_t = host::slam::LocalTrackingOptions::default().min_surface_fraction, allow_hyphen_values = true, value_parser = parse_fraction)]
        min_surface_fraction: f64,
        /// Local tracking: below this share after the wide search, it runs again over every
        /// heading, and a pose it finds must bring the share to this.
        #[arg(long, default_value_t = host::slam::LocalTrackingOptions::default().full_turn_below_surface_fraction, allow_hyphen_values = true, value_parser = parse_fraction)]
        every_heading_below: f64,
        /// Local tracking: how much the share of the scanned surface on cells the submap has
        /// seen free counts against a candidate pose (the share on its surfaces counts 1).
        #[arg(long, default_value_t = host::slam::LocalTrackingOptions::default().free_weight, allow_hyphen_values = true, value_parser = parse_weight)]
        free_weight: f64,
        /// Pose graph: a scan-to-scan constraint is left almost free along the direction in
        /// which its alignment holds less than this fraction of the information it holds
        /// across it (a corridor's axis); 0 never does.
        #[arg(long, default_value_t = host::slam::SlamOptions::default().degenerate_information_ratio, allow_hyphen_values = true, value_parser = parse_fraction)]
        degenerate_ratio: f64,
        /// Pose graph: the standard deviation added along such a direction, m.
        #[arg(long, default_value_t = host::slam::SlamOptions::default().degenerate_sigma_m, allow_hyphen_values = true, value_parser = parse_weight)]
        degenerate_sigma_m: f64,
    },
    /// Filter consistency: Monte-Carlo runs in a seeded world, the EKF submap filter, a single
    /// global EKF and the ideal EKF (true data association, Jacobians at the true state; the
    /// reference for what the test yields on these runs) on the same noisy odometry and tree
    /// observations. Prints as its last line
    /// `{"runs":N,"submap_fraction_within":…,"full_ekf_fraction_within":…,
    /// "ideal_ekf_fraction_within":…}`: the fraction of steps whose run-averaged robot-pose
    /// NEES lies within the 95 % chi-square bounds.
    Nees {
        /// World (only `outdoor` has landmarks).
        #[arg(long, default_value = "outdoor")]
        world: hil_sim::world::WorldKind,
        /// Monte-Carlo runs.
        #[arg(long, default_value_t = 20)]
        runs: usize,
        /// Number of the first run: runs `first-run .. first-run + runs` of the seed's set,
        /// each with the same noise as in a longer set (to look at one run again).
        #[arg(long, default_value_t = 0)]
        first_run: usize,
        /// Seed of the world and the noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Length of each run, s.
        #[arg(long, default_value_t = 120.0)]
        duration: f64,
        /// Landmarks per local map of the submap filter.
        #[arg(long, default_value_t = 30)]
        local_map_landmarks: usize,
        /// Standard deviation of a tree's range, in the simulator and in the filters, m.
        #[arg(long, default_value_t = 0.05, allow_hyphen_values = true, value_parser = parse_sigma)]
        range_sigma_m: f64,
        /// Standard deviation of a tree's bearing, in the simulator and in the filters,
        /// degrees.
        #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = parse_sigma)]
        bearing_sigma_deg: f64,
    },
    /// EKF SLAM with local maps over the Victoria Park run (tree detections, car odometry,
    /// GPS), measured against its GPS.
    ///
    /// Writes OUT/trajectory.tsv (`t_s x_m y_m theta_rad` of the laser at each scan, estimated
    /// again against the finished map, forwards and backwards; with GPS fused, in the frame
    /// of gps.dat), OUT/online_trajectory.tsv (the filter's estimate at each scan),
    /// OUT/landmarks.tsv and OUT/summary.json (`wall_s`, `steps`,
    /// `landmarks`, `local_maps`, `loop_closures`, `rms_to_gps_m`: directly with GPS fused,
    /// after the best rigid alignment with `--no-gps`; `rms_to_gps_without_jumps_m`: the same
    /// without the receiver's jumps; and step times by map size).
    ReplayVictoria {
        /// The `rfs_slam_ascii` directory (inputs.dat, gps.dat, measurements.dat).
        dir: PathBuf,
        /// Output directory (created if missing).
        #[arg(long, default_value = "victoria-out")]
        out: PathBuf,
        /// Do not fuse the GPS (it is still used to measure the error).
        #[arg(long)]
        no_gps: bool,
        /// Standard deviation of a GPS fix on each axis, m.
        #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = parse_sigma)]
        gps_sigma_m: f64,
        /// Close a local map once it holds this many landmarks; 0 runs one global EKF.
        #[arg(long, default_value_t = 30)]
        local_map_landmarks: usize,
        /// Do not estimate the odometry's speed scale and steering offset online.
        #[arg(long)]
        no_calibration: bool,
        /// Trees further than this are not used, m (0 runs on odometry alone).
        #[arg(long, default_value_t = 40.0)]
        max_range_m: f64,
        /// Use only the first S seconds of the run.
        #[arg(long)]
        duration_s: Option<f64>,
        /// `LAT,LON` (degrees) of the origin of gps.dat's metric frame, which the dataset does
        /// not record; with GPS fused, OUT/map.geojson and OUT/map.kml are written in WGS84.
        #[arg(long, allow_hyphen_values = true, value_parser = parse_datum)]
        datum: Option<host::georef::LocalFrame>,
        /// Standard deviation of a tree's range, m.
        #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = parse_sigma)]
        sigma_range_m: f64,
        /// Standard deviation of a tree's bearing, degrees.
        #[arg(long, default_value_t = 3.0, allow_hyphen_values = true, value_parser = parse_sigma)]
        sigma_bearing_deg: f64,
        /// Standard deviation of the measured wheel speed, m/s.
        #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = parse_sigma)]
        sigma_speed_mps: f64,
        /// Standard deviation of the measured steering angle, degrees.
        #[arg(long, default_value_t = 5.0, allow_hyphen_values = true, value_parser = parse_sigma)]
        sigma_steer_deg: f64,
        /// Lateral offset of the laser, m, positive to the left.
        #[arg(long, default_value_t = 0.5, allow_hyphen_values = true)]
        laser_left_m: f64,
        /// Distance of the laser ahead of the rear axle, m.
        #[arg(long, default_value_t = 3.78)]
        laser_ahead_m: f64,
    },
    /// Match consecutive scan pairs of a CARMEN log with the reference raster matcher and the
    /// fast matcher on the same table; prints per-pair timings on stderr and, as the last
    /// line on stdout, `{"pairs":N,"identical":K,"reference_s":…,"fast_s":…}`.
    BenchMatch {
        /// The CARMEN log.
        log: PathBuf,
        /// Scan pairs to match (scan k against scan k + 1).
        #[arg(long, default_value_t = 100)]
        pairs: usize,
    },
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
    /// Bring a freshly powered emulated LMS200 up on the wall clock: emulated LMS200 and GPS
    /// → firmware tasks → host link, all over pseudo-terminals. Prints laser state changes on
    /// stderr and a JSON report (every scan and fix accounted for) on stdout.
    Bringup {
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

/// Hardware in the loop: a flashed board on real serial ports.
#[derive(Debug, clap::Args)]
struct HardwareArgs {
    /// Drive a flashed board on real serial ports instead of the firmware in this process:
    /// the emulated laser writes to --laser-port at its own current baud rate (following its
    /// baud switches), the GPS to --gps-port, and the host reads --host-port. Runs on the wall
    /// clock (no lock-step); the board's counters come from its status report.
    #[arg(long, requires_all = ["laser_port", "gps_port", "host_port"])]
    hardware: bool,
    /// With --hardware: the serial port wired to the board's laser UART (RS-422 side).
    #[arg(long, requires = "hardware")]
    laser_port: Option<PathBuf>,
    /// With --hardware: the serial port wired to the board's GPS UART.
    #[arg(long, requires = "hardware")]
    gps_port: Option<PathBuf>,
    /// With --hardware: the board's host link, e.g. /dev/ttyACM0.
    #[arg(long, requires = "hardware")]
    host_port: Option<PathBuf>,
    /// With --hardware: the rate the board's GPS UART listens at (the GPS epoch rate is
    /// lowered to what fits).
    #[arg(long, default_value_t = 9_600)]
    gps_baud: u32,
}

impl HardwareArgs {
    fn ports(self) -> Option<hil_sim::run::HardwarePorts> {
        if !self.hardware {
            return None;
        }
        Some(hil_sim::run::HardwarePorts {
            laser: self.laser_port?,
            gps: self.gps_port?,
            host: self.host_port?,
            gps_baud: self.gps_baud,
        })
    }
}

fn demo(options: &hil_sim::demo::DemoOptions) -> Result<(), Box<dyn std::error::Error>> {
    let report = hil_sim::demo::run(options, |ready| {
        if let Some(web) = ready.web {
            println!("web view: http://{web}/");
        }
        if let Some(foxglove) = ready.foxglove {
            println!("foxglove: ws://{foxglove}");
        }
        eprintln!(
            "driving the {} world (seed {}) for {} s …",
            options.world, options.seed, options.duration_s
        );
    })?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}

fn bringup(options: hil_sim::bringup::BringUpOptions) -> Result<(), Box<dyn std::error::Error>> {
    if !(options.seconds.is_finite() && options.seconds > 0.0) {
        return Err("--seconds must be a positive number".into());
    }
    let report = hil_sim::bringup::run(options)?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    // The firmware tasks run forever, as on the board; the process ends them.
    std::process::exit(0);
}

fn run(
    options: hil_sim::run::RunOptions,
    qemu: Option<PathBuf>,
    qemu_config: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let Some(elf) = qemu else {
        let summary = if qemu_config {
            let image = Some(hil_sim::qemu::image_bring_up());
            hil_sim::run::run_with_bring_up(&options, None, image)?
        } else {
            hil_sim::run::run(&options)?
        };
        return report(&summary, &options.out);
    };
    let (summary, measured) = hil_sim::qemu::run(&options, &hil_sim::qemu::QemuOptions::new(elf))?;
    eprintln!(
        "hil-sim: QEMU image: stack {} of {} bytes used; telegram to frame at most {} cycles \
         ({:.1} µs, {} instructions) over {} scans",
        measured.measurements.stack_used_bytes,
        measured.measurements.stack_bytes,
        measured.measurements.latency_max_cycles,
        measured.latency_max_us,
        measured.latency_max_instructions,
        measured.measurements.latency_samples,
    );
    report(&summary, &options.out)
}

fn replay(options: hil_sim::run::ReplayOptions) -> Result<(), Box<dyn std::error::Error>> {
    let summary = hil_sim::run::replay(&options)?;
    report(&summary, &options.out)
}

fn replay_carmen(
    options: hil_sim::slam_replay::SlamReplayOptions,
) -> Result<(), Box<dyn std::error::Error>> {
    let summary = hil_sim::slam_replay::replay_carmen_slam(&options)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    eprintln!(
        "hil-sim: {} scans in {:.3} s ({:.0} scans/s); outputs in {}",
        summary.scans,
        summary.wall_s,
        summary.scans_per_second,
        options.out.display()
    );
    if let Some(agreement) = &summary.relations_agreement {
        let without = &agreement.undisputed_summary;
        eprintln!(
            "hil-sim: the scans dispute {} of {} relations (their true pose lines them up far \
             worse than the estimate); without those: {:.4} m, {:.3}° over {}",
            agreement.disputed.len(),
            agreement.checked,
            without.mean_translation_m,
            without.mean_rotation_deg,
            without.count
        );
    }
    Ok(())
}

/// Parses a number in `range` (finite); `rule` says what the range is in the error.
fn parse_in(text: &str, range: std::ops::RangeInclusive<f64>, rule: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|e| format!("{text:?}: {e}"))?;
    if value.is_finite() && range.contains(&value) {
        Ok(value)
    } else {
        Err(format!("{text:?}: {rule}"))
    }
}

/// Parses a standard deviation: a finite number, at least 0.
fn parse_sigma(text: &str) -> Result<f64, String> {
    parse_in(
        text,
        0.0..=f64::INFINITY,
        "a standard deviation must be a finite number of at least 0",
    )
}

/// Parses a weight: a finite number, at least 0.
fn parse_weight(text: &str) -> Result<f64, String> {
    parse_in(
        text,
        0.0..=f64::INFINITY,
        "a weight must be a finite number of at least 0",
    )
}

/// Parses a fraction: a number from 0 to 1.
fn parse_fraction(text: &str) -> Result<f64, String> {
    parse_in(text, 0.0..=1.0, "a fraction must lie between 0 and 1")
}

/// Parses `LAT,LON` in degrees into a local frame at sea level.
fn parse_datum(text: &str) -> Result<host::georef::LocalFrame, String> {
    let (lat, lon) = text
        .split_once(',')
        .ok_or_else(|| format!("{text:?}: expected LAT,LON in degrees"))?;
    let lat_deg: f64 = lat
        .trim()
        .parse()
        .map_err(|e| format!("latitude {lat:?}: {e}"))?;
    let lon_deg: f64 = lon
        .trim()
        .parse()
        .map_err(|e| format!("longitude {lon:?}: {e}"))?;
    host::georef::LocalFrame::new(lat_deg, lon_deg, 0.0).map_err(|e| e.to_string())
}

fn nees(options: hil_sim::nees::NeesOptions) -> Result<(), Box<dyn std::error::Error>> {
    let report = hil_sim::nees::run_nees(&options)?;
    eprintln!("{}", serde_json::to_string_pretty(&report)?);
    println!(
        "{}",
        serde_json::json!({
            "runs": report.runs,
            "submap_fraction_within": report.submap_fraction_within,
            "full_ekf_fraction_within": report.full_ekf_fraction_within,
            "ideal_ekf_fraction_within": report.ideal_ekf_fraction_within,
        })
    );
    Ok(())
}

fn replay_victoria(
    options: hil_sim::victoria_slam::VictoriaSlamOptions,
) -> Result<(), Box<dyn std::error::Error>> {
    let summary = hil_sim::victoria_slam::replay_victoria(&options)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    eprintln!(
        "hil-sim: {} scans in {:.3} s, RMS to GPS {:.2} m ({:.2} m without its {} jumps); \
         outputs in {}",
        summary.scans,
        summary.wall_s,
        summary.rms_to_gps_m,
        summary.rms_to_gps_without_jumps_m,
        summary.gps_jumps,
        options.out.display()
    );
    Ok(())
}

fn bench_match(log: &std::path::Path, pairs: usize) -> Result<(), Box<dyn std::error::Error>> {
    let options = hil_sim::bench_match::BenchMatchOptions {
        pairs,
        ..Default::default()
    };
    let report = hil_sim::bench_match::bench_match(log, &options)?;
    for pair in &report.details.pair_results {
        eprintln!(
            "scan {}: reference {:.4} s, fast {:.6} s, identical {}",
            pair.reference_scan,
            pair.reference_s,
            pair.fast_s,
            pair.identical()
        );
    }
    println!("{}", serde_json::to_string(&report)?);
    Ok(())
}

fn report(
    summary: &hil_sim::run::RunSummary,
    out: &std::path::Path,
) -> Result<(), Box<dyn std::error::Error>> {
    println!("{}", serde_json::to_string_pretty(summary)?);
    eprintln!(
        "hil-sim: {} s of sensor output in {:.2} s; outputs in {}",
        summary.duration_s,
        summary.wall_s,
        out.display()
    );
    if summary.accounting_balanced {
        Ok(())
    } else {
        Err("telegrams unaccounted for: delivered intact + counted rejected != emitted".into())
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo {
            world,
            seed,
            duration,
            serve,
            foxglove,
            out,
            fast,
            linger,
        } => demo(&hil_sim::demo::DemoOptions {
            world,
            seed,
            duration_s: duration,
            serve,
            foxglove,
            out,
            realtime: !fast,
            linger_s: linger,
        }),
        Command::Run {
            world,
            seed,
            duration,
            faults,
            out,
            realtime,
            hardware,
            qemu,
            qemu_config,
        } => run(
            hil_sim::run::RunOptions {
                world,
                seed,
                duration_s: duration,
                faults,
                out,
                realtime,
                hardware: hardware.ports(),
            },
            qemu,
            qemu_config,
        ),
        Command::Replay {
            carmen,
            victoria,
            capture,
            capture_baud,
            recorded_pace,
            no_return_from_m,
            faults,
            seed,
            out,
            realtime,
            hardware,
        } => {
            use hil_sim::run::ReplaySource;
            let source = match (carmen, victoria, capture) {
                (Some(log), _, _) => ReplaySource::Carmen(log),
                (_, Some(dir), _) => ReplaySource::Victoria(dir),
                (_, _, Some(path)) => ReplaySource::Capture {
                    path,
                    baud: capture_baud,
                },
                // clap requires exactly one of the three.
                (None, None, None) => return ExitCode::FAILURE,
            };
            replay(hil_sim::run::ReplayOptions {
                source,
                pace: if recorded_pace {
                    hil_sim::emulators::ReplayPace::Recorded
                } else {
                    hil_sim::emulators::ReplayPace::AsFastAsPossible
                },
                no_return_from_m,
                seed,
                faults,
                out,
                realtime,
                hardware: hardware.ports(),
            })
        }
        Command::ReplayCarmen {
            log,
            out,
            odometry,
            no_return_from_m,
            relations,
            reference,
            first_scans,
            no_loop_closure,
            no_chain_closure,
            no_refinement,
            min_surface_fraction,
            every_heading_below,
            free_weight,
            degenerate_ratio,
            degenerate_sigma_m,
        } => {
            let beside = |suffix: &str| {
                let path = log.with_extension(suffix);
                path.exists().then_some(path)
            };
            let mut slam = host::slam::SlamOptions::default();
            slam.loop_closure.enabled = !no_loop_closure;
            slam.chain_closure.enabled = !no_chain_closure;
            slam.refinement.enabled = !no_refinement;
            slam.local.min_surface_fraction = min_surface_fraction;
            slam.local.full_turn_below_surface_fraction = every_heading_below;
            slam.local.free_weight = free_weight;
            slam.degenerate_information_ratio = degenerate_ratio;
            slam.degenerate_sigma_m = degenerate_sigma_m;
            replay_carmen(hil_sim::slam_replay::SlamReplayOptions {
                relations: relations.or_else(|| beside("relations")),
                reference: reference.or_else(|| beside("reference.tsv")),
                log,
                out,
                odometry: odometry == "log",
                no_return_from_m,
                slam,
                first_scans: first_scans.map(|n| usize::try_from(n).unwrap_or(usize::MAX)),
            })
        }
        Command::Nees {
            world,
            runs,
            first_run,
            seed,
            duration,
            local_map_landmarks,
            range_sigma_m,
            bearing_sigma_deg,
        } => nees(hil_sim::nees::NeesOptions {
            world,
            runs,
            first_run,
            seed,
            duration_s: duration,
            local_map_landmarks,
            noise: hil_sim::landmark_sim::NoiseModel {
                range_sigma_m,
                bearing_sigma_rad: bearing_sigma_deg.to_radians(),
                ..Default::default()
            },
        }),
        Command::ReplayVictoria {
            dir,
            out,
            no_gps,
            gps_sigma_m,
            local_map_landmarks,
            no_calibration,
            max_range_m,
            duration_s,
            datum,
            sigma_range_m,
            sigma_bearing_deg,
            sigma_speed_mps,
            sigma_steer_deg,
            laser_left_m,
            laser_ahead_m,
        } => {
            let mut options = hil_sim::victoria_slam::VictoriaSlamOptions::new(dir, out);
            options.use_gps = !no_gps;
            options.gps_sigma_m = gps_sigma_m;
            options.slam.max_landmarks_per_local_map = if local_map_landmarks == 0 {
                usize::MAX
            } else {
                local_map_landmarks
            };
            options.motion.calibrate = !no_calibration;
            options.max_range_m = max_range_m;
            options.duration_s = duration_s;
            options.datum = datum;
            options.sensor.sigma_range_m = sigma_range_m;
            options.sensor.sigma_bearing_rad = sigma_bearing_deg.to_radians();
            options.sensor.sensor_in_robot[0] = laser_ahead_m;
            options.sensor.sensor_in_robot[1] = laser_left_m;
            options.motion.sigma_speed_mps = sigma_speed_mps;
            options.motion.sigma_steer_rad = sigma_steer_deg.to_radians();
            replay_victoria(options)
        }
        Command::BenchMatch { log, pairs } => bench_match(&log, pairs),
        Command::DecodeSick { file } => hil_sim::decode_sick::run(&file),
        Command::DecodeNmea { file } => hil_sim::decode_nmea::run(&file),
        Command::Bringup {
            seconds,
            gps_rate_hz,
            laser_restart_s,
            seed,
        } => bringup(hil_sim::bringup::BringUpOptions {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_standard_deviation_is_finite_and_not_negative() {
        assert_eq!(parse_sigma("0.5"), Ok(0.5));
        assert_eq!(parse_sigma(" 0 "), Ok(0.0));
        for bad in ["-1", "NaN", "inf", "half"] {
            assert!(parse_sigma(bad).is_err(), "{bad}");
        }
    }
}
