//! The running daemon: the reader thread on the serial port, one thread per SLAM pipeline,
//! the recorder thread, the web view, the live Foxglove stream and, on glibc, a thread that
//! hands the heaps' free pages back every second ([`memory_policy`]).
//!
//! ```text
//! port ──▶ reader ──events──▶ ekf thread  ──▶ LiveState ◀── web view, goal API
//!             │    ──events──▶ grid thread ──▶ LiveState ◀── Foxglove publisher
//!             └──bytes, messages, pings──▶ recorder ──▶ MCAP
//! ```
//!
//! The reader never waits for the pipelines or the disk: it hands each event over an
//! unbounded channel and goes back to the port. The pipelines see every event in the order it
//! was read, so their estimates do not depend on thread timing, and a replay of the recording
//! through the same [`LinkSession`] and pipelines gives the same results.

use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, RwLock};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use protocol::{MeasuringMode, Received};

use crate::camera_capture::FrameSource;
use crate::camera_runner::{CameraInputs, CameraThreads};
use crate::config::{DaemonConfig, SlamMethod};
use crate::foxglove_live::start_live_server;
use crate::memory_policy::{self, FreeMemoryReturner};
use crate::publish::{grid_view, publish_ekf, publish_grid, publish_grid_pose};
use crate::state::{LiveState, SharedState};
use host::camera::{CameraPipeline, CameraPipelineOptions};
use host::ekf_slam::EkfPipeline;
use host::geoimage::GeoImage;
use host::georef::GeoReferencer;
use host::link::{LinkSession, SensorEvent};
use host::recording::{Recorder, RecorderOptions, RecordingError, RecordingSummary};
use host::scan_match::ScanMatchError;
use host::slam::GridPipeline;

/// How long a read on the port waits before the reader checks for shutdown and pings.
const READ_TIMEOUT: Duration = Duration::from_millis(50);
/// The EKF thread refreshes the shown pose, trajectory and map at most this often, and shows
/// a change at most this long after it.
const EKF_PUBLISH_PERIOD: Duration = Duration::from_millis(200);
/// The Foxglove stream is refreshed this often.
const LIVE_PUBLISH_PERIOD: Duration = Duration::from_millis(200);

/// Opens the board's port, again after it went away.
pub trait PortOpener: Send {
    /// Opens the port.
    ///
    /// # Errors
    /// The port does not exist (yet) or cannot be opened.
    fn open(&mut self) -> io::Result<Box<dyn serialport::SerialPort>>;

    /// The port's name, for messages.
    fn name(&self) -> String;
}

/// A serial port by path: a USB CDC-ACM device, a UART adapter, a pty.
#[derive(Debug, Clone)]
pub struct SerialPortOpener {
    /// The device path.
    pub path: String,
    /// The baud rate (ignored by USB CDC-ACM and ptys).
    pub baud: u32,
}

impl PortOpener for SerialPortOpener {
    fn open(&mut self) -> io::Result<Box<dyn serialport::SerialPort>> {
        serialport::new(&self.path, self.baud)
            .timeout(READ_TIMEOUT)
            .open()
            .map_err(|e| io::Error::other(format!("cannot open {}: {e}", self.path)))
    }

    fn name(&self) -> String {
        self.path.clone()
    }
}

/// Why the daemon cannot start or finish.
#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    /// The port cannot be opened at start.
    #[error("{0}")]
    Port(io::Error),
    /// The recording cannot be created or written.
    #[error("recording: {0}")]
    Recording(#[from] RecordingError),
    /// The geo-referenced image cannot be read.
    #[error("image {path}: {message}")]
    Image {
        /// The image.
        path: String,
        /// Why.
        message: String,
    },
    /// The web view or the Foxglove server cannot bind.
    #[error("{0}")]
    Serve(String),
    /// The SLAM configuration cannot be used.
    #[error("invalid SLAM configuration: {0}")]
    Slam(#[from] ScanMatchError),
    /// A thread of the daemon panicked.
    #[error("the {0} thread stopped unexpectedly")]
    Thread(&'static str),
    /// The camera cannot be used.
    #[error("{0}")]
    Camera(String),
}

/// Where the reader hands the sensor events: every event to the laser pipelines, the fixes
/// alone to the camera method.
#[derive(Default)]
struct EventOutlets {
    all: Vec<Sender<SensorEvent>>,
    fixes_only: Vec<Sender<SensorEvent>>,
}

/// Sets the daemon's shutdown flag when dropped while armed: the threads already started
/// stop when a later part of [`Daemon::start`] fails.
struct StopOnFailure(Arc<AtomicBool>, bool);

impl Drop for StopOnFailure {
    fn drop(&mut self) {
        if self.1 {
            self.0.store(true, Ordering::Relaxed);
        }
    }
}

/// What the recorder thread is given.
pub(crate) enum RecordItem {
    Bytes(f64, Vec<u8>),
    Sent(f64, Vec<u8>),
    Reconnect(f64),
    Message(f64, Option<f64>, Box<Received>),
    /// A camera frame as JPEG.
    Image(f64, Arc<Vec<u8>>),
}

/// What a finished run leaves: the pipelines with their estimates and the link's accounting.
#[derive(Debug)]
pub struct RunOutcome {
    /// The EKF pipeline, when it ran.
    pub ekf: Option<EkfPipeline>,
    /// The grid pipeline, when it ran.
    pub grid: Option<GridPipeline>,
    /// The grid method's geo-referencing, when the grid pipeline ran without the EKF.
    pub grid_georef: Option<GeoReferencer>,
    /// The camera method, when it ran.
    pub camera: Option<CameraPipeline>,
    /// The live state at the end.
    pub state: LiveState,
    /// The recording's totals, when recording.
    pub recording: Option<RecordingSummary>,
}

/// A running daemon. See the [module documentation](self).
pub struct Daemon {
    state: SharedState,
    shutdown: Arc<AtomicBool>,
    reader: JoinHandle<()>,
    ekf: Option<JoinHandle<EkfPipeline>>,
    grid: Option<JoinHandle<(GridPipeline, Option<GeoReferencer>)>>,
    recorder: Option<JoinHandle<Result<RecordingSummary, RecordingError>>>,
    camera: Option<CameraThreads>,
    live: Option<(JoinHandle<()>, std::net::SocketAddr)>,
    memory: Option<JoinHandle<()>>,
    web: Option<crate::web::WebServer>,
    web_token: Option<String>,
    clock: Instant,
}

impl Daemon {
    /// Starts every thread: opens the port (waiting for it if it is not there yet), the
    /// camera, the recording, the web view and the Foxglove server as configured.
    ///
    /// # Errors
    /// The recording or the image cannot be opened, a server cannot bind, a camera is
    /// configured in a build without V4L2.
    pub fn start(
        config: &DaemonConfig,
        opener: Box<dyn PortOpener>,
    ) -> Result<Daemon, DaemonError> {
        let camera = configured_camera(config)?;
        Daemon::start_with_camera(config, opener, camera)
    }

    /// [`Daemon::start`] with frames from `camera` (a recorded sequence, say) instead of the
    /// configured device; `None`: no camera.
    ///
    /// # Errors
    /// As [`Daemon::start`]; also `slam.method = "camera"` without a camera.
    pub fn start_with_camera(
        config: &DaemonConfig,
        opener: Box<dyn PortOpener>,
        camera: Option<Box<dyn FrameSource>>,
    ) -> Result<Daemon, DaemonError> {
        if config.slam.method == SlamMethod::Camera && camera.is_none() {
            return Err(DaemonError::Camera(
                "slam.method = \"camera\" needs a camera: set [camera] device".into(),
            ));
        }
        // Frames and the link's messages are stamped on this one clock.
        let clock = Instant::now();
        let state = LiveState::shared();
        let shutdown = Arc::new(AtomicBool::new(false));
        let mut stop_on_failure = StopOnFailure(shutdown.clone(), true);
        let image = load_image(config)?;
        if let (Some(image), Ok(mut s)) = (&image, state.write()) {
            s.image = Some(crate::state::ImageView {
                width: image.width(),
                height: image.height(),
                crs: image
                    .crs()
                    .map_or_else(|| "none".into(), |c| c.name.clone()),
            });
        }

        let recorder = match &config.record.path {
            Some(path) => Some(Recorder::create(
                path,
                RecorderOptions {
                    flush_interval_s: config.record.flush_interval_s,
                    part_length_s: Some(config.record.part_length_s),
                    ..RecorderOptions::default()
                },
            )?),
            None => None,
        };
        let (record_tx, recorder) = match recorder {
            Some(recorder) => {
                let (tx, rx) = mpsc::channel();
                let flush = Duration::from_secs_f64(config.record.flush_interval_s);
                let handle = thread::Builder::new()
                    .name("recorder".into())
                    .spawn(move || record(recorder, &rx, flush))
                    .map_err(|e| DaemonError::Serve(e.to_string()))?;
                (Some(tx), Some(handle))
            }
            None => (None, None),
        };

        let mut event_txs = EventOutlets::default();
        let ekf = if config.slam.method.runs_ekf() {
            let (tx, rx) = mpsc::channel();
            event_txs.all.push(tx);
            let mut options = config
                .slam
                .ekf_pipeline_options(config.georef.datum_lat_lon_deg);
            // The trajectory's older poses go beside the recording, on its disk, rather than
            // to a temporary folder that may be in memory.
            options.trajectory.folder =
                config
                    .record
                    .path
                    .as_deref()
                    .map(|path| match path.parent() {
                        Some(folder) if !folder.as_os_str().is_empty() => folder.to_path_buf(),
                        _ => std::path::PathBuf::from("."),
                    });
            let pipeline = EkfPipeline::new(&options);
            let state = state.clone();
            let image = image.clone();
            Some(spawn("ekf", move || {
                run_ekf(pipeline, &rx, &state, image.as_deref())
            })?)
        } else {
            None
        };
        let grid = if config.slam.method.runs_grid() {
            let (tx, rx) = mpsc::channel();
            event_txs.all.push(tx);
            let pipeline = GridPipeline::new(config.slam.grid_pipeline_options())?;
            let state = state.clone();
            let owns_pose = !config.slam.method.runs_ekf();
            // With the EKF running, its own GPS alignment geo-references the view.
            let georef =
                owns_pose.then(|| config.slam.geo_referencer(config.georef.datum_lat_lon_deg));
            let every = config.slam.grid_redraw_every_scans;
            let image = image.clone();
            Some(spawn("grid", move || {
                run_grid(pipeline, georef, &rx, &state, image.as_deref(), every)
            })?)
        } else {
            None
        };

        let camera = match camera {
            Some(source) => {
                let method = if config.slam.method == SlamMethod::Camera {
                    let (tx, rx) = mpsc::channel();
                    event_txs.all.push(tx);
                    Some((camera_pipeline(config)?, rx))
                } else {
                    None
                };
                let inputs = CameraInputs {
                    source,
                    method,
                    clock,
                    jpeg_quality: config.camera.jpeg_quality,
                    record_tx: record_tx.clone(),
                    image: image.clone(),
                };
                Some(
                    CameraThreads::start(inputs, &state, &shutdown)
                        .map_err(|e| DaemonError::Serve(format!("cannot start the camera: {e}")))?,
                )
            }
            None => None,
        };

        let reader = {
            let state = state.clone();
            let shutdown = shutdown.clone();
            let link = config.link.clone();
            spawn("reader", move || {
                read_port(
                    opener,
                    (&link, clock),
                    &state,
                    &shutdown,
                    &event_txs,
                    record_tx.as_ref(),
                );
            })?
        };

        let live = match config.web.foxglove_listen {
            Some(addr) => {
                let server = start_live_server(addr, "robot-host")
                    .map_err(|e| DaemonError::Serve(format!("Foxglove server on {addr}: {e}")))?;
                let bound = server.local_addr();
                let state = state.clone();
                let shutdown = shutdown.clone();
                let handle = spawn("foxglove", move || {
                    while !shutdown.load(Ordering::Relaxed) {
                        if let Ok(s) = state.read() {
                            server.publish_state(&s);
                        }
                        thread::sleep(LIVE_PUBLISH_PERIOD);
                    }
                    server.stop();
                })?;
                Some((handle, bound))
            }
            None => None,
        };

        // Off the reader's path, whose receive times the clock sync uses.
        let memory = if memory_policy::RETURNS_FREE_MEMORY {
            let shutdown = shutdown.clone();
            Some(spawn("memory", move || {
                let mut returner = FreeMemoryReturner::default();
                while !shutdown.load(Ordering::Relaxed) {
                    returner.tick();
                    thread::sleep(READ_TIMEOUT);
                }
            })?)
        } else {
            None
        };

        let mut web_token = None;
        let web = if config.web.enabled {
            let access = access_policy(&config.web)?;
            web_token.clone_from(&access.token);
            let resolver = crate::goal::MapGoalResolver::new(
                state.clone(),
                image.clone(),
                config.georef.goal_margin_m,
            );
            let image_png = match &image {
                Some(image) => {
                    Some(Arc::new(image.to_png().map_err(|e| {
                        DaemonError::Serve(format!("cannot show the image: {e}"))
                    })?))
                }
                None => None,
            };
            Some(
                crate::web::WebServer::start(
                    config.web.listen,
                    crate::web::WebContext {
                        state: state.clone(),
                        goal: Arc::new(resolver),
                        image_png,
                        access,
                        limits: crate::web::WebLimits {
                            max_connections: config.web.max_connections,
                            ..crate::web::WebLimits::default()
                        },
                    },
                )
                .map_err(|e| {
                    DaemonError::Serve(format!("web view on {}: {e}", config.web.listen))
                })?,
            )
        } else {
            None
        };

        stop_on_failure.1 = false;
        Ok(Daemon {
            state,
            shutdown,
            reader,
            ekf,
            grid,
            recorder,
            camera,
            live,
            memory,
            web,
            web_token,
            clock,
        })
    }

    /// The origin of the daemon's host times: every time it stamps (frames, fixes, scans,
    /// the recording's log times) is in seconds since this instant.
    pub fn clock(&self) -> Instant {
        self.clock
    }

    /// The token the web view asks of state-changing requests, when it asks one.
    pub fn web_token(&self) -> Option<&str> {
        self.web_token.as_deref()
    }

    /// The live state.
    pub fn state(&self) -> SharedState {
        self.state.clone()
    }

    /// Where the web view listens, when it runs.
    pub fn web_addr(&self) -> Option<std::net::SocketAddr> {
        self.web.as_ref().map(crate::web::WebServer::local_addr)
    }

    /// Where the Foxglove server listens, when it runs.
    pub fn foxglove_addr(&self) -> Option<std::net::SocketAddr> {
        self.live.as_ref().map(|(_, addr)| *addr)
    }

    /// Stops reading, lets the pipelines finish what was read, closes the recording and the
    /// servers.
    ///
    /// # Errors
    /// The recording cannot be finished, or a thread panicked.
    pub fn stop(self) -> Result<RunOutcome, DaemonError> {
        self.shutdown.store(true, Ordering::Relaxed);
        self.reader
            .join()
            .map_err(|_| DaemonError::Thread("reader"))?;
        let ekf = self
            .ekf
            .map(|h| h.join().map_err(|_| DaemonError::Thread("ekf")))
            .transpose()?;
        let (grid, grid_georef) = match self.grid {
            Some(handle) => {
                let (grid, georef) = handle.join().map_err(|_| DaemonError::Thread("grid"))?;
                (Some(grid), georef)
            }
            None => (None, None),
        };
        let camera = match self.camera {
            Some(threads) => threads.join().map_err(DaemonError::Thread)?,
            None => None,
        };
        let recording = self
            .recorder
            .map(|h| h.join().map_err(|_| DaemonError::Thread("recorder")))
            .transpose()?
            .transpose()?;
        if let Some((handle, _)) = self.live {
            let _ = handle.join();
        }
        if let Some(handle) = self.memory {
            let _ = handle.join();
        }
        if let Some(web) = self.web {
            web.stop();
        }
        let state = self.state.read().map(|s| s.clone()).unwrap_or_default();
        Ok(RunOutcome {
            ekf,
            grid,
            grid_georef,
            camera,
            state,
            recording,
        })
    }
}

fn spawn<T: Send + 'static>(
    name: &'static str,
    f: impl FnOnce() -> T + Send + 'static,
) -> Result<JoinHandle<T>, DaemonError> {
    thread::Builder::new()
        .name(name.into())
        .spawn(f)
        .map_err(|e| DaemonError::Serve(format!("cannot start the {name} thread: {e}")))
}

/// The web view's access rule: the configured token; beyond loopback without one, a new one.
fn access_policy(web: &crate::config::WebConfig) -> Result<crate::web::AccessPolicy, DaemonError> {
    let token = match &web.token {
        Some(token) => Some(token.clone()),
        None if !web.listen.ip().is_loopback() => {
            let token = crate::web::generate_token()
                .map_err(|e| DaemonError::Serve(format!("cannot make a web view token: {e}")))?;
            tracing::warn!(
                listen = %web.listen,
                "the web view is open beyond this machine: setting the goal needs the token \
                 printed below (or set [web] token)"
            );
            Some(token)
        }
        None => None,
    };
    Ok(crate::web::AccessPolicy {
        token,
        open_read_only: web.open_read_only,
    })
}

/// The camera the configuration names, opened on its first frame.
#[cfg(feature = "v4l2")]
fn configured_camera(config: &DaemonConfig) -> Result<Option<Box<dyn FrameSource>>, DaemonError> {
    Ok(config.camera.device.as_ref().map(|device| {
        Box::new(crate::camera_v4l2::V4l2Camera::new(
            crate::camera_v4l2::V4l2Request {
                device: device.clone(),
                width_px: config.camera.width_px,
                height_px: config.camera.height_px,
                rate_hz: config.camera.rate_hz,
            },
        )) as Box<dyn FrameSource>
    }))
}

/// The camera the configuration names: refused, this build having no V4L2.
#[cfg(not(feature = "v4l2"))]
fn configured_camera(config: &DaemonConfig) -> Result<Option<Box<dyn FrameSource>>, DaemonError> {
    match &config.camera.device {
        Some(device) => Err(DaemonError::Camera(format!(
            "camera {device}: this robot-host was built without the v4l2 feature"
        ))),
        None => Ok(None),
    }
}

/// The camera method of the configuration.
pub(crate) fn camera_pipeline(config: &DaemonConfig) -> Result<CameraPipeline, DaemonError> {
    let defaults = CameraPipelineOptions::default();
    CameraPipeline::new(
        config.camera.pinhole(),
        CameraPipelineOptions {
            datum_lat_lon_deg: config.georef.datum_lat_lon_deg,
            fuse_gps: config.camera.fuse_gps,
            slam: host::camera::MonoSlamOptions {
                level: config.camera.level_prior(),
                forward_motion: config.camera.forward_motion_prior(),
                ..defaults.slam
            },
            ..defaults
        },
    )
    .map_err(|e| DaemonError::Camera(format!("camera method: {e}")))
}

fn load_image(config: &DaemonConfig) -> Result<Option<Arc<GeoImage>>, DaemonError> {
    config
        .georef
        .image
        .as_ref()
        .map(|path| {
            GeoImage::open(path)
                .map(Arc::new)
                .map_err(|e| DaemonError::Image {
                    path: path.display().to_string(),
                    message: e.to_string(),
                })
        })
        .transpose()
}

/// The reader thread: port → session → pipelines and recorder; pings; reopens after an
/// unplug, keeping the session (counters, clock, partial state) across.
fn read_port(
    mut opener: Box<dyn PortOpener>,
    (link, clock): (&crate::config::LinkConfig, Instant),
    state: &SharedState,
    shutdown: &AtomicBool,
    event_txs: &EventOutlets,
    record_tx: Option<&Sender<RecordItem>>,
) {
    let now_s = || clock.elapsed().as_secs_f64();
    let mut session = LinkSession::new(MeasuringMode(link.measuring_mode));
    let mut port: Option<Box<dyn serialport::SerialPort>> = None;
    let mut next_open = Instant::now();
    let mut next_ping_s = 0.0;
    let mut buf = vec![0u8; 8192];
    let mut opened_before = false;
    while !shutdown.load(Ordering::Relaxed) {
        let Some(p) = port.as_mut() else {
            if Instant::now() >= next_open {
                match opener.open() {
                    Ok(p) => {
                        tracing::info!(port = %opener.name(), "port open");
                        if opened_before {
                            session.reconnected();
                            if let Some(tx) = record_tx {
                                let _ = tx.send(RecordItem::Reconnect(now_s()));
                            }
                        }
                        opened_before = true;
                        port = Some(p);
                    }
                    Err(e) => {
                        tracing::debug!(error = %e, "port not available");
                        next_open = Instant::now() + Duration::from_millis(link.reopen_interval_ms);
                    }
                }
            } else {
                thread::sleep(Duration::from_millis(10));
            }
            continue;
        };
        if now_s() >= next_ping_s {
            next_ping_s = now_s() + link.ping_interval_s;
            let sent_s = now_s();
            let frame = session.ping(sent_s);
            if p.write_all(&frame).is_ok()
                && let Some(tx) = record_tx
            {
                let _ = tx.send(RecordItem::Sent(sent_s, frame));
            }
        }
        match p.read(&mut buf) {
            Ok(0) => {}
            Ok(n) => {
                let recv_s = now_s();
                if let Some(tx) = record_tx {
                    let _ = tx.send(RecordItem::Bytes(recv_s, buf[..n].to_vec()));
                }
                let decoded = session.feed(&buf[..n], recv_s);
                if let Some(tx) = record_tx {
                    for (received, host_s) in decoded.messages {
                        let _ = tx.send(RecordItem::Message(recv_s, host_s, Box::new(received)));
                    }
                }
                for event in decoded.events {
                    let is_fix = matches!(event, SensorEvent::Fix { .. });
                    let outlets = event_txs
                        .all
                        .iter()
                        .chain(event_txs.fixes_only.iter().filter(|_| is_fix));
                    for tx in outlets {
                        let _ = tx.send(event.clone());
                    }
                }
                if let Ok(mut s) = state.write() {
                    s.counters = session.counters();
                }
            }
            Err(e) if e.kind() == io::ErrorKind::TimedOut => {}
            Err(e) => {
                tracing::warn!(port = %opener.name(), error = %e, "port lost; reopening");
                port = None;
                next_open = Instant::now() + Duration::from_millis(link.reopen_interval_ms);
                if let Ok(mut s) = state.write() {
                    s.counters = session.counters();
                }
            }
        }
    }
}

fn run_ekf(
    mut pipeline: EkfPipeline,
    rx: &Receiver<SensorEvent>,
    state: &RwLock<LiveState>,
    image: Option<&GeoImage>,
) -> EkfPipeline {
    // On wall time, not per event: a replay faster than real time shows no more than a robot.
    let mut last_publish = Instant::now();
    let mut changed = false;
    loop {
        // Unchanged, wait for the next event; changed, only until the change is due.
        let next = if changed {
            let due = (last_publish + EKF_PUBLISH_PERIOD).saturating_duration_since(Instant::now());
            rx.recv_timeout(due)
        } else {
            rx.recv().map_err(|_| RecvTimeoutError::Disconnected)
        };
        match next {
            Ok(event) => {
                pipeline.on_event(&event);
                changed = true;
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if changed && last_publish.elapsed() >= EKF_PUBLISH_PERIOD {
            if let Ok(mut s) = state.write() {
                publish_ekf(&mut s, &pipeline, image);
            }
            last_publish = Instant::now();
            changed = false;
        }
    }
    pipeline.finish();
    if let Ok(mut s) = state.write() {
        publish_ekf(&mut s, &pipeline, image);
    }
    pipeline
}

fn run_grid(
    mut pipeline: GridPipeline,
    mut georef: Option<GeoReferencer>,
    rx: &Receiver<SensorEvent>,
    state: &RwLock<LiveState>,
    image: Option<&GeoImage>,
    redraw_every_scans: u32,
) -> (GridPipeline, Option<GeoReferencer>) {
    let owns_pose = georef.is_some();
    let mut scans = 0u32;
    for event in rx {
        on_grid_event(&mut pipeline, georef.as_mut(), &event);
        if !matches!(event, SensorEvent::Scan { .. }) {
            continue;
        }
        scans += 1;
        if scans.is_multiple_of(redraw_every_scans) {
            let view = grid_view(&pipeline);
            if let Some(georef) = georef.as_mut() {
                georef.align(&pipeline.trajectory());
            }
            if let Ok(mut s) = state.write() {
                s.grid = Some(view);
            }
        }
        if owns_pose && let Ok(mut s) = state.write() {
            publish_grid_pose(&mut s, &pipeline, georef.as_ref(), image);
        }
    }
    pipeline.finish();
    if let Some(georef) = georef.as_mut() {
        georef.align(&pipeline.trajectory());
    }
    if let Ok(mut s) = state.write() {
        publish_grid(&mut s, &pipeline, owns_pose, georef.as_ref(), image);
    }
    (pipeline, georef)
}

/// One sensor event into the grid pipeline, and its fixes into the geo-referencing: the live
/// run and the replay of its recording go through here alike.
pub(crate) fn on_grid_event(
    pipeline: &mut GridPipeline,
    georef: Option<&mut GeoReferencer>,
    event: &SensorEvent,
) {
    pipeline.on_event(event);
    if let (
        Some(georef),
        SensorEvent::Fix {
            host_time_s, fix, ..
        },
    ) = (georef, event)
    {
        // A fix that cannot be placed in the `enu` frame is left out, as a fix without a
        // position is.
        let _ = georef.add_fix(*host_time_s, fix);
    }
}

/// The recorder thread: writes what the reader hands over, flushes on the interval.
fn record(
    mut recorder: Recorder,
    rx: &Receiver<RecordItem>,
    flush_every: Duration,
) -> Result<RecordingSummary, RecordingError> {
    let mut last_flush = Instant::now();
    loop {
        match rx.recv_timeout(flush_every) {
            Ok(RecordItem::Bytes(t, bytes)) => recorder.record_bytes(t, &bytes)?,
            Ok(RecordItem::Sent(t, bytes)) => recorder.record_sent(t, &bytes)?,
            Ok(RecordItem::Reconnect(t)) => recorder.record_reconnect(t)?,
            Ok(RecordItem::Message(t, host_s, received)) => {
                recorder.record_message(t, host_s, &received)?;
            }
            Ok(RecordItem::Image(t, jpeg)) => recorder.record_image(t, &jpeg)?,
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if last_flush.elapsed() >= flush_every {
            recorder.flush()?;
            last_flush = Instant::now();
        }
    }
    recorder.finish()
}
