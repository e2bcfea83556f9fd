//! The whole system on one machine, no hardware and no data files: a seeded world with its
//! generated, geo-referenced aerial image; emulated laser and GPS → the firmware tasks on
//! the host executor → a pseudo-terminal → the robot-host daemon, which maps, records and
//! serves the web view where the user clicks a goal.
//!
//! The world's run is [`crate::run`]'s lock-step chain paced at the wall clock; its host link
//! is passed on through a second pseudo-terminal, which the daemon opens as its serial port
//! exactly as it opens the board's on the robot.
//!
//! With the camera ([`DemoOptions::camera`], outdoors) the robot computer's camera is rendered
//! at the true pose of each frame's time and handed to the daemon as its camera
//! ([`SimulatedCamera`]): 8-bit grey frames, which the daemon's capture code takes as it takes
//! a grey camera's, and the daemon runs the camera method on them with the board's GPS.

use std::fs;
use std::io;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use host::camera::{CameraPipeline, ForwardMotionPrior, LevelPrior};
use robot_host::camera_capture::{CaptureError, FrameSource, PixelFormat, RawFrame};

use host::geoimage::{GeoImage, GeographicGeoref, write_geotiff_geographic_rgb8};
use host::recording::existing_parts;
use robot_host::LinkCounters;
use robot_host::config::{DaemonConfig, SlamMethod};
use robot_host::outputs::write_outputs;
use robot_host::runner::{Daemon, SerialPortOpener};
use serde::Serialize;

use crate::faults::FaultSpec;
use crate::pty::PtyLink;
use crate::run::camera_feed::{CameraFrame, CameraRunOptions};
use crate::run::camera_outcome::CameraOutcome;
use crate::run::host_side::CameraRecord;
use crate::run::{RunOptions, RunSummary, run_relayed};
use crate::world::aerial::render_aerial;
use crate::world::{Scenario, WorldKind};

/// Metres per pixel of the generated aerial image.
const AERIAL_PIXEL_M: f64 = 0.25;
/// After the sensors stop, the daemon gets up to this long to take in the last frames.
const DRAIN: Duration = Duration::from_secs(10);

/// What to run.
#[derive(Debug, Clone)]
pub struct DemoOptions {
    /// Indoor (occupancy-grid SLAM) or outdoor (EKF SLAM with GPS and the aerial image).
    pub world: WorldKind,
    /// Seed of the world, its route and the sensor noise.
    pub seed: u64,
    /// Seconds of driving.
    pub duration_s: f64,
    /// Where the web view listens (port 0: any free port).
    pub serve: SocketAddr,
    /// Where the live Foxglove stream listens, if anywhere.
    pub foxglove: Option<SocketAddr>,
    /// Where the outputs go.
    pub out: PathBuf,
    /// Pace the run at the wall clock (off: as fast as the machine goes).
    pub realtime: bool,
    /// After the drive, keep the web view up this many seconds before writing the outputs.
    pub linger_s: f64,
    /// The robot computer's camera and the camera method (outdoors); `None`: the laser
    /// method.
    pub camera: Option<CameraRunOptions>,
}

impl Default for DemoOptions {
    fn default() -> Self {
        DemoOptions {
            world: WorldKind::Outdoor,
            seed: 1,
            duration_s: 60.0,
            serve: SocketAddr::from(([127, 0, 0, 1], 8080)),
            foxglove: None,
            out: PathBuf::from("demo-out"),
            realtime: true,
            linger_s: 0.0,
            camera: None,
        }
    }
}

/// What the demo did.
#[derive(Debug, Clone, Serialize)]
pub struct DemoReport {
    /// The world.
    pub world: String,
    /// Its seed.
    pub seed: u64,
    /// Where the web view was served.
    pub web: Option<String>,
    /// The daemon's link counters at the end.
    pub daemon_counters: LinkCounters,
    /// Scans the daemon's map holds a pose for.
    pub daemon_scans: usize,
    /// Whether the map was geo-referenced by GPS.
    pub geo_referenced: bool,
    /// Landmarks mapped (outdoors; the map's points with the camera method).
    pub landmarks: usize,
    /// The camera, with the camera method.
    pub camera: Option<DemoCameraReport>,
    /// The files written.
    pub outputs: Vec<PathBuf>,
    /// The simulation's own accounting of the run (emulators, firmware, link).
    pub simulation: RunSummary,
}

/// What the daemon's camera did, and how its path compares with the truth.
#[derive(Debug, Clone, Serialize)]
pub struct DemoCameraReport {
    /// Frames whose time falls within the drive: those the run renders and hands over.
    pub frames_due: u64,
    /// Frames the daemon's capture took (from the daemon's own count).
    pub frames_captured: u64,
    /// Frames the camera method tracked.
    pub frames_tracked: usize,
    /// Frames the camera method was still busy for.
    pub frames_skipped: u64,
    /// Local maps started.
    pub local_maps: usize,
    /// Places of earlier local maps recognised.
    pub places_recognised: usize,
    /// GPS fixes paired with the camera.
    pub fixes_paired: usize,
    /// The map's scale from GPS, metres per map unit, once aligned.
    pub scale_from_gps: Option<f64>,
    /// Map points.
    pub map_points: usize,
    /// How far the run fell behind the wall clock at its worst, s: the daemon stamps frames
    /// on the wall clock and fixes through the board's clock, which follows the run, so a
    /// machine too busy to keep pace skews the one against the other.
    pub run_behind_wall_clock_max_s: f64,
    /// The frames the camera method tracked, scored against their truth: the path once GPS
    /// placed it, the map's scale from GPS against the truth's (`None` if a tracked frame
    /// was not one the run took, which would be a fault of the chain).
    pub against_truth: Option<CameraOutcome>,
}

/// The rendered camera as the daemon's camera: each frame the run hands over, as 8-bit grey,
/// taken when the run's clock reached its time. It keeps each frame's truth.
pub struct SimulatedCamera {
    frames: Receiver<CameraFrame>,
    truth: Arc<Mutex<Vec<(Instant, CameraRecord)>>>,
}

impl FrameSource for SimulatedCamera {
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError> {
        // The run has ended when it drops its end.
        let Ok(frame) = self.frames.recv() else {
            return Ok(None);
        };
        self.truth
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push((
                frame.taken_at,
                CameraRecord {
                    t_s: frame.t_s,
                    position_m: frame.position_m,
                    orientation: frame.orientation,
                },
            ));
        let (width_px, height_px) = frame.image.dimensions();
        Ok(Some(RawFrame {
            captured_at: Some(frame.taken_at),
            format: PixelFormat::Grey,
            width_px,
            height_px,
            bytes: frame.image.into_raw(),
        }))
    }

    fn name(&self) -> String {
        "hil-sim camera".into()
    }
}

/// Something the demo needs while it runs: the web view's address once it is up.
pub struct DemoReady {
    /// The web view.
    pub web: Option<SocketAddr>,
    /// The Foxglove stream.
    pub foxglove: Option<SocketAddr>,
    /// The daemon's live state.
    pub state: robot_host::SharedState,
}

/// Runs the demo: writes the aerial image, starts the daemon, calls `ready` once it serves,
/// drives the world for the duration, keeps serving for the linger time, then writes the
/// outputs.
///
/// # Errors
/// A pty, the daemon or an output that cannot be set up or written.
pub fn run(options: &DemoOptions, ready: impl FnOnce(&DemoReady)) -> io::Result<DemoReport> {
    if !(options.duration_s.is_finite() && options.duration_s > 0.0) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "the duration must be a positive number of seconds",
        ));
    }
    if options.camera.is_some() && options.world != WorldKind::Outdoor {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "the camera method runs outdoors (the indoor world has no texture to track)",
        ));
    }
    fs::create_dir_all(&options.out)?;
    let DaemonSetup {
        relay,
        mut config,
        image: image_path,
    } = DaemonSetup::prepare(
        options.world,
        options.seed,
        options.duration_s,
        &options.out,
        options.serve,
        options.foxglove,
    )?;

    let opener = SerialPortOpener {
        path: config.link.port.clone(),
        baud: config.link.baud,
    };
    let camera_truth = Arc::new(Mutex::new(Vec::new()));
    let (camera_tx, camera) = match &options.camera {
        Some(camera) => {
            set_camera(&mut config, camera);
            // Two frames in hand: the run waits rather than drop a frame the capture has
            // not yet taken.
            let (tx, rx) = mpsc::sync_channel(2);
            let source = SimulatedCamera {
                frames: rx,
                truth: camera_truth.clone(),
            };
            (Some(tx), Some(Box::new(source) as Box<dyn FrameSource>))
        }
        None => (None, None),
    };
    let daemon =
        Daemon::start_with_camera(&config, Box::new(opener), camera).map_err(io::Error::other)?;
    ready(&DemoReady {
        web: daemon.web_addr(),
        foxglove: daemon.foxglove_addr(),
        state: daemon.state(),
    });

    let run_options = RunOptions {
        world: options.world,
        seed: options.seed,
        duration_s: options.duration_s,
        faults: FaultSpec::default(),
        out: options.out.join("simulation"),
        realtime: options.realtime,
        hardware: None,
        grid_every_scan: false,
        camera: options.camera,
    };
    // The pty's device end stays open until the daemon has read everything: closing it hangs
    // the line up, and the frames still in the board end's buffer would be lost.
    let device_end = relay.device.try_clone_native().map_err(io::Error::other)?;
    let simulation = run_relayed(&run_options, relay, camera_tx);
    // The daemon reads on its own thread: give it the frames the simulation's side read, and
    // the camera frames still waiting for its capture.
    if let Ok(summary) = &simulation {
        let state = daemon.state();
        let deadline = Instant::now() + DRAIN;
        let camera_frames = frames_due(options);
        let waiting = |s: &robot_host::LiveState| {
            let captured = s.camera.as_ref().map_or(0, |c| c.status.frames_captured);
            s.counters.frames < summary.counted.host_frames || captured < camera_frames
        };
        while Instant::now() < deadline && state.read().is_ok_and(|s| waiting(&s)) {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    std::thread::sleep(Duration::from_secs_f64(options.linger_s.max(0.0)));
    let web = daemon.web_addr().map(|a| format!("http://{a}/"));
    let clock = daemon.clock();
    let outcome = daemon.stop().map_err(io::Error::other)?;
    drop(device_end);
    let simulation = simulation?;

    let image = image_path
        .as_deref()
        .map(GeoImage::open)
        .transpose()
        .map_err(io::Error::other)?;
    let written =
        write_outputs(&options.out, &outcome, image.as_ref()).map_err(io::Error::other)?;
    let mut outputs = written.files;
    outputs.extend(image_path);
    outputs.push(options.out.join("run.mcap"));
    let daemon_scans = outcome
        .ekf
        .as_ref()
        .map(|e| e.scans_placed())
        .or(outcome.grid.as_ref().map(|g| g.trajectory().len()))
        .unwrap_or(0);
    Ok(DemoReport {
        world: options.world.to_string(),
        seed: options.seed,
        web,
        daemon_counters: outcome.state.counters,
        daemon_scans,
        geo_referenced: outcome.state.enu_from_map.is_some(),
        landmarks: outcome.ekf.as_ref().map_or_else(
            || {
                outcome
                    .camera
                    .as_ref()
                    .map_or(0, |c| c.slam().map_points().len())
            },
            |e| e.landmarks_in_map().len(),
        ),
        camera: outcome.camera.as_ref().map(|pipeline| {
            let status = outcome.state.camera.as_ref().map(|c| &c.status);
            let stats = pipeline.slam_stats();
            let truth = camera_truth.lock().unwrap_or_else(PoisonError::into_inner);
            DemoCameraReport {
                frames_due: frames_due(options),
                frames_captured: status.map_or(0, |s| s.frames_captured),
                frames_tracked: pipeline.poses().len(),
                frames_skipped: status.map_or(0, |s| s.frames_skipped),
                local_maps: stats.local_maps,
                places_recognised: stats.places_recognised,
                fixes_paired: pipeline.stats().fixes_paired,
                scale_from_gps: pipeline.alignment().map(|a| a.scale),
                map_points: pipeline.slam().map_points().len(),
                run_behind_wall_clock_max_s: behind_wall_clock_s(&truth),
                against_truth: Some(tracked_truth(pipeline, &truth, clock))
                    .filter(|records| records.len() == pipeline.poses().len())
                    .map(|records| CameraOutcome::new(pipeline, &records)),
            }
        }),
        outputs,
        simulation,
    })
}

/// What a run of the daemon on a generated world needs: the pty it reads the board on, its
/// configuration and the aerial image written for it.
pub(crate) struct DaemonSetup {
    /// The pty between the simulated board and the daemon.
    pub relay: PtyLink,
    /// The daemon's configuration: the board on the relay, EKF SLAM with GPS and the aerial
    /// image outdoors, the occupancy grid indoors, recording to `out/run.mcap`.
    pub config: DaemonConfig,
    /// The aerial image (outdoors).
    pub image: Option<PathBuf>,
}

impl DaemonSetup {
    /// Generates the world of `seed` for `duration_s`, writes its aerial image to `out`
    /// (outdoors), opens the relay and configures the daemon to serve its web view on
    /// `web` and its Foxglove stream on `foxglove`.
    ///
    /// # Errors
    /// The image cannot be written, no pty is free, or the daemon would refuse the
    /// configuration.
    pub(crate) fn prepare(
        world: WorldKind,
        seed: u64,
        duration_s: f64,
        out: &Path,
        web: SocketAddr,
        foxglove: Option<SocketAddr>,
    ) -> io::Result<Self> {
        let scenario = Scenario::generate_for(world, seed, duration_s + 1.0);
        let outdoor = world == WorldKind::Outdoor;
        let image = if outdoor {
            Some(write_aerial(&scenario, out)?)
        } else {
            None
        };
        let relay = PtyLink::open()?;
        let mut config = DaemonConfig::default();
        config.link.port = relay.board_path().display().to_string();
        config.slam.method = if outdoor {
            SlamMethod::Ekf
        } else {
            SlamMethod::Grid
        };
        config.slam.grid_max_range_m = 8.0;
        let recording = out.join("run.mcap");
        // An earlier run's recording in the same folder, and its further parts, make way.
        for old in std::iter::once(recording.clone()).chain(existing_parts(&recording)) {
            let _ = fs::remove_file(old);
        }
        config.record.path = Some(recording);
        config.georef.image.clone_from(&image);
        let datum = scenario.datum();
        config.georef.datum_lat_lon_deg = Some([datum.lat_deg, datum.lon_deg]);
        config.web.listen = web;
        config.web.foxglove_listen = foxglove;
        config.validate().map_err(io::Error::other)?;
        Ok(DaemonSetup {
            relay,
            config,
            image,
        })
    }
}

/// The camera frames a demo's simulation renders: one at 0 s and one a period after another
/// up to its duration (none without a camera).
fn frames_due(options: &DemoOptions) -> u64 {
    options.camera.map_or(0, |camera| {
        (options.duration_s * camera.rate_hz + 1e-9).floor() as u64 + 1
    })
}

/// The truth of the frames the camera method tracked, in its order: each frame's host time
/// is the time since `clock` the frame was taken.
fn tracked_truth(
    pipeline: &CameraPipeline,
    truth: &[(Instant, CameraRecord)],
    clock: Instant,
) -> Vec<CameraRecord> {
    let mut frames = truth.iter().peekable();
    pipeline
        .poses()
        .iter()
        .filter_map(|pose| {
            let same = |(at, _): &&(Instant, CameraRecord)| {
                at.checked_duration_since(clock)
                    .is_some_and(|d| (d.as_secs_f64() - pose.time_s).abs() < 1e-6)
            };
            // The frames skipped come between those tracked.
            while frames.next_if(|f| !same(f)).is_some() {}
            frames.next().map(|(_, record)| *record)
        })
        .collect()
}

/// How far the run's frames were taken behind their time on the wall clock, at most,
/// measured from the first frame, s.
fn behind_wall_clock_s(truth: &[(Instant, CameraRecord)]) -> f64 {
    let Some((first_at, first)) = truth.first() else {
        return 0.0;
    };
    truth
        .iter()
        .map(|(at, record)| {
            at.saturating_duration_since(*first_at).as_secs_f64() - (record.t_s - first.t_s)
        })
        .fold(0.0, f64::max)
}

/// Gives `config` the rendered camera of `camera`, held as it says, and the camera method.
fn set_camera(config: &mut DaemonConfig, camera: &CameraRunOptions) {
    config.slam.method = SlamMethod::Camera;
    config.camera.device = Some("hil-sim camera".into());
    config.camera.set_model(&camera.rig.camera);
    config.camera.tilt_sigma_deg = LevelPrior::tilt_deg(camera.level);
    config.camera.sideslip_sigma_deg = ForwardMotionPrior::sideslip_deg(camera.forward_motion);
    config.camera.fuse_gps = camera.fuse_gps;
}

/// Renders the world from above and writes it as a GeoTIFF in WGS84 latitude/longitude.
fn write_aerial(scenario: &Scenario, out: &Path) -> io::Result<PathBuf> {
    let aerial = render_aerial(scenario, AERIAL_PIXEL_M);
    let path = out.join("aerial.tif");
    write_geotiff_geographic_rgb8(
        &path,
        aerial.width,
        aerial.height,
        &aerial.rgb,
        &GeographicGeoref {
            upper_left_lon_lat_deg: aerial.upper_left_lon_lat_deg,
            pixel_size_deg: aerial.pixel_size_deg,
        },
    )
    .map_err(io::Error::other)?;
    Ok(path)
}
