//! The flags that choose the camera method, shared by `run` and `demo`.

use hil_sim::run::CameraRunOptions;

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
}

impl CameraArgs {
    /// The camera of the flags, `None` for the laser method.
    ///
    /// # Errors
    /// Camera flags without `--method camera`.
    pub fn options(&self) -> Result<Option<CameraRunOptions>, String> {
        if self.method == Method::Laser && (self.movers > 0 || self.camera_rate.is_some()) {
            return Err(
                "--movers and --camera-rate are the camera's: they need --method camera".into(),
            );
        }
        Ok((self.method == Method::Camera).then(|| CameraRunOptions {
            rate_hz: self
                .camera_rate
                .unwrap_or(CameraRunOptions::default().rate_hz),
            movers: self.movers,
            ..CameraRunOptions::default()
        }))
    }
}
