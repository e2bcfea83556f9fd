//! `hil-sim nees`: filter consistency by Monte-Carlo runs: the NEES of the EKF submap filter,
//! a single global EKF and the ideal EKF, or of the camera method.

use super::CliResult;
use super::parsers::{parse_pixels, parse_sigma};

/// Filter consistency: Monte-Carlo runs in a seeded world, the EKF submap filter, a single
/// global EKF and the ideal EKF (true data association, Jacobians at the true state; the
/// reference for what the test yields on these runs) on the same noisy odometry and tree
/// observations. Prints as its last line
/// `{"runs":N,"submap_fraction_within":…,"full_ekf_fraction_within":…,
/// "ideal_ekf_fraction_within":…}`: the fraction of steps whose run-averaged robot-pose
/// NEES lies within the 95 % chi-square bounds.
///
/// With `--method camera`, run r renders the world of seed + r through the robot's camera
/// and runs the camera method on its frames; the camera's orientation relative to its local
/// map is tested (a single camera does not observe its position's scale), beside the same
/// filter told the true association on the world's own points (the ideal camera filter).
/// The last line is then
/// `{"method":"camera","runs":N,"camera_fraction_within":…,"ideal_fraction_within":…}`.
#[derive(Debug, clap::Args)]
pub struct NeesArgs {
    /// The filter tested: `ekf-submap` (the laser landmark filters) or `camera`.
    #[arg(long, value_enum, default_value_t = Method::EkfSubmap)]
    method: Method,
    /// World (only `outdoor` has landmarks and texture).
    #[arg(long, default_value = "outdoor")]
    world: hil_sim::world::WorldKind,
    /// Monte-Carlo runs [default: 20, camera 10].
    #[arg(long)]
    runs: Option<usize>,
    /// Number of the first run: runs `first-run .. first-run + runs` of the seed's set,
    /// each with the same noise as in a longer set (to look at one run again).
    #[arg(long, default_value_t = 0)]
    first_run: usize,
    /// Seed of the world and the noise (camera: the first run's world; run r renders the
    /// world of seed + r).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Length of each run, s [default: 120, camera 10].
    #[arg(long, allow_hyphen_values = true)]
    duration: Option<f64>,
    /// Camera only: people walking about near the route.
    #[arg(long, default_value_t = 0)]
    movers: usize,
    /// Camera only: how far the robot's camera, mounted level, tilts as it drives, standard
    /// deviation in degrees; the camera method holds its roll and pitch to it. 0: not held
    /// level, as for a hand-held camera [default: 3].
    #[arg(long)]
    camera_tilt_deg: Option<f64>,
    /// Camera only: how far the motion of the robot's camera, looking forward, leaves its
    /// optical axis as it turns, standard deviation in degrees; the camera method holds the
    /// camera's velocity to it (3 for the rendered robot's camera). Without it the camera may
    /// move in any direction.
    #[arg(long)]
    camera_sideslip_deg: Option<f64>,
    /// Camera only: refuse every match farther than this from where the rendered truth puts
    /// its feature, px. The camera method then runs with a front end that never errs by
    /// more than this, which measures what its larger errors cost the filter (a diagnostic;
    /// a robot has no truth). The report's `camera_match_errors` gives the errors either way.
    #[arg(long, value_parser = parse_pixels)]
    truth_gate_px: Option<f64>,
    /// Landmarks per local map of the submap filter (ekf-submap).
    #[arg(long, default_value_t = 30)]
    local_map_landmarks: usize,
    /// Standard deviation of a tree's range, in the simulator and in the filters, m
    /// (ekf-submap).
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true, value_parser = parse_sigma)]
    range_sigma_m: f64,
    /// Standard deviation of a tree's bearing, in the simulator and in the filters,
    /// degrees (ekf-submap).
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = parse_sigma)]
    bearing_sigma_deg: f64,
}

/// Runs the Monte-Carlo runs; the full report on stderr, the fractions within the bounds as
/// the last line on stdout.
pub fn run(args: NeesArgs) -> CliResult {
    if args.method == Method::Camera {
        return run_camera(args);
    }
    if args.movers > 0
        || args.camera_tilt_deg.is_some()
        || args.camera_sideslip_deg.is_some()
        || args.truth_gate_px.is_some()
    {
        return Err(
            "--movers, --camera-tilt-deg, --camera-sideslip-deg and --truth-gate-px are for \
                    --method camera: the laser filters' world has no walkers and no camera"
                .into(),
        );
    }
    let options = hil_sim::nees::NeesOptions {
        world: args.world,
        runs: args.runs.unwrap_or(20),
        first_run: args.first_run,
        seed: args.seed,
        duration_s: args.duration.unwrap_or(120.0),
        local_map_landmarks: args.local_map_landmarks,
        noise: hil_sim::landmark_sim::NoiseModel {
            range_sigma_m: args.range_sigma_m,
            bearing_sigma_rad: args.bearing_sigma_deg.to_radians(),
            ..Default::default()
        },
    };
    let report = hil_sim::nees::run_nees(&options)?;
    eprintln!("{}", serde_json::to_string_pretty(&report)?);
    println!(
        "{}",
        serde_json::json!({
            "runs": report.runs,
            "submap_fraction_within": report.submap_fraction_within,
            "full_ekf_fraction_within": report.full_ekf_fraction_within,
            "ideal_ekf_fraction_within": report.ideal_ekf_fraction_within,
        })
    );
    Ok(())
}

/// The filter `nees` tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Method {
    /// The laser landmark filters: EKF submaps, one global EKF, the ideal EKF.
    EkfSubmap,
    /// The camera method, on a rendered camera.
    Camera,
}

/// `nees --method camera`: the full report on stderr, the fractions as the last line.
fn run_camera(args: NeesArgs) -> CliResult {
    let defaults = hil_sim::camera_nees::CameraNeesOptions::default();
    let options = hil_sim::camera_nees::CameraNeesOptions {
        world: args.world,
        runs: args.runs.unwrap_or(defaults.runs),
        seed: args
            .seed
            .checked_add(args.first_run as u64)
            .ok_or("--seed and --first-run run past the largest seed")?,
        duration_s: args.duration.unwrap_or(defaults.duration_s),
        movers: args.movers,
        slam: host::camera::MonoSlamOptions {
            level: super::camera_args::level_prior(args.camera_tilt_deg)?,
            forward_motion: super::camera_args::forward_motion_prior(args.camera_sideslip_deg)?,
            ..defaults.slam
        },
        truth_gate_px: args.truth_gate_px,
        progress: true,
        ..defaults
    };
    let report = hil_sim::camera_nees::run_camera_nees(&options)?;
    eprintln!("{}", serde_json::to_string_pretty(&report)?);
    println!(
        "{}",
        serde_json::json!({
            "method": "camera",
            "runs": report.runs,
            "camera_fraction_within": report.camera_fraction_within,
            "ideal_fraction_within": report.ideal_fraction_within,
        })
    );
    Ok(())
}
