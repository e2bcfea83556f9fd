//! `robot-host run`, `robot-host replay` and `robot-host config`: the daemon from the command
//! line, with every configuration field overridable by a flag.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use host::geoimage::GeoImage;
use robot_host::config::{DaemonConfig, SlamMethod};
use robot_host::outputs::write_outputs;
use robot_host::replay::replay;
use robot_host::runner::{Daemon, SerialPortOpener};

/// Where the configuration comes from and what overrides it.
#[derive(Debug, clap::Args)]
pub struct ConfigArgs {
    /// The TOML configuration file (see `robot-host config` for every field and its default).
    #[arg(long, short = 'c')]
    pub config: Option<PathBuf>,
    /// Serial port of the board [link.port].
    #[arg(long)]
    pub port: Option<String>,
    /// Baud rate of a UART link [link.baud].
    #[arg(long)]
    pub baud: Option<u32>,
    /// After an unplug, try to reopen the port this often, milliseconds
    /// [link.reopen_interval_ms].
    #[arg(long)]
    pub reopen_interval_ms: Option<u64>,
    /// Time-sync pings every this many seconds [link.ping_interval_s].
    #[arg(long)]
    pub ping_interval_s: Option<f64>,
    /// The laser's measuring mode, how its range words are coded [link.measuring_mode].
    #[arg(long)]
    pub measuring_mode: Option<u8>,
    /// Which SLAM pipelines run: ekf, grid, both, camera (needs --camera) or none
    /// [slam.method].
    #[arg(long)]
    pub slam: Option<SlamMethod>,
    /// The laser's pose on the robot, X_M,Y_M,THETA_RAD [slam.laser_in_robot].
    #[arg(long, value_parser = parse_triple)]
    pub laser_in_robot: Option<[f64; 3]>,
    /// The GPS antenna's position on the robot, X_M,Y_M [slam.antenna_in_robot].
    #[arg(long, value_parser = parse_pair)]
    pub antenna_in_robot: Option<[f64; 2]>,
    /// The EKF uses returns up to this range, metres [slam.ekf_max_range_m].
    #[arg(long)]
    pub ekf_max_range_m: Option<f64>,
    /// A local map closes at this many landmarks [slam.ekf_landmarks_per_local_map].
    #[arg(long)]
    pub ekf_landmarks_per_local_map: Option<usize>,
    /// The grid pipeline uses returns up to this range, metres [slam.grid_max_range_m].
    #[arg(long)]
    pub grid_max_range_m: Option<f64>,
    /// The live occupancy grid is redrawn every this many scans
    /// [slam.grid_redraw_every_scans].
    #[arg(long)]
    pub grid_redraw_every_scans: Option<u32>,
    /// Cell size of the occupancy grid, metres [slam.grid_resolution_m].
    #[arg(long)]
    pub grid_resolution_m: Option<f64>,
    /// Address of the web view [web.listen]; 127.0.0.1 unless told otherwise.
    #[arg(long)]
    pub serve: Option<SocketAddr>,
    /// Do not serve the web view [web.enabled = false].
    #[arg(long)]
    pub no_web: bool,
    /// Address of the live Foxglove WebSocket server [web.foxglove_listen].
    #[arg(long)]
    pub foxglove: Option<SocketAddr>,
    /// Do not serve the live Foxglove stream [web.foxglove_listen absent].
    #[arg(long)]
    pub no_foxglove: bool,
    /// Record every frame to this MCAP file, going on in FILE_1.mcap, FILE_2.mcap, … every
    /// --part-length-s; refused when the file or such a part already exists [record.path].
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Flush the recording every this many seconds [record.flush_interval_s].
    #[arg(long)]
    pub flush_interval_s: Option<f64>,
    /// Go on in the recording's next file (run_1.mcap, run_2.mcap, …) after this many
    /// seconds [record.part_length_s].
    #[arg(long)]
    pub part_length_s: Option<f64>,
    /// Geo-referenced image under the map (GeoTIFF, or PNG/JPEG with a world file)
    /// [georef.image].
    #[arg(long)]
    pub image: Option<PathBuf>,
    /// Origin of the local metric frame, LAT_DEG,LON_DEG [georef.datum_lat_lon_deg].
    #[arg(long, value_parser = parse_pair)]
    pub datum: Option<[f64; 2]>,
    /// Goals farther than this from the map are refused, metres [georef.goal_margin_m].
    #[arg(long)]
    pub goal_margin_m: Option<f64>,
    /// A V4L2 camera, e.g. /dev/video0: shown and recorded, and tracked with --slam camera
    /// [camera.device].
    #[arg(long)]
    pub camera: Option<String>,
    /// Frame size asked of the camera, WIDTH_PX,HEIGHT_PX [camera.width_px, camera.height_px].
    #[arg(long, value_parser = parse_size)]
    pub camera_size: Option<[u32; 2]>,
    /// Frames per second asked of the camera [camera.rate_hz].
    #[arg(long)]
    pub camera_rate_hz: Option<f64>,
    /// The camera's calibration at that size, FX,FY,CX,CY in pixels [camera.intrinsics_px].
    #[arg(long, value_parser = parse_numbers::<4>)]
    pub camera_intrinsics: Option<[f64; 4]>,
    /// The lens distortion, K1,K2,P1,P2,K3 (OpenCV's model) [camera.distortion].
    #[arg(long, value_parser = parse_numbers::<5>)]
    pub camera_distortion: Option<[f64; 5]>,
    /// JPEG quality (1-100) of uncompressed frames as recorded and shown
    /// [camera.jpeg_quality].
    #[arg(long)]
    pub camera_jpeg_quality: Option<u8>,
}

impl ConfigArgs {
    /// The configuration file (or the defaults) with the flags applied, checked.
    pub fn resolve(&self) -> Result<DaemonConfig, String> {
        let mut c = match &self.config {
            Some(path) => DaemonConfig::load(path).map_err(|e| e.to_string())?,
            None => DaemonConfig::default(),
        };
        if let Some(v) = &self.port {
            c.link.port.clone_from(v);
        }
        if let Some(v) = self.baud {
            c.link.baud = v;
        }
        if let Some(v) = self.reopen_interval_ms {
            c.link.reopen_interval_ms = v;
        }
        if let Some(v) = self.ping_interval_s {
            c.link.ping_interval_s = v;
        }
        if let Some(v) = self.measuring_mode {
            c.link.measuring_mode = v;
        }
        if let Some(v) = self.ekf_landmarks_per_local_map {
            c.slam.ekf_landmarks_per_local_map = v;
        }
        if let Some(v) = self.grid_max_range_m {
            c.slam.grid_max_range_m = v;
        }
        if let Some(v) = self.grid_redraw_every_scans {
            c.slam.grid_redraw_every_scans = v;
        }
        if let Some(v) = self.slam {
            c.slam.method = v;
        }
        if let Some(v) = self.laser_in_robot {
            c.slam.laser_in_robot = v;
        }
        if let Some(v) = self.antenna_in_robot {
            c.slam.antenna_in_robot = v;
        }
        if let Some(v) = self.ekf_max_range_m {
            c.slam.ekf_max_range_m = v;
        }
        if let Some(v) = self.grid_resolution_m {
            c.slam.grid_resolution_m = v;
        }
        if let Some(v) = self.serve {
            c.web.listen = v;
        }
        if self.no_web {
            c.web.enabled = false;
        }
        if let Some(v) = self.foxglove {
            c.web.foxglove_listen = Some(v);
        }
        if self.no_foxglove {
            c.web.foxglove_listen = None;
        }
        if let Some(v) = &self.record {
            c.record.path = Some(v.clone());
        }
        if let Some(v) = self.flush_interval_s {
            c.record.flush_interval_s = v;
        }
        if let Some(v) = self.part_length_s {
            c.record.part_length_s = v;
        }
        if let Some(v) = &self.image {
            c.georef.image = Some(v.clone());
        }
        if let Some(v) = self.datum {
            c.georef.datum_lat_lon_deg = Some(v);
        }
        if let Some(v) = self.goal_margin_m {
            c.georef.goal_margin_m = v;
        }
        if let Some(v) = &self.camera {
            c.camera.device = Some(v.clone());
        }
        if let Some([width_px, height_px]) = self.camera_size {
            c.camera.width_px = width_px;
            c.camera.height_px = height_px;
        }
        if let Some(v) = self.camera_rate_hz {
            c.camera.rate_hz = v;
        }
        if let Some(v) = self.camera_intrinsics {
            c.camera.intrinsics_px = v;
        }
        if let Some(v) = self.camera_distortion {
            c.camera.distortion = v;
        }
        if let Some(v) = self.camera_jpeg_quality {
            c.camera.jpeg_quality = v;
        }
        c.validate().map_err(|e| e.to_string())?;
        Ok(c)
    }
}

fn parse_numbers<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let values: Vec<f64> = s
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{s:?}: {e}"))?;
    values
        .try_into()
        .map_err(|_| format!("expected {N} comma-separated numbers, got {s:?}"))
}

fn parse_size(s: &str) -> Result<[u32; 2], String> {
    let values: Vec<u32> = s
        .split(',')
        .map(|v| v.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{s:?}: {e}"))?;
    values
        .try_into()
        .map_err(|_| format!("expected WIDTH_PX,HEIGHT_PX, got {s:?}"))
}

fn parse_pair(s: &str) -> Result<[f64; 2], String> {
    parse_numbers::<2>(s)
}

fn parse_triple(s: &str) -> Result<[f64; 3], String> {
    parse_numbers::<3>(s)
}

/// `robot-host run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    config: ConfigArgs,
    /// Stop after this many seconds (run until Ctrl-C otherwise).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Write the trajectory, maps, GeoJSON/KML and a summary here when stopping.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `robot-host replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The MCAP recording made by `robot-host run --record` (its first file: the parts
    /// after it, run_1.mcap, run_2.mcap, …, are read in turn).
    file: PathBuf,
    #[command(flatten)]
    config: ConfigArgs,
    /// Write the trajectory, maps, GeoJSON/KML and a summary here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// Runs the daemon until Ctrl-C or the duration.
pub fn run(args: &RunArgs) -> Result<(), String> {
    let config = args.config.resolve()?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed))
            .map_err(|e| format!("cannot catch Ctrl-C: {e}"))?;
    }
    let opener = SerialPortOpener {
        path: config.link.port.clone(),
        baud: config.link.baud,
    };
    let daemon = Daemon::start(&config, Box::new(opener)).map_err(|e| e.to_string())?;
    if let Some(addr) = daemon.web_addr() {
        println!("web view: http://{addr}/");
        if let Some(token) = daemon.web_token() {
            println!("web view token (the page asks for it once): {token}");
        }
    }
    if let Some(addr) = daemon.foxglove_addr() {
        println!("foxglove: ws://{addr}");
    }
    let started = Instant::now();
    // A status line on a terminal (hidden when stderr is not one).
    let status = indicatif::ProgressBar::new_spinner();
    status.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    let state = daemon.state();
    while !stop.load(Ordering::Relaxed)
        && args
            .duration_s
            .is_none_or(|d| started.elapsed().as_secs_f64() < d)
    {
        if let Ok(s) = state.read() {
            let c = s.counters;
            status.set_message(format!(
                "scans {} · fixes {} (quality {}) · frames lost {} · CRC errors {} · reconnects {}",
                c.telegrams,
                c.gps_fixes,
                c.gps_fix_quality,
                c.frames_lost,
                c.crc_errors,
                c.reconnects
            ));
        }
        status.tick();
        std::thread::sleep(Duration::from_millis(100));
    }
    status.finish_and_clear();
    let outcome = daemon.stop().map_err(|e| e.to_string())?;
    if let Some(out) = &args.out {
        let image = open_image(&config)?;
        let written = write_outputs(out, &outcome, image.as_ref()).map_err(|e| e.to_string())?;
        tracing::info!(files = written.files.len(), dir = %out.display(), "outputs written");
    }
    println!(
        "{}",
        serde_json::to_string(&outcome.state.counters).unwrap_or_default()
    );
    Ok(())
}

/// Replays a recording and writes its outputs.
pub fn replay_file(args: &ReplayArgs) -> Result<(), String> {
    let config = args.config.resolve()?;
    let image = open_image(&config)?;
    let (outcome, truncated) = replay(&args.file, &config, image.as_ref(), !args.quiet)
        .map_err(|e| format!("{}: {e}", args.file.display()))?;
    if truncated {
        tracing::warn!(file = %args.file.display(), "the recording was cut short; replayed up to its last complete chunk");
    }
    if let Some(out) = &args.out {
        write_outputs(out, &outcome, image.as_ref()).map_err(|e| e.to_string())?;
    }
    let pose = outcome.state.pose;
    println!(
        "{}",
        serde_json::json!({
            "truncated": truncated,
            "counters": outcome.state.counters,
            "scans": outcome.ekf.as_ref().map(|e| e.scans_placed())
                .or(outcome.grid.as_ref().map(|g| g.trajectory().len())),
            "final_pose": {"x_m": pose.x_m, "y_m": pose.y_m, "theta_rad": pose.theta_rad},
        })
    );
    Ok(())
}

fn open_image(config: &DaemonConfig) -> Result<Option<GeoImage>, String> {
    config
        .georef
        .image
        .as_ref()
        .map(|p| GeoImage::open(p).map_err(|e| format!("{}: {e}", p.display())))
        .transpose()
}
