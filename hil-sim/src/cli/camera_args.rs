//! The flags that choose the camera method, shared by `run` and `demo`.

use hil_sim::run::CameraRunOptions;
use host::camera::{ForwardMotionPrior, LevelPrior};

/// What estimates the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// The world's laser method.
    Laser,
    /// The camera method with GPS (outdoors).
    Camera,
}

/// The method, and the camera's flags.
#[derive(Debug, clap::Args)]
pub struct CameraArgs {
    /// What estimates the robot: `laser` (the world's laser method: the occupancy grid
    /// indoors, the EKF on trees with GPS outdoors) or `camera` (needs `--world outdoor`:
    /// the camera method on the robot computer's camera, with GPS).
    #[arg(long, value_enum, default_value_t = Method::Laser)]
    method: Method,
    /// Camera frames per second (`--method camera`) [default: 10]. At most a day's worth
    /// of frames (864 000) per run.
    #[arg(long)]
    camera_rate: Option<f64>,
    /// People walking about near the route, seen by the camera (`--method camera`).
    #[arg(long, default_value_t = 0)]
    movers: usize,
    /// How far the robot's camera, mounted level, tilts as it drives (the ground's slope),
    /// standard deviation in degrees: the camera method holds its roll and pitch to it.
    /// 0: not held level, as for a hand-held camera (`--method camera`) [default: 3].
    #[arg(long)]
    camera_tilt_deg: Option<f64>,
    /// How far the motion of the robot's camera, looking forward, leaves its optical axis as
    /// the robot turns, standard deviation in degrees (3 for the rendered robot's camera):
    /// the camera method holds the camera's velocity to it. Without it the camera may move in
    /// any direction (`--method camera`).
    #[arg(long)]
    camera_sideslip_deg: Option<f64>,
    /// Fuse the GPS fixes into the camera method's filter: once the fixes have aligned the
    /// map, each corrects the camera's position and, through it, its velocity, map and
    /// scale. Without it the fixes only place the camera's path (`--method camera`).
    #[arg(long)]
    camera_fuse_gps: bool,
}

/// The camera method's level prior for `--camera-tilt-deg` (`None`: the default).
///
/// # Errors
/// A tilt that is negative or not a number.
pub fn level_prior(tilt_deg: Option<f64>) -> Result<Option<LevelPrior>, String> {
    tilt_deg.map_or(Ok(Some(LevelPrior::default())), level_prior_of)
}

/// The camera method's level prior for `--camera-tilt-deg DEG` (0: not held level).
///
/// # Errors
/// A tilt that is negative or not a number.
pub fn level_prior_of(tilt_deg: f64) -> Result<Option<LevelPrior>, String> {
    LevelPrior::from_tilt_deg(tilt_deg).map_err(|e| format!("--camera-tilt-deg: {e}"))
}

/// The camera method's forward-motion prior for `--camera-sideslip-deg` (absent or 0: none).
///
/// # Errors
/// A sideslip that is negative, not a number, or 90° or more.
pub fn forward_motion_prior(
    sideslip_deg: Option<f64>,
) -> Result<Option<ForwardMotionPrior>, String> {
    sideslip_deg.map_or(Ok(None), |deg| {
        ForwardMotionPrior::from_sideslip_deg(deg)
            .map_err(|e| format!("--camera-sideslip-deg: {e}"))
    })
}

impl CameraArgs {
    /// The camera of the flags, `None` for the laser method.
    ///
    /// # Errors
    /// Camera flags without `--method camera`.
    pub fn options(&self) -> Result<Option<CameraRunOptions>, String> {
        if self.method == Method::Laser
            && (self.movers > 0
                || self.camera_rate.is_some()
                || self.camera_tilt_deg.is_some()
                || self.camera_sideslip_deg.is_some()
                || self.camera_fuse_gps)
        {
            return Err(
                "--movers, --camera-rate, --camera-tilt-deg, --camera-sideslip-deg and \
                        --camera-fuse-gps are the camera's: they need --method camera"
                    .into(),
            );
        }
        let level = level_prior(self.camera_tilt_deg)?;
        let forward_motion = forward_motion_prior(self.camera_sideslip_deg)?;
        Ok((self.method == Method::Camera).then(|| CameraRunOptions {
            rate_hz: self
                .camera_rate
                .unwrap_or(CameraRunOptions::default().rate_hz),
            movers: self.movers,
            level,
            forward_motion,
            fuse_gps: self.camera_fuse_gps,
            ..CameraRunOptions::default()
        }))
    }
}
