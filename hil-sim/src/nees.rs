//! `hil-sim nees`: the consistency of the EKF submapping filter, measured by Monte-Carlo runs
//! in the seeded outdoor park ([`crate::landmark_sim`]).
//!
//! Every run drives the same park and route with its own odometry and observation noise; the
//! submap filter and a single global EKF (the same filter with local maps that never close)
//! run on the same data with the noise model's own standard deviations and with data
//! association by JCBB (the simulator's landmark identities are not used). At every step the
//! robot-pose NEES `eᵀ P⁻¹ e` is averaged over the runs; a consistent filter keeps that average
//! within the two-sided 95 % bounds of `χ²(3 N) / N` on 95 % of the steps (Bar-Shalom, Li and
//! Kirubarajan, "Estimation with Applications to Tracking and Navigation", §5.4).
//!
//! A run's error persists over many steps, so the run-averaged NEES moves up or down as a
//! block with the set of runs drawn, and the fraction of steps within the bounds scatters from
//! one set to the next even for a consistent filter. The ideal EKF
//! ([`crate::landmark_sim::IdealEkf`]: the true association, every Jacobian at the true state)
//! runs on the same data as the reference for what the test yields on that set.

use host::ekf_slam::{DifferentialDriveInput, LandmarkObservation, SubmapSlam, SubmapSlamOptions};
use host::geometry::Pose2;
use serde::Serialize;

use crate::landmark_sim::{
    IdealEkf, IdealEkfError, NoiseModel, NoiseModelError, SimStep, SimulatedRun, chi_square_bounds,
    pose_nees, simulate,
};
use crate::world::{Scenario, WorldKind};

/// Confidence of the NEES bounds.
const CONFIDENCE: f64 = 0.95;

/// What to run.
#[derive(Debug, Clone, Copy)]
pub struct NeesOptions {
    /// The world; only the outdoor park has landmarks for this filter.
    pub world: WorldKind,
    /// Monte-Carlo runs.
    pub runs: usize,
    /// Number of the first run: runs `first_run .. first_run + runs` of the seed's set are
    /// made, each with the noise it has in any set.
    pub first_run: usize,
    /// Seed of the world and of the runs' noise.
    pub seed: u64,
    /// Length of each run, seconds.
    pub duration_s: f64,
    /// Landmarks per local map of the submap filter.
    pub local_map_landmarks: usize,
    /// The sensors' noise (used by the simulator and, as its model, by the filters).
    pub noise: NoiseModel,
}

impl Default for NeesOptions {
    /// Outdoor, runs 0–19 of 120 s, seed 1, local maps of 30 landmarks, default noise.
    fn default() -> Self {
        NeesOptions {
            world: WorldKind::Outdoor,
            runs: 20,
            first_run: 0,
            seed: 1,
            duration_s: 120.0,
            local_map_landmarks: 30,
            noise: NoiseModel::default(),
        }
    }
}

/// The result, printed as JSON.
#[derive(Debug, Clone, Serialize)]
pub struct NeesReport {
    /// Monte-Carlo runs.
    pub runs: usize,
    /// Fraction of steps whose run-averaged robot-pose NEES of the submap filter lies within
    /// the 95 % bounds.
    pub submap_fraction_within: f64,
    /// The same for a single global EKF.
    pub full_ekf_fraction_within: f64,
    /// The same for the ideal EKF on the same runs: what the test yields on this set of runs
    /// when neither data association nor linearisation is at fault.
    pub ideal_ekf_fraction_within: f64,
    /// Steps per run.
    pub steps: usize,
    /// The bounds on the run-averaged NEES.
    pub bounds: [f64; 2],
    /// Mean over the steps of the run-averaged NEES, submap filter (3 when consistent).
    pub submap_mean_nees: f64,
    /// The same for the global EKF.
    pub full_ekf_mean_nees: f64,
    /// The same for the ideal EKF.
    pub ideal_ekf_mean_nees: f64,
    /// Mean final position error of the submap filter over the runs, metres.
    pub submap_final_error_m: f64,
    /// The same for the global EKF.
    pub full_ekf_final_error_m: f64,
    /// The same for the ideal EKF.
    pub ideal_ekf_final_error_m: f64,
    /// Local maps the submap filter joined, summed over the runs.
    pub local_maps: usize,
}

/// Errors of the command.
#[derive(Debug, thiserror::Error)]
pub enum NeesError {
    /// The world has no landmarks for the filter.
    #[error("the {0} world has no landmarks for the EKF; use --world outdoor")]
    NoLandmarks(WorldKind),
    /// Nothing to average.
    #[error("--runs must be at least 1")]
    NoRuns,
    /// The noise model is invalid.
    #[error(transparent)]
    Noise(#[from] NoiseModelError),
    /// The ideal EKF failed.
    #[error("ideal EKF: {0}")]
    Ideal(#[from] IdealEkfError),
}

/// Per-step NEES of one filter over one run, and its final position error.
struct FilterTrack {
    nees: Vec<f64>,
    final_error_m: f64,
    joins: usize,
}

/// Runs the Monte-Carlo test.
///
/// # Errors
/// An indoor world, zero runs, or an invalid noise model.
pub fn run_nees(options: &NeesOptions) -> Result<NeesReport, NeesError> {
    if options.world != WorldKind::Outdoor {
        return Err(NeesError::NoLandmarks(options.world));
    }
    if options.runs == 0 {
        return Err(NeesError::NoRuns);
    }
    let scenario = Scenario::generate_for(options.world, options.seed, options.duration_s);
    let mut submap_sum: Vec<f64> = Vec::new();
    let mut full_sum: Vec<f64> = Vec::new();
    let mut ideal_sum: Vec<f64> = Vec::new();
    let (mut submap_error, mut full_error, mut ideal_error, mut local_maps) = (0.0, 0.0, 0.0, 0);
    for run in options.first_run..options.first_run + options.runs {
        let run_seed = options
            .seed
            .wrapping_mul(1_000_003)
            .wrapping_add(run as u64);
        let data = simulate(&scenario, &options.noise, run_seed)?;
        let submap = track(&data, &options.noise, options.local_map_landmarks);
        let full = track(&data, &options.noise, usize::MAX);
        let ideal = track_ideal(&data, &scenario, &options.noise)?;
        accumulate(&mut submap_sum, &submap.nees);
        accumulate(&mut full_sum, &full.nees);
        accumulate(&mut ideal_sum, &ideal.nees);
        submap_error += submap.final_error_m;
        full_error += full.final_error_m;
        ideal_error += ideal.final_error_m;
        local_maps += submap.joins;
    }
    let runs = options.runs as f64;
    let (low, high) =
        chi_square_bounds(3, options.runs, CONFIDENCE).unwrap_or((0.0, f64::INFINITY));
    let fraction = |sums: &[f64]| {
        // Step 0 is exact (zero covariance): it is not tested.
        let tested: Vec<f64> = sums.iter().skip(1).map(|s| s / runs).collect();
        let within = tested.iter().filter(|&&v| v >= low && v <= high).count();
        let mean = tested.iter().sum::<f64>() / tested.len().max(1) as f64;
        (within as f64 / tested.len().max(1) as f64, mean)
    };
    let (submap_fraction_within, submap_mean_nees) = fraction(&submap_sum);
    let (full_ekf_fraction_within, full_ekf_mean_nees) = fraction(&full_sum);
    let (ideal_ekf_fraction_within, ideal_ekf_mean_nees) = fraction(&ideal_sum);
    Ok(NeesReport {
        runs: options.runs,
        submap_fraction_within,
        full_ekf_fraction_within,
        ideal_ekf_fraction_within,
        steps: submap_sum.len(),
        bounds: [low, high],
        submap_mean_nees,
        full_ekf_mean_nees,
        ideal_ekf_mean_nees,
        submap_final_error_m: submap_error / runs,
        full_ekf_final_error_m: full_error / runs,
        ideal_ekf_final_error_m: ideal_error / runs,
        local_maps,
    })
}

/// Adds `values` into `sums` element by element.
fn accumulate(sums: &mut Vec<f64>, values: &[f64]) {
    if sums.len() < values.len() {
        sums.resize(values.len(), 0.0);
    }
    for (sum, value) in sums.iter_mut().zip(values) {
        *sum += value;
    }
}

/// Runs one filter over `data`.
fn track(data: &SimulatedRun, noise: &NoiseModel, local_map_landmarks: usize) -> FilterTrack {
    let options = SubmapSlamOptions {
        max_landmarks_per_local_map: local_map_landmarks,
        ..SubmapSlamOptions::default()
    };
    let [x_m, y_m, theta_rad] = data.initial_pose().unwrap_or([0.0; 3]);
    // The simulated pose as it is: the angle is not wrapped again.
    let start = Pose2 {
        x_m,
        y_m,
        theta_rad,
    };
    let mut slam = SubmapSlam::new(noise.motion_model(), noise.sensor_model(), options, start);
    let mut nees = Vec::with_capacity(data.steps.len());
    let mut final_error_m = 0.0;
    for step in &data.steps {
        slam.predict(&odometry_of(step), step.dt_s);
        let observations: Vec<LandmarkObservation> = step
            .observations
            .iter()
            .map(|o| LandmarkObservation {
                range_m: o.range_m,
                bearing_rad: o.bearing_rad,
                diameter_m: Some(o.diameter_m),
            })
            .collect();
        slam.observe(&observations);
        let (pose, covariance) = slam.pose_in_map();
        let (step_nees, error_m) = score(step, pose, &covariance);
        nees.push(step_nees);
        final_error_m = error_m;
    }
    FilterTrack {
        nees,
        final_error_m,
        joins: slam.stats().joins,
    }
}

/// Runs the ideal EKF over `data` in `scenario`'s world.
fn track_ideal(
    data: &SimulatedRun,
    scenario: &Scenario,
    noise: &NoiseModel,
) -> Result<FilterTrack, IdealEkfError> {
    let start = data.initial_pose().unwrap_or([0.0; 3]);
    let mut filter = IdealEkf::new(
        noise.motion_model(),
        noise.sensor_model(),
        scenario.landmarks(),
        start,
    );
    let mut nees = Vec::with_capacity(data.steps.len());
    let mut final_error_m = 0.0;
    let mut previous_true_pose = start;
    for step in &data.steps {
        filter.predict(&odometry_of(step), step.dt_s, previous_true_pose);
        filter.observe(&step.observations, step.true_pose)?;
        previous_true_pose = step.true_pose;
        let (pose, covariance) = filter.pose();
        let (step_nees, error_m) = score(step, pose, &covariance);
        nees.push(step_nees);
        final_error_m = error_m;
    }
    Ok(FilterTrack {
        nees,
        final_error_m,
        joins: 0,
    })
}

/// The step's odometry as the filters take it.
fn odometry_of(step: &SimStep) -> DifferentialDriveInput {
    DifferentialDriveInput {
        speed_mps: step.odometry.speed_mps,
        yaw_rate_radps: step.odometry.yaw_rate_radps,
    }
}

/// The NEES of `pose` with `covariance` against the step's true pose, and the position
/// error in metres. An exact pose (the first step, zero covariance) has no NEES; it counts
/// as zero.
fn score(step: &SimStep, pose: Pose2, covariance: &nalgebra::Matrix3<f64>) -> (f64, f64) {
    let error = [
        pose.x_m - step.true_pose[0],
        pose.y_m - step.true_pose[1],
        pose.theta_rad - step.true_pose[2],
    ];
    let rows = [0, 1, 2].map(|r| [0, 1, 2].map(|c| covariance[(r, c)]));
    (
        pose_nees(error, rows).unwrap_or(0.0),
        error[0].hypot(error[1]),
    )
}
