//! `hil-sim nees`: filter consistency by Monte-Carlo runs, the NEES of the EKF submap filter,
//! a single global EKF and the ideal EKF.

use super::CliResult;
use super::parsers::parse_sigma;

/// Filter consistency: Monte-Carlo runs in a seeded world, the EKF submap filter, a single
/// global EKF and the ideal EKF (true data association, Jacobians at the true state; the
/// reference for what the test yields on these runs) on the same noisy odometry and tree
/// observations. Prints as its last line
/// `{"runs":N,"submap_fraction_within":…,"full_ekf_fraction_within":…,
/// "ideal_ekf_fraction_within":…}`: the fraction of steps whose run-averaged robot-pose
/// NEES lies within the 95 % chi-square bounds.
#[derive(Debug, clap::Args)]
pub struct NeesArgs {
    /// World (only `outdoor` has landmarks).
    #[arg(long, default_value = "outdoor")]
    world: hil_sim::world::WorldKind,
    /// Monte-Carlo runs.
    #[arg(long, default_value_t = 20)]
    runs: usize,
    /// Number of the first run: runs `first-run .. first-run + runs` of the seed's set,
    /// each with the same noise as in a longer set (to look at one run again).
    #[arg(long, default_value_t = 0)]
    first_run: usize,
    /// Seed of the world and the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Length of each run, s.
    #[arg(long, default_value_t = 120.0)]
    duration: f64,
    /// Landmarks per local map of the submap filter.
    #[arg(long, default_value_t = 30)]
    local_map_landmarks: usize,
    /// Standard deviation of a tree's range, in the simulator and in the filters, m.
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true, value_parser = parse_sigma)]
    range_sigma_m: f64,
    /// Standard deviation of a tree's bearing, in the simulator and in the filters,
    /// degrees.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = parse_sigma)]
    bearing_sigma_deg: f64,
}

/// Runs the Monte-Carlo runs; the full report on stderr, the fractions within the bounds as
/// the last line on stdout.
pub fn run(args: NeesArgs) -> CliResult {
    let options = hil_sim::nees::NeesOptions {
        world: args.world,
        runs: args.runs,
        first_run: args.first_run,
        seed: args.seed,
        duration_s: args.duration,
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
