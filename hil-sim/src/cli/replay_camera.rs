//! `hil-sim replay-camera`: the camera method over a recorded image sequence.

use std::path::PathBuf;

use super::CliResult;

/// The camera method (MonoSLAM-style EKF, inverse-depth features, 1-point RANSAC) over a
/// recorded image sequence.
///
/// SEQ is a folder in the KITTI odometry layout (image_0/, times.txt, calib.txt, optional
/// poses.txt) or the TUM RGB-D layout (rgb.txt, its images, calib.txt with
/// `fx fy cx cy k1 k2 p1 p2 k3`, optional groundtruth.txt). Writes OUT/trajectory.tum
/// (`t tx ty tz qx qy qz qw`, the camera in the first frame's camera frame),
/// OUT/map.ply (the 3D features), OUT/tracks.png (four frames with the features in view and
/// their 3σ search ellipses, corners found moving in blue) and OUT/summary.json (frames,
/// speed, features per frame, local maps, places seen before and recognised, features
/// rejected as moving and, with ground truth,
/// the error after the best similarity alignment: a single camera fixes no scale unless a
/// known target gives it).
#[derive(Debug, clap::Args)]
pub struct ReplayCameraArgs {
    /// The sequence folder.
    sequence: PathBuf,
    /// Output directory (created if missing).
    #[arg(long, default_value = "camera-out")]
    out: PathBuf,
    /// Only the first N frames.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    first_frames: Option<u64>,
    /// A known target seen in the first frame, which gives the run a metric scale: a text
    /// file, one corner per line, `u_px v_px x_m y_m z_m` (its pixel in the first frame and
    /// its position in the first camera's frame: x right, y down, z forward); `#` comments.
    #[arg(long, value_name = "FILE")]
    target: Option<PathBuf>,
    /// The camera was mounted level on a ground vehicle, and tilted from level by about this
    /// much as it drove (the ground's slope), standard deviation in degrees: the method holds
    /// its roll and pitch to it. Without it the camera may point anywhere (hand-held).
    #[arg(long, value_name = "DEG")]
    camera_tilt_deg: Option<f64>,
    /// The camera looks forward from a ground vehicle, and its motion leaves its optical axis
    /// by about this much as the vehicle turns and pitches (standard deviation, degrees): the
    /// method holds the camera's velocity to it; 0: the camera may move in any direction
    /// (hand-held). Default: 3 for a KITTI folder (the KITTI car's camera), 0 for a TUM
    /// folder (a camera that may be hand-held).
    #[arg(long, value_name = "DEG")]
    camera_sideslip_deg: Option<f64>,
}

/// Runs the camera method; prints the summary on stdout.
pub fn run(args: ReplayCameraArgs) -> CliResult {
    let sideslip_deg = match args.camera_sideslip_deg {
        Some(deg) => Some(deg),
        None => host::camera::CameraSequence::open(&args.sequence)?
            .layout
            .is_forward_looking_vehicle()
            .then_some(host::camera::ForwardMotionPrior::DEFAULT_SIDESLIP_DEG),
    };
    let options = hil_sim::camera_replay::CameraReplayOptions {
        sequence: args.sequence,
        out: args.out,
        first_frames: args.first_frames.map(|n| n as usize),
        target: args.target,
        slam: host::camera::MonoSlamOptions {
            // A recorded sequence is not held level unless asked.
            level: args
                .camera_tilt_deg
                .map_or(Ok(None), super::camera_args::level_prior_of)?,
            forward_motion: super::camera_args::forward_motion_prior(sideslip_deg)?,
            ..host::camera::MonoSlamOptions::default()
        },
        progress: true,
    };
    let summary = hil_sim::camera_replay::replay_camera(&options)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}
