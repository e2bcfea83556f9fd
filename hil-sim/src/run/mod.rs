//! `hil-sim run`: the whole chain on a seeded world — emulated LMS2xx and GPS → pseudo-terminals
//! → the firmware tasks → the host link → the host's estimate — with fault injection and an
//! account of every telegram.
//!
//! The run is lock-step on a virtual clock ([`engine`]), so the same seed, world, duration and
//! faults give byte-identical outputs, as fast as the host allows (`realtime` paces it).
//! It writes into the output directory:
//!
//! * `trajectory.tsv`: the host's estimate per scan received intact, `timestamp_s x_m y_m
//!   theta_rad`, in the `map` frame (origin: the robot's pose at its first scan);
//! * `ground_truth.tsv`: the true pose at the same scans, in the same frame;
//! * `summary.json`: the accounting ([`RunSummary`]);
//! * `landmarks.tsv`, `world.tsv`: the world's landmarks and shapes, in the world frame.
//!
//! Accounting: every scan telegram the laser emitted is either delivered intact to the host
//! or counted as rejected by the system itself — by the firmware (scan periods with bytes but
//! no valid telegram, [`firmware::sick::ScanSlots`]) or by the host (gaps in the board's scan
//! counter: dropped on the board or lost on the link). `accounting_balanced` says whether
//! `delivered intact + counted rejected = emitted`.

pub mod engine;
pub mod estimator;
pub mod host_side;
pub mod summary;
pub mod tap;

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use firmware::sick::BringUpConfig;
use firmware::tasks::gps::GpsOptions;
use protocol::RangeUnit;

use crate::board::{self, BoardConfig};
use crate::emulators::{
    BeamMapping, GpsEmulator, GpsEmulatorOptions, Lms2xx, Lms2xxOptions, ReplayPace,
};
use crate::faults::FaultSpec;
use crate::pty::PtyLink;
use crate::replay::{CarmenLog, recorded_scans};
use crate::sim_time::VirtualClock;
use crate::world::{GeoDatum, RobotState, Scenario, ShapeWorld, Trajectory, WorldKind};
use engine::{Endpoint, Engine, Sensors};
use estimator::Estimator;
use host_side::{HostSide, ScanRecord};
pub use summary::RunSummary;

/// What to run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Indoor or outdoor.
    pub world: WorldKind,
    /// Seed of the world, route, sensor noise and faults.
    pub seed: u64,
    /// Virtual seconds of sensor output.
    pub duration_s: f64,
    /// Faults to inject.
    pub faults: FaultSpec,
    /// Where the outputs go.
    pub out: PathBuf,
    /// Pace the run at the wall clock.
    pub realtime: bool,
}

/// Runs the chain and writes the outputs; returns the summary.
///
/// # Errors
/// When a pty cannot be opened, the firmware hangs, or an output cannot be written.
pub fn run(options: &RunOptions) -> io::Result<RunSummary> {
    check_duration(options.duration_s)?;
    fs::create_dir_all(&options.out)?;
    let scenario = Scenario::generate_for(options.world, options.seed, options.duration_s + 1.0);
    let outdoor = options.world == WorldKind::Outdoor;
    let lms = Lms2xx::with_world(
        Lms2xxOptions {
            seed: options.seed ^ 0x1A5E,
            pose: scenario.sensor_pose_at(0.0),
            max_range_m: if outdoor { 60.0 } else { 8.0 },
            ..Lms2xxOptions::default()
        },
        scenario.world().clone(),
    );
    let chain = Chain {
        lms,
        datum: scenario.datum(),
        trajectory: scenario.trajectory().clone(),
        gps_has_sky: outdoor,
        scan_truth: None,
        // Outdoors the features are far: 80 m (cm) mode; indoors mm resolution.
        unit: if outdoor {
            RangeUnit::Cm
        } else {
            RangeUnit::Mm
        },
        pixel_m: if outdoor { 0.1 } else { 0.05 },
    };
    let (summary, records) = execute(chain, options, options.duration_s)?;
    write_outputs(&options.out, &records, &summary)?;
    scenario.write_landmarks_tsv(BufWriter::new(fs::File::create(
        options.out.join("landmarks.tsv"),
    )?))?;
    scenario.write_world_tsv(BufWriter::new(fs::File::create(
        options.out.join("world.tsv"),
    )?))?;
    Ok(summary)
}

/// What to replay.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// A CARMEN log (FLASER / ROBOTLASER1 lines; `.gz` too).
    pub carmen: PathBuf,
    /// At the log's pace, or one scan per scan period.
    pub pace: ReplayPace,
    /// The range the log writes for "no return", m (81.83 for Intel, 50 for ACES); ranges
    /// at or above it become the sensor's no-return code.
    pub no_return_from_m: Option<f64>,
    /// Seed of the faults.
    pub seed: u64,
    /// Faults to inject.
    pub faults: FaultSpec,
    /// Where the outputs go.
    pub out: PathBuf,
    /// Pace the run at the wall clock.
    pub realtime: bool,
}

/// Bring-up of the emulated laser before it streams, s (measured: about 3 s).
const BRING_UP_ALLOWANCE_S: f64 = 5.0;

/// Replays a CARMEN log's scans through the chain: the emulated LMS is brought up by the
/// firmware as usual, then streams the recorded ranges. The truth written beside the estimate
/// is the pose the log records with each scan.
///
/// # Errors
/// When the log cannot be read, a pty cannot be opened, the firmware hangs, or an output
/// cannot be written.
pub fn replay_carmen(options: &ReplayOptions) -> io::Result<RunSummary> {
    let log = CarmenLog::read(&options.carmen)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))?;
    let scans = recorded_scans(&log, options.no_return_from_m);
    let Some(first) = scans.first() else {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!("{}: no laser records", options.carmen.display()),
        ));
    };
    let span_s = scans
        .last()
        .map_or(0.0, |l| l.timestamp_s - first.timestamp_s);
    let truth: Vec<RobotState> = log
        .lasers()
        .map(|l| RobotState {
            x_m: l.robot_pose.x_m,
            y_m: l.robot_pose.y_m,
            theta_rad: l.robot_pose.theta_rad,
            ..RobotState::default()
        })
        .collect();
    // One scan per 0.5° period (26.7 ms) as fast as possible.
    let stream_s = match options.pace {
        ReplayPace::Recorded => span_s,
        ReplayPace::AsFastAsPossible => scans.len() as f64 * 0.027,
    };
    fs::create_dir_all(&options.out)?;
    let mut lms = Lms2xx::with_world(
        Lms2xxOptions {
            seed: options.seed ^ 0x1A5E,
            ..Lms2xxOptions::default()
        },
        ShapeWorld::new(Vec::new()),
    );
    lms.replay(scans.into_iter(), options.pace, BeamMapping::Exact);
    let chain = Chain {
        lms,
        datum: GeoDatum::default(),
        trajectory: Trajectory::from_samples(1.0, vec![RobotState::default()]),
        gps_has_sky: false,
        scan_truth: Some(truth),
        unit: RangeUnit::Cm,
        pixel_m: 0.05,
    };
    let run_options = RunOptions {
        world: WorldKind::Indoor,
        seed: options.seed,
        duration_s: BRING_UP_ALLOWANCE_S + stream_s,
        faults: options.faults.clone(),
        out: options.out.clone(),
        realtime: options.realtime,
    };
    let (mut summary, records) = execute(chain, &run_options, run_options.duration_s)?;
    summary.world = format!("replay of {}", options.carmen.display());
    write_outputs(&options.out, &records, &summary)?;
    Ok(summary)
}

/// The sensors and settings of one run.
struct Chain {
    lms: Lms2xx<ShapeWorld>,
    datum: GeoDatum,
    trajectory: Trajectory,
    gps_has_sky: bool,
    scan_truth: Option<Vec<RobotState>>,
    unit: RangeUnit,
    pixel_m: f64,
}

fn check_duration(duration_s: f64) -> io::Result<()> {
    if duration_s.is_finite() && duration_s > 0.0 {
        Ok(())
    } else {
        Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("duration must be positive seconds, not {duration_s}"),
        ))
    }
}

/// Wires `chain` to the firmware through ptys and runs it for `duration_s` virtual seconds.
fn execute(
    chain: Chain,
    options: &RunOptions,
    duration_s: f64,
) -> io::Result<(RunSummary, Vec<ScanRecord>)> {
    let clock = VirtualClock::begin();
    let laser_link = PtyLink::open()?;
    let gps_link = PtyLink::open()?;
    let host_link = PtyLink::open()?;
    let gps_options = GpsEmulatorOptions {
        seed: options.seed ^ 0x6750,
        datum: chain.datum,
        ..GpsEmulatorOptions::default()
    };
    let mut laser_config = BringUpConfig::default();
    laser_config.laser.unit = chain.unit;
    let board = board::spawn(BoardConfig {
        laser_path: laser_link.board_path().into(),
        gps_path: gps_link.board_path().into(),
        host_path: host_link.board_path().into(),
        gps_baud: gps_options.baud,
        laser: laser_config,
        gps: GpsOptions::default(),
    })?;
    let endpoints = (
        Endpoint::new(laser_link, board.laser_port.clone()),
        Endpoint::new(gps_link, board.gps_port.clone()),
        Endpoint::new(host_link, board.host_port.clone()),
    );
    let sensors = Sensors {
        lms: chain.lms,
        gps: GpsEmulator::new(gps_options),
        trajectory: chain.trajectory,
        gps_has_sky: chain.gps_has_sky,
        scan_truth: chain.scan_truth,
    };
    let host = HostSide::new(Estimator::new(chain.pixel_m));
    let wall = std::time::Instant::now();
    let mut engine = Engine::new(
        &clock,
        board.clone(),
        endpoints,
        sensors,
        options.faults.clone(),
        options.seed,
        host,
        options.realtime,
    );
    let outcome = engine.run((duration_s * 1e6).round() as u64);
    board.stop();
    outcome?;
    let summary = RunSummary::new(options, &engine, wall.elapsed().as_secs_f64());
    Ok((summary, std::mem::take(&mut engine.host.records)))
}

fn write_outputs(out: &Path, records: &[ScanRecord], summary: &RunSummary) -> io::Result<()> {
    let origin = records.first().map(|r| r.truth);
    let mut trajectory = BufWriter::new(fs::File::create(out.join("trajectory.tsv"))?);
    let mut truth = BufWriter::new(fs::File::create(out.join("ground_truth.tsv"))?);
    writeln!(
        trajectory,
        "# timestamp_s x_m y_m theta_rad (map frame: the first scan's pose)"
    )?;
    writeln!(
        truth,
        "# timestamp_s x_m y_m theta_rad (map frame: the first scan's pose)"
    )?;
    for record in records {
        let [x, y, theta] = record.estimate;
        writeln!(trajectory, "{:.6} {x:.6} {y:.6} {theta:.6}", record.t_s)?;
        let [tx, ty, ttheta] = summary::in_map(origin, &record.truth);
        writeln!(truth, "{:.6} {tx:.6} {ty:.6} {ttheta:.6}", record.t_s)?;
    }
    trajectory.flush()?;
    truth.flush()?;
    let json = serde_json::to_string_pretty(summary).map_err(io::Error::other)?;
    fs::write(out.join("summary.json"), json + "\n")
}
