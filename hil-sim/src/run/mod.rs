//! `hil-sim run`: the whole chain on a seeded world — emulated LMS2xx and GPS → pseudo-terminals
//! → the firmware tasks → the host link → the host library's pipeline, as the daemon runs it
//! ([`estimator`]: method 2 indoors, method 1 with GPS outdoors) — with fault injection and an
//! account of every telegram.
//!
//! The run is lock-step on a virtual clock ([`engine`]), so the same seed, world, duration and
//! faults give byte-identical outputs, as fast as the host allows (`realtime` paces it).
//! It writes into the output directory:
//!
//! * `trajectory.tsv`: the host's estimate per scan received intact, `timestamp_s x_m y_m
//!   theta_rad`, as the pipeline holds it at the end of the run, in the `map` frame (origin:
//!   the robot's pose at its first scan; once method 1 is aligned to GPS, the local frame at
//!   the datum, which is the world frame);
//! * `ground_truth.tsv`: the true pose at the same scans, in the same frame;
//! * `scans.tsv`: every scan the host decoded, `scan_counter` then the range words;
//! * `fixes.jsonl`: every GPS fix message the host decoded, one JSON object a line, without
//!   the board's time stamp (`stamp_us` is 0);
//! * `summary.json`: the accounting ([`RunSummary`]);
//! * `performance.json`: how long the host's pipeline took per scan on this machine, and the
//!   peak memory ([`pipeline_timing::PipelineTiming`]; the one output that differs between
//!   runs);
//! * `landmarks.tsv`, `world.tsv`: the world's landmarks and shapes, in the world frame;
//! * with the EKF method, `map.tsv`: the landmarks it mapped, `x_m y_m diameter_m
//!   observations`, in the frame of `trajectory.tsv`, scored against the world's trees in
//!   `summary.json`'s `map` ([`map_quality`]);
//! * with the camera method ([`RunOptions::camera`]), `camera_trajectory.tum` and
//!   `camera_ground_truth.tum`: the camera's estimated and true path per frame, and once
//!   GPS has aligned its map `camera_map.geojson` and `camera_map.kml` ([`camera_outcome`]),
//!   scored in `summary.json`'s `camera`.
//!
//! Accounting: every scan telegram the laser emitted is either delivered intact to the host
//! or counted as rejected by the system itself — by the firmware (scan periods between valid
//! telegrams, or with bytes but no valid telegram, [`firmware::sick::ScanSlots`]) or by the
//! host (gaps in the board's scan counter: dropped on the board or lost on the link).
//! `accounting_balanced` says whether `delivered intact + counted rejected = emitted`.

pub mod camera_feed;
pub mod camera_outcome;
pub mod engine;
pub mod estimator;
pub mod host_side;
pub mod map_quality;
pub mod pipeline_timing;
pub mod summary;
pub mod tap;

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::SyncSender;

use firmware::sick::BringUpConfig;
use firmware::tasks::gps::GpsOptions;
use host::ekf_slam::MappedLandmark;
use protocol::RangeUnit;

use crate::board::{self, BoardConfig};
use crate::emulators::{
    BeamMapping, GpsEmulator, GpsEmulatorOptions, Lms2xx, Lms2xxOptions, RecordedScan, ReplayPace,
};
use crate::faults::FaultSpec;
use crate::pty::PtyLink;
use crate::replay::{
    CarmenLog, LocalGpsFix, TreeScanOptions, VictoriaPark, capture_scans, recorded_scans,
    saturation_from_m, tree_scans,
};
use crate::sim_time::VirtualClock;
use crate::world::{GeoDatum, RobotState, Scenario, ShapeWorld, Trajectory, WorldKind};
pub use camera_feed::CameraRunOptions;
use camera_feed::{CameraFeed, CameraFrame};
use engine::{Endpoint, Engine, Sensors, Wiring};
pub use engine::{Line, ReportedBaud};
use estimator::Estimator;
use host_side::{DecodedScan, HostSide, ScanRecord};
use map_quality::MapQuality;
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
    /// Drive a flashed board on these serial ports instead of the firmware in this process.
    pub hardware: Option<HardwarePorts>,
    /// Indoors, make every scan a node of the map instead of only those after which the
    /// robot moved 0.2 m or turned 1° ([`host::slam::motion_filter`], the default).
    pub grid_every_scan: bool,
    /// Outdoors, estimate with the camera method on the robot computer's camera (method 1
    /// on a single camera, aligned to GPS) instead of the laser.
    pub camera: Option<CameraRunOptions>,
}

/// The serial ports of a flashed board (`--hardware`): the emulators write to the laser and
/// GPS lines, the host reads the link.
#[derive(Debug, Clone, PartialEq)]
pub struct HardwarePorts {
    /// The port wired to the board's laser UART (RS-422 side).
    pub laser: PathBuf,
    /// The port wired to the board's GPS UART.
    pub gps: PathBuf,
    /// The board's host link (USB CDC-ACM, e.g. `/dev/ttyACM0`, or a UART adapter).
    pub host: PathBuf,
    /// The rate the board's GPS UART listens at (the board's default is 9600 Bd).
    pub gps_baud: u32,
}

/// Baud rate of the board's host link with a UART (USB CDC-ACM ignores it).
const HOST_LINK_BAUD: u32 = 921_600;
/// The laser's rate at power-up.
const LASER_POWER_UP_BAUD: u32 = 9_600;

/// The three lines to a board that the engine cannot observe, open.
pub struct WallLines {
    /// To the board's laser UART.
    pub laser: Line,
    /// To the board's GPS UART.
    pub gps: Line,
    /// The board's host link.
    pub host: Line,
    /// The rate the board's GPS UART listens at.
    pub gps_baud: u32,
    /// Called just before the run's clock starts (an emulated board is released from reset).
    pub start: Option<Box<dyn FnOnce() -> io::Result<()> + Send>>,
}

impl WallLines {
    /// Opens the ports of `ports`: the laser line at the sensor's power-on rate, the GPS line
    /// at `ports.gps_baud`.
    ///
    /// # Errors
    /// A port that cannot be opened, named.
    pub fn open(ports: &HardwarePorts) -> io::Result<WallLines> {
        let open = |path: &Path, baud: u32| {
            serialport::new(path.to_string_lossy(), baud)
                .open_native()
                .map(Line::Port)
                .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))
        };
        Ok(WallLines {
            laser: open(&ports.laser, LASER_POWER_UP_BAUD)?,
            gps: open(&ports.gps, ports.gps_baud)?,
            host: open(&ports.host, HOST_LINK_BAUD)?,
            gps_baud: ports.gps_baud,
            start: None,
        })
    }
}

/// Runs the chain and writes the outputs; returns the summary.
///
/// # Errors
/// When a pty cannot be opened, the firmware hangs, or an output cannot be written.
pub fn run(options: &RunOptions) -> io::Result<RunSummary> {
    let lines = options.hardware.as_ref().map(WallLines::open).transpose()?;
    run_on(options, lines)
}

/// As [`run`], driving a board through `lines` on the wall clock when given (whatever
/// `options.hardware` says), else the firmware in this process, lock-step.
///
/// # Errors
/// As [`run`].
pub fn run_on(options: &RunOptions, lines: Option<WallLines>) -> io::Result<RunSummary> {
    run_chain(options, lines, None, None)
}

/// As [`run_on`], with the firmware in this process bringing the laser up with `bring_up`
/// when given (e.g. as the QEMU image does, [`crate::qemu::image_bring_up`]) instead of the
/// board's default with the world's range unit (cm outdoors, mm indoors).
///
/// # Errors
/// As [`run`].
pub fn run_with_bring_up(
    options: &RunOptions,
    lines: Option<WallLines>,
    bring_up: Option<BringUpConfig>,
) -> io::Result<RunSummary> {
    run_chain(options, lines, bring_up, None)
}

/// As [`run`] with the firmware in this process, passing the host link on through `relay`
/// to the program that opened its other end (the robot computer's daemon), which then
/// drives the board's clock sync; this side keeps its accounting.
///
/// # Errors
/// As [`run`].
pub fn run_relayed(
    options: &RunOptions,
    relay: PtyLink,
    camera_relay: Option<SyncSender<CameraFrame>>,
) -> io::Result<RunSummary> {
    run_chain(options, None, None, Some((relay, camera_relay)))
}

/// The host link and, with the camera, its frames, passed on to another program.
type Relay = (PtyLink, Option<SyncSender<CameraFrame>>);

fn run_chain(
    options: &RunOptions,
    lines: Option<WallLines>,
    bring_up: Option<BringUpConfig>,
    relay: Option<Relay>,
) -> io::Result<RunSummary> {
    check_duration(options.duration_s)?;
    let outdoor = options.world == WorldKind::Outdoor;
    if let Some(camera) = &options.camera {
        if !outdoor {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "the camera method runs outdoors (the indoor world has no texture to track)",
            ));
        }
        if !(camera.rate_hz.is_finite() && camera.rate_hz > 0.0) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "the camera rate must be positive frames per second, not {}",
                    camera.rate_hz
                ),
            ));
        }
        if let Err(frames) = crate::camera_render::frame_count(options.duration_s, camera.rate_hz) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "{frames} camera frames are more than the {} a run may render",
                    crate::camera_render::MAX_FRAMES
                ),
            ));
        }
    }
    fs::create_dir_all(&options.out)?;
    let scenario = Scenario::generate_for(options.world, options.seed, options.duration_s + 1.0);
    let lms = Lms2xx::with_world(
        Lms2xxOptions {
            seed: options.seed ^ 0x1A5E,
            pose: scenario.sensor_pose_at(0.0),
            max_range_m: if outdoor { 60.0 } else { 8.0 },
            ..Lms2xxOptions::default()
        },
        scenario.world().clone(),
    );
    // Outdoors the features are far: 80 m (cm) mode; indoors mm resolution.
    let bring_up = bring_up.unwrap_or_else(|| {
        let mut config = BringUpConfig::default();
        config.laser.unit = if outdoor {
            RangeUnit::Cm
        } else {
            RangeUnit::Mm
        };
        config
    });
    let chain = Chain {
        lms,
        datum: scenario.datum(),
        trajectory: scenario.trajectory().clone(),
        gps_has_sky: outdoor,
        scan_truth: None,
        gps_log: None,
        bring_up,
        uses_landmarks: outdoor,
        camera: options
            .camera
            .as_ref()
            .map(|camera| CameraFeed::new(&scenario, camera, options.seed))
            .transpose()?,
    };
    let (mut summary, received) = execute(chain, options, options.duration_s, lines, relay)?;
    if !received.map.is_empty() {
        let origin = received
            .records
            .first()
            .map(|r| r.truth)
            .filter(|_| !received.geo_referenced);
        summary.map = Some(MapQuality::new(&received.map, scenario.landmarks(), |p| {
            summary::world_from_map(origin, p)
        }));
    }
    write_outputs(&options.out, &received, &summary)?;
    scenario.write_landmarks_tsv(BufWriter::new(fs::File::create(
        options.out.join("landmarks.tsv"),
    )?))?;
    scenario.write_world_tsv(BufWriter::new(fs::File::create(
        options.out.join("world.tsv"),
    )?))?;
    Ok(summary)
}

/// A recording to turn back into sensor byte streams.
#[derive(Debug, Clone, PartialEq)]
pub enum ReplaySource {
    /// A CARMEN log (FLASER / ROBOTLASER1 lines; `.gz` too): its scans' ranges. The truth is
    /// the pose the log records with each scan.
    Carmen(PathBuf),
    /// The Victoria Park directory (`measurements.dat`, `gps.dat`, `inputs.dat`): laser scans
    /// rebuilt from the tree detections and the recorded GPS fixes as NMEA. The truth is the
    /// GPS position at each scan (heading along the GPS track).
    Victoria(PathBuf),
    /// A raw sensor → host capture at the given baud rate: its scan telegrams, byte for byte
    /// (damaged ones too). No truth.
    Capture {
        /// The capture file.
        path: PathBuf,
        /// The rate it was recorded at (it times the telegrams at the recorded pace).
        baud: u32,
    },
}

impl std::fmt::Display for ReplaySource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReplaySource::Carmen(path) => write!(f, "CARMEN log {}", path.display()),
            ReplaySource::Victoria(path) => write!(f, "Victoria Park {}", path.display()),
            ReplaySource::Capture { path, baud } => {
                write!(f, "capture {} at {baud} Bd", path.display())
            }
        }
    }
}

/// What to replay.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// The recording.
    pub source: ReplaySource,
    /// At the log's pace, or one scan per scan period.
    pub pace: ReplayPace,
    /// The range a CARMEN log writes for "no return", m (81.83 for Intel, 50 for ACES); ranges
    /// at or above it become the sensor's no-return code. `None` reads it from the log where
    /// its ranges pile up at their largest value ([`saturation_from_m`]), else takes a
    /// `ROBOTLASER1` record's maximum range.
    pub no_return_from_m: Option<f64>,
    /// Seed of the faults.
    pub seed: u64,
    /// Faults to inject.
    pub faults: FaultSpec,
    /// Where the outputs go.
    pub out: PathBuf,
    /// Pace the run at the wall clock.
    pub realtime: bool,
    /// Drive a flashed board on these serial ports instead of the firmware in this process.
    pub hardware: Option<HardwarePorts>,
}

/// Bring-up of the emulated laser before it streams, s (measured: about 3 s).
const BRING_UP_ALLOWANCE_S: f64 = 5.0;

/// The scans, their truth and the GPS of a recording.
struct Recording {
    scans: Vec<RecordedScan>,
    truth: Vec<RobotState>,
    gps: Option<(Vec<LocalGpsFix>, f64)>,
    unit: RangeUnit,
}

fn invalid_data(e: impl std::fmt::Display) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, e.to_string())
}

fn read_recording(options: &ReplayOptions) -> io::Result<Recording> {
    match &options.source {
        ReplaySource::Carmen(path) => {
            let log = CarmenLog::read(path).map_err(invalid_data)?;
            let truth = log
                .lasers()
                .map(|l| RobotState {
                    x_m: l.robot_pose.x_m,
                    y_m: l.robot_pose.y_m,
                    theta_rad: l.robot_pose.theta_rad,
                    ..RobotState::default()
                })
                .collect();
            Ok(Recording {
                scans: recorded_scans(
                    &log,
                    options
                        .no_return_from_m
                        .or_else(|| saturation_from_m(log.lasers())),
                ),
                truth,
                gps: None,
                unit: RangeUnit::Cm,
            })
        }
        ReplaySource::Victoria(dir) => {
            let park = VictoriaPark::read_dir(dir).map_err(invalid_data)?;
            let scans = tree_scans(&park.scans, &TreeScanOptions::default());
            let truth = park
                .scans
                .iter()
                .map(|s| gps_truth_at(&park.gps, s.t_s))
                .collect();
            let first_scan_s = park.scans.first().map_or(0.0, |s| s.t_s);
            Ok(Recording {
                scans,
                truth,
                gps: Some((park.gps, first_scan_s)),
                unit: RangeUnit::Cm,
            })
        }
        ReplaySource::Capture { path, baud } => {
            let bytes = fs::read(path)
                .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
            let scans = capture_scans(&bytes, *baud);
            let truth = vec![RobotState::default(); scans.len()];
            Ok(Recording {
                scans,
                truth,
                gps: None,
                unit: RangeUnit::Mm,
            })
        }
    }
}

/// The robot's pose at `t_s` from recorded GPS fixes: the position interpolated between the
/// fixes around it, the heading along the track between them (east = x, north = y).
fn gps_truth_at(fixes: &[LocalGpsFix], t_s: f64) -> RobotState {
    let after = fixes.partition_point(|f| f.t_s <= t_s);
    let (a, b) = match (
        after.checked_sub(1).and_then(|i| fixes.get(i)),
        fixes.get(after),
    ) {
        (Some(a), Some(b)) => (a, b),
        (Some(a), None) => (a, a),
        (None, Some(b)) => (b, b),
        (None, None) => return RobotState::default(),
    };
    let span_s = b.t_s - a.t_s;
    let w = if span_s > 0.0 {
        (t_s - a.t_s) / span_s
    } else {
        0.0
    };
    RobotState {
        x_m: a.x_m + w * (b.x_m - a.x_m),
        y_m: a.y_m + w * (b.y_m - a.y_m),
        theta_rad: (b.y_m - a.y_m).atan2(b.x_m - a.x_m),
        ..RobotState::default()
    }
}

/// Replays a recording's scans (and GPS) through the chain: the emulated LMS is brought up by
/// the firmware as usual, then streams the recorded scans. The truth written beside the
/// estimate is the recording's own (see [`ReplaySource`]).
///
/// # Errors
/// When the recording cannot be read or holds no scan, a port cannot be opened, the firmware
/// hangs, or an output cannot be written.
pub fn replay(options: &ReplayOptions) -> io::Result<RunSummary> {
    let lines = options.hardware.as_ref().map(WallLines::open).transpose()?;
    replay_on(options, lines)
}

/// As [`replay`], driving a board through `lines` on the wall clock when given.
///
/// # Errors
/// As [`replay`].
pub fn replay_on(options: &ReplayOptions, lines: Option<WallLines>) -> io::Result<RunSummary> {
    let recording = read_recording(options)?;
    let scans = recording.scans;
    let (Some(first), Some(last)) = (scans.first(), scans.last()) else {
        return Err(invalid_data(format!("{}: no laser scans", options.source)));
    };
    let span_s = last.timestamp_s - first.timestamp_s;
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
        gps_has_sky: recording.gps.is_some(),
        scan_truth: Some(recording.truth),
        gps_log: recording.gps,
        bring_up: {
            let mut config = BringUpConfig::default();
            config.laser.unit = recording.unit;
            config
        },
        uses_landmarks: matches!(options.source, ReplaySource::Victoria(_)),
        camera: None,
    };
    let run_options = RunOptions {
        world: WorldKind::Indoor,
        seed: options.seed,
        duration_s: BRING_UP_ALLOWANCE_S + stream_s,
        faults: options.faults.clone(),
        out: options.out.clone(),
        realtime: options.realtime,
        hardware: options.hardware.clone(),
        grid_every_scan: false,
        camera: None,
    };
    let (mut summary, received) =
        execute(chain, &run_options, run_options.duration_s, lines, None)?;
    summary.world = format!("replay of {}", options.source);
    write_outputs(&options.out, &received, &summary)?;
    Ok(summary)
}

/// The sensors and settings of one run.
struct Chain {
    lms: Lms2xx<ShapeWorld>,
    datum: GeoDatum,
    trajectory: Trajectory,
    gps_has_sky: bool,
    scan_truth: Option<Vec<RobotState>>,
    gps_log: Option<(Vec<LocalGpsFix>, f64)>,
    /// How the firmware in this process brings the laser up.
    bring_up: BringUpConfig,
    /// Trees and GPS, method 1 (outdoors, Victoria Park); else the occupancy grid, method 2.
    uses_landmarks: bool,
    /// The robot computer's camera: method 1 on it (with GPS) instead of the laser.
    camera: Option<CameraFeed>,
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

/// Wires `chain` to the firmware through ptys and runs it for `duration_s` virtual seconds,
/// or, given `lines`, to a board on those lines for `duration_s` wall-clock seconds.
fn execute(
    chain: Chain,
    options: &RunOptions,
    duration_s: f64,
    lines: Option<WallLines>,
    relay: Option<Relay>,
) -> io::Result<(RunSummary, Received)> {
    let mut gps_options = GpsEmulatorOptions {
        seed: options.seed ^ 0x6750,
        datum: chain.datum,
        ..GpsEmulatorOptions::default()
    };
    if let Some(lines) = &lines {
        gps_options.baud = lines.gps_baud;
        gps_options.rate_hz = gps_rate_for(lines.gps_baud);
    }
    let datum = [chain.datum.lat_deg, chain.datum.lon_deg];
    // A camera relayed to another program is that program's: this side maps with the laser.
    let camera_relayed = relay.as_ref().is_some_and(|(_, camera)| camera.is_some());
    let estimator = if let Some(camera) = chain.camera.as_ref().filter(|_| !camera_relayed) {
        Estimator::camera(
            *camera.camera(),
            camera.level(),
            camera.forward_motion(),
            camera.fuse_gps(),
            datum,
        )?
    } else if chain.uses_landmarks {
        Estimator::ekf(datum)
    } else {
        Estimator::grid(options.grid_every_scan).map_err(io::Error::other)?
    };
    let sensors = Sensors {
        lms: chain.lms,
        gps: GpsEmulator::new(gps_options.clone()),
        trajectory: chain.trajectory,
        gps_has_sky: chain.gps_has_sky,
        scan_truth: chain.scan_truth,
        gps_log: chain.gps_log,
        camera: chain.camera,
    };
    let host = HostSide::new(estimator);
    let duration_us = (duration_s * 1e6).round() as u64;
    let wall = std::time::Instant::now();
    if let Some(mut lines) = lines {
        if let Some(start) = lines.start.take() {
            start()?;
        }
        let endpoints = (
            Endpoint::wall(lines.laser),
            Endpoint::wall(lines.gps),
            Endpoint::wall(lines.host),
        );
        let mut engine = Engine::new(
            Wiring::Wall,
            endpoints,
            sensors,
            options.faults.clone(),
            options.seed,
            host,
            true,
        );
        engine.run(duration_us)?;
        engine.host.finish()?;
        write_camera_outputs(&engine.host, &options.out)?;
        let summary = RunSummary::new(options, &engine, wall.elapsed().as_secs_f64());
        return Ok((summary, Received::take(&mut engine.host)));
    }

    let clock = VirtualClock::begin();
    let laser_link = PtyLink::open()?;
    let gps_link = PtyLink::open()?;
    let host_link = PtyLink::open()?;
    let board = board::spawn(BoardConfig {
        laser_path: laser_link.board_path().into(),
        gps_path: gps_link.board_path().into(),
        host_path: host_link.board_path().into(),
        gps_baud: gps_options.baud,
        laser: chain.bring_up,
        gps: GpsOptions::default(),
    })?;
    let endpoints = (
        Endpoint::new(laser_link, board.laser_port.clone()),
        Endpoint::new(gps_link, board.gps_port.clone()),
        Endpoint::new(host_link, board.host_port.clone()),
    );
    let mut engine = Engine::new(
        Wiring::LockStep {
            clock: &clock,
            board: board.clone(),
        },
        endpoints,
        sensors,
        options.faults.clone(),
        options.seed,
        host,
        options.realtime,
    );
    if let Some((relay, camera)) = relay {
        engine.relay_host_link(relay);
        if let Some(camera) = camera {
            engine.relay_camera(camera);
        }
    }
    let outcome = engine.run(duration_us);
    board.stop();
    outcome?;
    engine.host.finish()?;
    write_camera_outputs(&engine.host, &options.out)?;
    let summary = RunSummary::new(options, &engine, wall.elapsed().as_secs_f64());
    Ok((summary, Received::take(&mut engine.host)))
}

/// The camera method's path and its truth, when it ran ([`camera_outcome`]).
fn write_camera_outputs(host: &HostSide, out: &Path) -> io::Result<()> {
    match host.camera_pipeline() {
        Some(pipeline) => camera_outcome::write_camera_outputs(out, pipeline, &host.camera_records),
        None => Ok(()),
    }
}

/// GPS epochs per second that fit a line at `baud` (an epoch of five sentences is about
/// 400 bytes, 4 000 bits with start and stop bits), 1–10.
fn gps_rate_for(baud: u32) -> u32 {
    (baud / 4_000).clamp(1, 10)
}

/// What the host received, for the outputs.
struct Received {
    records: Vec<ScanRecord>,
    /// The EKF method's landmarks, in the frame of `records`' estimates.
    map: Vec<MappedLandmark>,
    geo_referenced: bool,
    scans: Vec<DecodedScan>,
    fixes: Vec<protocol::GpsFixMsg>,
}

impl Received {
    fn take(host: &mut HostSide) -> Received {
        Received {
            records: std::mem::take(&mut host.records),
            map: host.mapped_landmarks(),
            geo_referenced: host.geo_referenced,
            scans: std::mem::take(&mut host.scans),
            fixes: std::mem::take(&mut host.fixes),
        }
    }
}

fn write_outputs(out: &Path, received: &Received, summary: &RunSummary) -> io::Result<()> {
    let records = &received.records;
    let origin = records
        .first()
        .map(|r| r.truth)
        .filter(|_| !received.geo_referenced);
    let frame = if received.geo_referenced {
        "map frame: the local frame at the GPS datum"
    } else {
        "map frame: the first scan's pose"
    };
    let mut trajectory = BufWriter::new(fs::File::create(out.join("trajectory.tsv"))?);
    let mut truth = BufWriter::new(fs::File::create(out.join("ground_truth.tsv"))?);
    writeln!(trajectory, "# timestamp_s x_m y_m theta_rad ({frame})")?;
    writeln!(truth, "# timestamp_s x_m y_m theta_rad ({frame})")?;
    for record in records {
        let [x, y, theta] = record.estimate;
        writeln!(trajectory, "{:.6} {x:.6} {y:.6} {theta:.6}", record.t_s)?;
        let [tx, ty, ttheta] = summary::in_map(origin, &record.truth);
        writeln!(truth, "{:.6} {tx:.6} {ty:.6} {ttheta:.6}", record.t_s)?;
    }
    trajectory.flush()?;
    truth.flush()?;
    let mut scans = BufWriter::new(fs::File::create(out.join("scans.tsv"))?);
    writeln!(scans, "# scan_counter range words")?;
    for scan in &received.scans {
        write!(scans, "{}", scan.scan_counter)?;
        for value in &scan.values {
            write!(scans, " {value}")?;
        }
        writeln!(scans)?;
    }
    scans.flush()?;
    let mut fixes = BufWriter::new(fs::File::create(out.join("fixes.jsonl"))?);
    for fix in &received.fixes {
        serde_json::to_writer(&mut fixes, fix).map_err(io::Error::other)?;
        writeln!(fixes)?;
    }
    fixes.flush()?;
    if !received.map.is_empty() {
        let mut map = BufWriter::new(fs::File::create(out.join("map.tsv"))?);
        writeln!(map, "# x_m y_m diameter_m observations ({frame})")?;
        for landmark in &received.map {
            let [x, y] = landmark.position_in_map;
            let diameter_m = landmark.info.diameter_m.unwrap_or(f64::NAN);
            let observations = landmark.info.observations;
            writeln!(map, "{x:.6} {y:.6} {diameter_m:.4} {observations}")?;
        }
        map.flush()?;
    }
    let json = serde_json::to_string_pretty(summary).map_err(io::Error::other)?;
    fs::write(out.join("summary.json"), json + "\n")?;
    let json = serde_json::to_string_pretty(&summary.pipeline).map_err(io::Error::other)?;
    fs::write(out.join("performance.json"), json + "\n")
}
