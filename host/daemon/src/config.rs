//! The daemon's configuration: one TOML file whose every field has a default that works, and
//! which command-line flags override field by field.
//!
//! `host/daemon/config/robot-host.toml` is the documented default file; a test checks that it
//! parses to [`DaemonConfig::default`].

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use host::ekf_slam::{EkfPipelineOptions, PoseHistoryOptions};
use host::geometry::Pose2;
use host::georef::{GeoReferencer, GeoReferencerOptions};
use host::slam::{GridPipelineOptions, SlamOptions};
use serde::{Deserialize, Serialize};

/// Which SLAM pipelines run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum SlamMethod {
    /// EKF SLAM with local maps over trees and corners, geo-referenced by GPS (outdoors).
    #[default]
    Ekf,
    /// Raster scan matching with occupancy-grid submaps and loop closure (indoors).
    Grid,
    /// Both; the EKF owns the pose shown, the grid pipeline the occupancy grid.
    Both,
    /// The camera method (a single camera's EKF SLAM with local maps, geo-referenced by GPS)
    /// owns the pose and the map; a run needs `[camera] device`, a replay the recording's
    /// frames. The laser is read and recorded.
    Camera,
    /// None: read, record and show the link only.
    None,
}

impl SlamMethod {
    /// Whether the EKF pipeline runs.
    pub fn runs_ekf(self) -> bool {
        matches!(self, SlamMethod::Ekf | SlamMethod::Both)
    }

    /// Whether the grid pipeline runs.
    pub fn runs_grid(self) -> bool {
        matches!(self, SlamMethod::Grid | SlamMethod::Both)
    }
}

impl std::str::FromStr for SlamMethod {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "ekf" => Ok(SlamMethod::Ekf),
            "grid" => Ok(SlamMethod::Grid),
            "both" => Ok(SlamMethod::Both),
            "camera" => Ok(SlamMethod::Camera),
            "none" => Ok(SlamMethod::None),
            other => Err(format!(
                "unknown SLAM method {other:?}: expected ekf, grid, both, camera or none"
            )),
        }
    }
}

/// The serial link to the board.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LinkConfig {
    /// The board's serial port: `/dev/ttyACM0` (USB), a UART adapter, or a hil-sim pty.
    pub port: String,
    /// Baud rate of a UART link (USB CDC-ACM ignores it).
    pub baud: u32,
    /// How often to try to reopen the port after it went away, milliseconds.
    pub reopen_interval_ms: u64,
    /// Time-sync pings, one every this many seconds.
    pub ping_interval_s: f64,
    /// The laser's measuring mode (configuration byte 5), which says how range words are
    /// coded; the board configures the factory default 0.
    pub measuring_mode: u8,
}

impl Default for LinkConfig {
    fn default() -> Self {
        LinkConfig {
            port: "/dev/ttyACM0".into(),
            baud: 921_600,
            reopen_interval_ms: 500,
            ping_interval_s: 1.0,
            measuring_mode: 0,
        }
    }
}

/// The SLAM pipelines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlamConfig {
    /// Which pipelines run: `ekf`, `grid`, `both` or `none`.
    pub method: SlamMethod,
    /// The laser's pose on the robot, `[x_m, y_m, theta_rad]` (x forward, y left).
    pub laser_in_robot: [f64; 3],
    /// The GPS antenna's position on the robot, `[x_m, y_m]`.
    pub antenna_in_robot: [f64; 2],
    /// The EKF uses laser returns up to this range, metres.
    pub ekf_max_range_m: f64,
    /// A local map closes when it holds this many landmarks.
    pub ekf_landmarks_per_local_map: usize,
    /// The grid pipeline uses laser returns up to this range, metres.
    pub grid_max_range_m: f64,
    /// Cell size of the occupancy grid, metres.
    pub grid_resolution_m: f64,
    /// The occupancy grid shown live is redrawn every this many scans.
    pub grid_redraw_every_scans: u32,
}

impl Default for SlamConfig {
    fn default() -> Self {
        SlamConfig {
            method: SlamMethod::Ekf,
            laser_in_robot: [0.0; 3],
            antenna_in_robot: [0.0; 2],
            ekf_max_range_m: 40.0,
            ekf_landmarks_per_local_map: 30,
            grid_max_range_m: 30.0,
            grid_resolution_m: 0.05,
            grid_redraw_every_scans: 50,
        }
    }
}

impl SlamConfig {
    /// The grid pipeline's options (method 2).
    pub fn grid_pipeline_options(&self) -> GridPipelineOptions {
        let [x_m, y_m, theta_rad] = self.laser_in_robot;
        GridPipelineOptions {
            slam: SlamOptions {
                max_range_m: self.grid_max_range_m,
                ..SlamOptions::default()
            },
            map_resolution_m: self.grid_resolution_m,
            laser_in_robot: Pose2::new(x_m, y_m, theta_rad),
        }
    }

    /// The geo-referencing of the grid method's map: its trajectory aligned to the fixes.
    pub fn geo_referencer(&self, datum_lat_lon_deg: Option<[f64; 2]>) -> GeoReferencer {
        GeoReferencer::new(
            GeoReferencerOptions {
                antenna_in_robot: self.antenna_in_robot,
                ..GeoReferencerOptions::default()
            },
            datum_lat_lon_deg,
        )
    }

    /// The EKF pipeline's options (method 1), with the local metric frame at
    /// `datum_lat_lon_deg` when given, else at the first fix.
    pub fn ekf_pipeline_options(&self, datum_lat_lon_deg: Option<[f64; 2]>) -> EkfPipelineOptions {
        let [x_m, y_m, theta_rad] = self.laser_in_robot;
        EkfPipelineOptions {
            // As written in the configuration: the angle is not wrapped.
            laser_in_robot: Pose2 {
                x_m,
                y_m,
                theta_rad,
            },
            antenna_in_robot: self.antenna_in_robot,
            max_range_m: self.ekf_max_range_m,
            landmarks_per_local_map: self.ekf_landmarks_per_local_map,
            datum_lat_lon_deg,
            trajectory: PoseHistoryOptions {
                max_shown: crate::publish::MAX_SHOWN_TRAJECTORY_POINTS,
                ..PoseHistoryOptions::default()
            },
            ..EkfPipelineOptions::default()
        }
    }
}

/// The web view and the live Foxglove stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WebConfig {
    /// Serve the web view and its API.
    pub enabled: bool,
    /// Address of the web view. Loopback unless told otherwise.
    pub listen: SocketAddr,
    /// Address of the Foxglove WebSocket server; absent: no live Foxglove stream.
    pub foxglove_listen: Option<SocketAddr>,
    /// The token that requests changing the robot's state (the goal) must carry, as
    /// `Authorization: Bearer TOKEN`. When absent and `listen` is not a loopback address, one
    /// is generated at start and printed; on loopback, absent means no token.
    pub token: Option<String>,
    /// Whether the read-only views (`GET /api/...`) stay open without the token.
    pub open_read_only: bool,
    /// Connections the web view serves at once; more are closed as they arrive.
    pub max_connections: usize,
}

impl Default for WebConfig {
    fn default() -> Self {
        WebConfig {
            enabled: true,
            listen: SocketAddr::from(([127, 0, 0, 1], 8080)),
            foxglove_listen: Some(SocketAddr::from(([127, 0, 0, 1], 8765))),
            token: None,
            open_read_only: true,
            max_connections: 64,
        }
    }
}

/// The shortest token accepted from the configuration, characters.
pub const MIN_TOKEN_LEN: usize = 16;

/// The MCAP recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RecordConfig {
    /// Where to record; absent: no recording.
    pub path: Option<PathBuf>,
    /// The recording is flushed to disk every this many seconds: a crash loses at most this
    /// much.
    pub flush_interval_s: f64,
    /// After this many seconds the recording goes on in its next file (`run.mcap`, then
    /// `run_1.mcap`, …; replay reads them in turn from the first): the recorder's index of
    /// a file grows with the time in it.
    pub part_length_s: f64,
}

impl Default for RecordConfig {
    fn default() -> Self {
        RecordConfig {
            path: None,
            flush_interval_s: 1.0,
            part_length_s: 600.0,
        }
    }
}

/// Geo-referencing and goals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GeorefConfig {
    /// A geo-referenced image (GeoTIFF, or PNG/JPEG with a world file) to show under the map
    /// and to click goals on.
    pub image: Option<PathBuf>,
    /// The origin of the local metric frame, `[lat_deg, lon_deg]`; absent: the first fix.
    pub datum_lat_lon_deg: Option<[f64; 2]>,
    /// A goal farther than this from the built map (its trajectory and landmarks) is refused,
    /// metres.
    pub goal_margin_m: f64,
}

impl Default for GeorefConfig {
    fn default() -> Self {
        GeorefConfig {
            image: None,
            datum_lat_lon_deg: None,
            goal_margin_m: 30.0,
        }
    }
}

/// The camera on the robot computer, for the camera method.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraConfig {
    /// The V4L2 device, e.g. `/dev/video0`; absent: no camera.
    pub device: Option<String>,
    /// Frame width asked of the camera, pixels.
    pub width_px: u32,
    /// Frame height asked of the camera, pixels.
    pub height_px: u32,
    /// Frames per second asked of the camera.
    pub rate_hz: f64,
    /// Focal lengths and principal point at that size, `[fx, fy, cx, cy]`, pixels (pixel
    /// `(0, 0)` is the centre of the top-left pixel).
    pub intrinsics_px: [f64; 4],
    /// Lens distortion, `[k1, k2, p1, p2, k3]` (OpenCV's order).
    pub distortion: [f64; 5],
    /// JPEG quality (1–100) of frames the camera gives uncompressed, as they are recorded and
    /// shown; MJPEG frames are kept as they come.
    pub jpeg_quality: u8,
    /// How far the camera, mounted level, tilts from level as the robot drives (the ground's
    /// slope), standard deviation in degrees; the camera method holds its roll and pitch to
    /// it (`host::camera::LevelPrior`). 0: the camera is not held level.
    pub tilt_sigma_deg: f64,
    /// The camera looks forward, and its motion leaves its optical axis by about this much
    /// as the robot turns (standard deviation, degrees); the camera method holds the camera's
    /// velocity to it (`host::camera::ForwardMotionPrior`, 3° suits a camera ahead of the
    /// robot's axle). 0 (the default): the camera may move in any direction.
    pub sideslip_sigma_deg: f64,
    /// Fuse the GPS fixes into the camera method's filter
    /// (`host::camera::CameraPipelineOptions::fuse_gps`); false (the default): the fixes only
    /// place the camera's path.
    pub fuse_gps: bool,
}

impl Default for CameraConfig {
    fn default() -> Self {
        // A 640 × 480 camera with a 65° horizontal field of view (320 / tan 32.5°), no
        // distortion.
        let focal_px = 502.3;
        CameraConfig {
            device: None,
            width_px: 640,
            height_px: 480,
            rate_hz: 10.0,
            intrinsics_px: [focal_px, focal_px, 319.5, 239.5],
            distortion: [0.0; 5],
            jpeg_quality: 85,
            tilt_sigma_deg: host::camera::LevelPrior::DEFAULT_TILT_DEG,
            sideslip_sigma_deg: 0.0,
            fuse_gps: false,
        }
    }
}

impl CameraConfig {
    /// Sets the size and calibration to `camera`'s.
    pub fn set_model(&mut self, camera: &host::camera::PinholeCamera) {
        self.width_px = camera.width_px;
        self.height_px = camera.height_px;
        self.intrinsics_px = [camera.fx_px, camera.fy_px, camera.cx_px, camera.cy_px];
        let ([k1, k2, k3], [p1, p2]) = (camera.radial, camera.tangential);
        self.distortion = [k1, k2, p1, p2, k3];
    }

    /// How the camera method holds the camera level (`None`: it does not).
    pub fn level_prior(&self) -> Option<host::camera::LevelPrior> {
        // A tilt `validate` refuses is not held level.
        host::camera::LevelPrior::from_tilt_deg(self.tilt_sigma_deg)
            .ok()
            .flatten()
    }

    /// How the camera method holds the camera's motion to its optical axis (`None`: it does
    /// not).
    pub fn forward_motion_prior(&self) -> Option<host::camera::ForwardMotionPrior> {
        // A sideslip `validate` refuses is no prior.
        host::camera::ForwardMotionPrior::from_sideslip_deg(self.sideslip_sigma_deg)
            .ok()
            .flatten()
    }

    /// The camera model of the configuration.
    pub fn pinhole(&self) -> host::camera::PinholeCamera {
        let [fx, fy, cx, cy] = self.intrinsics_px;
        let [k1, k2, p1, p2, k3] = self.distortion;
        host::camera::PinholeCamera {
            radial: [k1, k2, k3],
            tangential: [p1, p2],
            ..host::camera::PinholeCamera::ideal(fx, fy, cx, cy, [self.width_px, self.height_px])
        }
    }
}

/// The whole configuration.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DaemonConfig {
    /// The serial link.
    pub link: LinkConfig,
    /// The SLAM pipelines.
    pub slam: SlamConfig,
    /// The web view.
    pub web: WebConfig,
    /// The recording.
    pub record: RecordConfig,
    /// Geo-referencing and goals.
    pub georef: GeorefConfig,
    /// The camera.
    pub camera: CameraConfig,
}

/// A configuration file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("cannot read the configuration {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not valid TOML for this configuration (the message names the line and
    /// the field).
    #[error("configuration {path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What and where.
        message: String,
    },
    /// A value out of its range.
    #[error("configuration: {0}")]
    Invalid(String),
}

impl DaemonConfig {
    /// Reads and checks a configuration file; fields it leaves out keep their defaults.
    ///
    /// # Errors
    /// An unreadable file, invalid TOML, an unknown field, a value out of range.
    pub fn load(path: &Path) -> Result<DaemonConfig, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        DaemonConfig::parse(&text, path)
    }

    /// Reads and checks the text of a configuration file; `path` names it in errors.
    ///
    /// # Errors
    /// Invalid TOML, an unknown field, a value out of range.
    pub fn parse(text: &str, path: &Path) -> Result<DaemonConfig, ConfigError> {
        let config: DaemonConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        config.validate()?;
        Ok(config)
    }

    /// Checks the values' ranges.
    ///
    /// # Errors
    /// The first value out of range, named.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ConfigError::Invalid(format!(
                    "{name} must be a positive number, got {v}"
                )))
            }
        };
        positive("link.ping_interval_s", self.link.ping_interval_s)?;
        positive("slam.ekf_max_range_m", self.slam.ekf_max_range_m)?;
        positive("slam.grid_max_range_m", self.slam.grid_max_range_m)?;
        positive("slam.grid_resolution_m", self.slam.grid_resolution_m)?;
        positive("record.flush_interval_s", self.record.flush_interval_s)?;
        positive("record.part_length_s", self.record.part_length_s)?;
        positive("georef.goal_margin_m", self.georef.goal_margin_m)?;
        if self.link.baud == 0 {
            return Err(ConfigError::Invalid("link.baud must not be 0".into()));
        }
        if let Some(token) = &self.web.token
            && (token.chars().count() < MIN_TOKEN_LEN
                || !token.chars().all(|c| c.is_ascii_graphic()))
        {
            return Err(ConfigError::Invalid(format!(
                "web.token must be at least {MIN_TOKEN_LEN} printable characters without spaces"
            )));
        }
        if self.web.max_connections == 0 {
            return Err(ConfigError::Invalid(
                "web.max_connections must be at least 1".into(),
            ));
        }
        if self.slam.ekf_landmarks_per_local_map < 2 {
            return Err(ConfigError::Invalid(
                "slam.ekf_landmarks_per_local_map must be at least 2".into(),
            ));
        }
        if self.slam.grid_redraw_every_scans == 0 {
            return Err(ConfigError::Invalid(
                "slam.grid_redraw_every_scans must be at least 1".into(),
            ));
        }
        if let Some([lat, lon]) = self.georef.datum_lat_lon_deg
            && !(lat.abs() <= 90.0 && lon.abs() <= 180.0)
        {
            return Err(ConfigError::Invalid(format!(
                "georef.datum_lat_lon_deg must be a latitude within ±90° and a longitude \
                 within ±180°, got [{lat}, {lon}]"
            )));
        }
        positive("camera.rate_hz", self.camera.rate_hz)?;
        let [fx, fy, cx, cy] = self.camera.intrinsics_px;
        positive("camera.intrinsics_px (fx)", fx)?;
        positive("camera.intrinsics_px (fy)", fy)?;
        if !(cx.is_finite()
            && cy.is_finite()
            && self.camera.distortion.iter().all(|v| v.is_finite()))
        {
            return Err(ConfigError::Invalid(
                "camera.intrinsics_px and camera.distortion must be finite".into(),
            ));
        }
        if self.camera.width_px == 0 || self.camera.height_px == 0 {
            return Err(ConfigError::Invalid(
                "camera.width_px and camera.height_px must be at least 1".into(),
            ));
        }
        host::camera::LevelPrior::from_tilt_deg(self.camera.tilt_sigma_deg)
            .map_err(|e| ConfigError::Invalid(format!("camera.tilt_sigma_deg: {e}")))?;
        host::camera::ForwardMotionPrior::from_sideslip_deg(self.camera.sideslip_sigma_deg)
            .map_err(|e| ConfigError::Invalid(format!("camera.sideslip_sigma_deg: {e}")))?;
        if !(1..=100).contains(&self.camera.jpeg_quality) {
            return Err(ConfigError::Invalid(format!(
                "camera.jpeg_quality must be 1 to 100, got {}",
                self.camera.jpeg_quality
            )));
        }
        if !self.slam.laser_in_robot.iter().all(|v| v.is_finite())
            || !self.slam.antenna_in_robot.iter().all(|v| v.is_finite())
        {
            return Err(ConfigError::Invalid(
                "slam.laser_in_robot and slam.antenna_in_robot must be finite".into(),
            ));
        }
        Ok(())
    }

    /// The configuration as TOML (what `robot-host config` prints).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_else(|e| format!("# cannot print: {e}\n"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEFAULT_FILE: &str = include_str!("../config/robot-host.toml");

    #[test]
    fn the_documented_file_is_the_default() {
        let parsed: DaemonConfig = toml::from_str(DEFAULT_FILE).expect("the default file parses");
        assert_eq!(parsed, DaemonConfig::default());
    }

    #[test]
    fn printed_config_reads_back() {
        let mut config = DaemonConfig::default();
        config.slam.method = SlamMethod::Both;
        config.record.path = Some("/tmp/run.mcap".into());
        let again: DaemonConfig = toml::from_str(&config.to_toml()).expect("reads back");
        assert_eq!(again, config);
    }

    #[test]
    fn missing_fields_keep_defaults_and_unknown_fields_are_named() {
        let partial: DaemonConfig =
            toml::from_str("[link]\nport = \"/dev/ttyUSB0\"\n").expect("partial file");
        assert_eq!(partial.link.port, "/dev/ttyUSB0");
        assert_eq!(partial.link.baud, 921_600);
        let err = toml::from_str::<DaemonConfig>("[link]\nprot = \"x\"\n")
            .expect_err("unknown field")
            .to_string();
        assert!(err.contains("prot"), "{err}");
    }

    #[test]
    fn out_of_range_values_are_refused_with_their_name() {
        let mut config = DaemonConfig::default();
        config.slam.grid_resolution_m = 0.0;
        let err = config.validate().expect_err("refused").to_string();
        assert!(err.contains("slam.grid_resolution_m"), "{err}");
        let mut config = DaemonConfig::default();
        config.georef.datum_lat_lon_deg = Some([95.0, 0.0]);
        assert!(config.validate().is_err());
    }

    #[test]
    fn a_camera_model_round_trips_through_the_configuration() {
        let mut model = host::camera::PinholeCamera::ideal(610.0, 605.0, 320.5, 241.0, [640, 482]);
        model.radial = [-0.2, 0.05, 0.001];
        model.tangential = [0.002, -0.001];
        let mut config = CameraConfig::default();
        config.set_model(&model);
        assert_eq!(config.pinhole(), model);
    }

    #[test]
    fn camera_values_out_of_range_are_named() {
        let mut config = DaemonConfig::default();
        // A replay of recorded frames needs no device: the daemon asks for one at start.
        config.slam.method = SlamMethod::Camera;
        config.validate().expect("accepted");
        config.camera.jpeg_quality = 0;
        let err = config.validate().expect_err("refused").to_string();
        assert!(err.contains("camera.jpeg_quality"), "{err}");
    }

    #[test]
    fn a_missing_file_is_named() {
        let err = DaemonConfig::load(Path::new("/nonexistent/robot-host.toml"))
            .expect_err("missing")
            .to_string();
        assert!(err.contains("/nonexistent/robot-host.toml"), "{err}");
    }
}
