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
use crate::emulators::{GpsEmulator, GpsEmulatorOptions, Lms2xx, Lms2xxOptions};
use crate::faults::FaultSpec;
use crate::pty::PtyLink;
use crate::sim_time::VirtualClock;
use crate::world::{Scenario, WorldKind};
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
    if !(options.duration_s.is_finite() && options.duration_s > 0.0) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "duration must be positive seconds, not {}",
                options.duration_s
            ),
        ));
    }
    fs::create_dir_all(&options.out)?;
    let scenario = Scenario::generate_for(options.world, options.seed, options.duration_s + 1.0);
    let outdoor = options.world == WorldKind::Outdoor;

    let clock = VirtualClock::begin();
    let laser_link = PtyLink::open()?;
    let gps_link = PtyLink::open()?;
    let host_link = PtyLink::open()?;
    let gps_options = GpsEmulatorOptions {
        seed: options.seed ^ 0x6750,
        datum: scenario.datum(),
        ..GpsEmulatorOptions::default()
    };
    // Outdoors the features are far: 80 m (cm) mode; indoors mm resolution.
    let mut laser_config = BringUpConfig::default();
    laser_config.laser.unit = if outdoor {
        RangeUnit::Cm
    } else {
        RangeUnit::Mm
    };
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
    let lms = Lms2xx::with_world(
        Lms2xxOptions {
            seed: options.seed ^ 0x1A5E,
            pose: scenario.sensor_pose_at(0.0),
            max_range_m: if outdoor { 60.0 } else { 8.0 },
            ..Lms2xxOptions::default()
        },
        scenario.world().clone(),
    );
    let sensors = Sensors {
        lms,
        gps: GpsEmulator::new(gps_options),
        trajectory: scenario.trajectory().clone(),
        gps_has_sky: outdoor,
    };
    let host = HostSide::new(Estimator::new(if outdoor { 0.1 } else { 0.05 }));
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
    let outcome = engine.run((options.duration_s * 1e6).round() as u64);
    board.stop();
    outcome?;
    let wall_s = wall.elapsed().as_secs_f64();
    let summary = RunSummary::new(options, &engine, wall_s);
    write_outputs(&options.out, &scenario, &engine.host.records, &summary)?;
    Ok(summary)
}

fn write_outputs(
    out: &Path,
    scenario: &Scenario,
    records: &[ScanRecord],
    summary: &RunSummary,
) -> io::Result<()> {
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
    scenario.write_landmarks_tsv(BufWriter::new(fs::File::create(out.join("landmarks.tsv"))?))?;
    scenario.write_world_tsv(BufWriter::new(fs::File::create(out.join("world.tsv"))?))?;
    let json = serde_json::to_string_pretty(summary).map_err(io::Error::other)?;
    fs::write(out.join("summary.json"), json + "\n")
}
