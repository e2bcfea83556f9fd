//! `hil-sim replay-victoria`: EKF SLAM with local maps over the Victoria Park run, measured
//! against its GPS.

use std::path::PathBuf;

use super::CliResult;
use super::parsers::{parse_datum, parse_sigma};

/// EKF SLAM with local maps over the Victoria Park run (tree detections, car odometry,
/// GPS), measured against its GPS.
///
/// Writes OUT/trajectory.tsv (`t_s x_m y_m theta_rad` of the laser at each scan, estimated
/// again against the finished map, forwards and backwards; with GPS fused, in the frame
/// of gps.dat), OUT/online_trajectory.tsv (the filter's estimate at each scan),
/// OUT/landmarks.tsv and OUT/summary.json (`wall_s`, `steps`,
/// `landmarks`, `local_maps`, `loop_closures`, `rms_to_gps_m`: directly with GPS fused,
/// after the best rigid alignment with `--no-gps`; `rms_to_gps_without_jumps_m`: the same
/// without the receiver's jumps; and step times by map size).
#[derive(Debug, clap::Args)]
pub struct ReplayVictoriaArgs {
    /// The `rfs_slam_ascii` directory (inputs.dat, gps.dat, measurements.dat).
    dir: PathBuf,
    /// Output directory (created if missing).
    #[arg(long, default_value = "victoria-out")]
    out: PathBuf,
    /// Do not fuse the GPS (it is still used to measure the error).
    #[arg(long)]
    no_gps: bool,
    /// Standard deviation of a GPS fix on each axis, m.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = parse_sigma)]
    gps_sigma_m: f64,
    /// Close a local map once it holds this many landmarks; 0 runs one global EKF.
    #[arg(long, default_value_t = 30)]
    local_map_landmarks: usize,
    /// Do not estimate the odometry's speed scale and steering offset online.
    #[arg(long)]
    no_calibration: bool,
    /// Trees further than this are not used, m (0 runs on odometry alone).
    #[arg(long, default_value_t = 40.0)]
    max_range_m: f64,
    /// Use only the first S seconds of the run.
    #[arg(long)]
    duration_s: Option<f64>,
    /// `LAT,LON` (degrees) of the origin of gps.dat's metric frame, which the dataset does
    /// not record; with GPS fused, OUT/map.geojson and OUT/map.kml are written in WGS84.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_datum)]
    datum: Option<host::georef::LocalFrame>,
    /// Standard deviation of a tree's range, m.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = parse_sigma)]
    sigma_range_m: f64,
    /// Standard deviation of a tree's bearing, degrees.
    #[arg(long, default_value_t = 3.0, allow_hyphen_values = true, value_parser = parse_sigma)]
    sigma_bearing_deg: f64,
    /// Standard deviation of the measured wheel speed, m/s.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = parse_sigma)]
    sigma_speed_mps: f64,
    /// Standard deviation of the measured steering angle, degrees.
    #[arg(long, default_value_t = 5.0, allow_hyphen_values = true, value_parser = parse_sigma)]
    sigma_steer_deg: f64,
    /// Lateral offset of the laser, m, positive to the left.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true)]
    laser_left_m: f64,
    /// Distance of the laser ahead of the rear axle, m.
    #[arg(long, default_value_t = 3.78)]
    laser_ahead_m: f64,
}

/// Runs the SLAM over the Victoria Park run; prints the summary on stdout, the speed and
/// the error to the GPS on stderr.
pub fn run(args: ReplayVictoriaArgs) -> CliResult {
    let mut options = hil_sim::victoria_slam::VictoriaSlamOptions::new(args.dir, args.out);
    options.use_gps = !args.no_gps;
    options.gps_sigma_m = args.gps_sigma_m;
    options.slam.max_landmarks_per_local_map = if args.local_map_landmarks == 0 {
        usize::MAX
    } else {
        args.local_map_landmarks
    };
    options.motion.calibrate = !args.no_calibration;
    options.max_range_m = args.max_range_m;
    options.duration_s = args.duration_s;
    options.datum = args.datum;
    options.sensor.sigma_range_m = args.sigma_range_m;
    options.sensor.sigma_bearing_rad = args.sigma_bearing_deg.to_radians();
    options.sensor.sensor_in_robot.x_m = args.laser_ahead_m;
    options.sensor.sensor_in_robot.y_m = args.laser_left_m;
    options.motion.sigma_speed_mps = args.sigma_speed_mps;
    options.motion.sigma_steer_rad = args.sigma_steer_deg.to_radians();
    let summary = hil_sim::victoria_slam::replay_victoria(&options)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    eprintln!(
        "hil-sim: {} scans in {:.3} s, RMS to GPS {:.2} m ({:.2} m without its {} jumps); \
         outputs in {}",
        summary.scans,
        summary.wall_s,
        summary.rms_to_gps_m,
        summary.rms_to_gps_without_jumps_m,
        summary.gps_jumps,
        options.out.display()
    );
    Ok(())
}
