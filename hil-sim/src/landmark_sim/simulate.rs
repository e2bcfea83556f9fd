//! Generates one Monte-Carlo run of landmark SLAM data from a [`Scenario`]: true poses,
//! noisy odometry and noisy range-bearing observations of the landmarks, one step per laser
//! scan. See [`super`] for the exact contract.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::arc_model::{arc_odometry, arc_step};
use super::noise_model::{NoiseModel, NoiseModelError};
use super::simulated_run::{OdometryInput, SimObservation, SimStep, SimulatedRun};
use crate::world::robot_state::wrap_angle_rad;
use crate::world::{RobotState, Scenario, World};

/// ChaCha stream of the odometry noise; observations use another stream of the same seed, so
/// changing what is observed (field of view, range) leaves the odometry noise as it was.
const ODOMETRY_STREAM: u64 = 0;
/// ChaCha stream of the observation noise.
const OBSERVATION_STREAM: u64 = 1;
/// How much nearer than a landmark's own surface the first hit on the line of sight may be
/// and still count as the landmark, metres (absorbs rounding; obstacles stand at least a
/// metre apart in the generated worlds).
const VISIBILITY_TOLERANCE_M: f64 = 1e-3;

/// Simulates the robot of `scenario` with the noise and timing of `model`, drawing every
/// noise from `run_seed`: steps at `t = k · laser_period_s` for every `k` from 0 while
/// `t` does not exceed the scenario's duration.
///
/// The same scenario, model and seed give the same run, bit for bit; different seeds give
/// independent noise over the same true poses. What is drawn, and how, is listed in
/// [`super`].
///
/// # Errors
///
/// [`NoiseModelError`] if `model` fails [`NoiseModel::validate`].
pub fn simulate(
    scenario: &Scenario,
    model: &NoiseModel,
    run_seed: u64,
) -> Result<SimulatedRun, NoiseModelError> {
    model.validate()?;
    let mut odometry_rng = ChaCha8Rng::seed_from_u64(run_seed);
    odometry_rng.set_stream(ODOMETRY_STREAM);
    let mut observation_rng = ChaCha8Rng::seed_from_u64(run_seed);
    observation_rng.set_stream(OBSERVATION_STREAM);

    let period_s = model.laser_period_s;
    // Validated: period positive; the scenario's duration is finite and not negative. The
    // small slack keeps the last scan when the duration is a multiple of the period.
    let last_step = (scenario.duration_s() / period_s + 1e-9).floor() as usize;
    let mut steps = Vec::with_capacity(last_step + 1);

    let mut true_pose = pose_of(scenario.pose_at(0.0));
    steps.push(SimStep {
        t_s: 0.0,
        dt_s: 0.0,
        true_pose,
        odometry: OdometryInput::default(),
        observations: observe(scenario, model, true_pose, &mut observation_rng),
    });
    for k in 1..=last_step {
        let t_s = k as f64 * period_s;
        // The arc that follows the scenario: exact heading, nearest position (see `super`).
        let true_odometry = arc_odometry(true_pose, pose_of(scenario.pose_at(t_s)), period_s);
        true_pose = arc_step(true_pose, true_odometry, period_s);
        let odometry = OdometryInput {
            speed_mps: true_odometry.speed_mps
                + model.speed_sigma_at_mps(true_odometry.speed_mps)
                    * standard_normal(&mut odometry_rng),
            yaw_rate_radps: true_odometry.yaw_rate_radps
                + model.yaw_rate_sigma_at_radps(true_odometry.yaw_rate_radps)
                    * standard_normal(&mut odometry_rng),
        };
        steps.push(SimStep {
            t_s,
            dt_s: period_s,
            true_pose,
            odometry,
            observations: observe(scenario, model, true_pose, &mut observation_rng),
        });
    }
    Ok(SimulatedRun { steps })
}

/// The noisy observations, in id order, of the landmarks of `scenario` the laser at `pose`
/// sees: centre within `max_range_m` and the field of view, line of sight to the centre not
/// blocked before the landmark's own surface.
fn observe(
    scenario: &Scenario,
    model: &NoiseModel,
    pose: [f64; 3],
    rng: &mut ChaCha8Rng,
) -> Vec<SimObservation> {
    let [x_m, y_m, theta_rad] = pose;
    let half_fov_rad = 0.5 * model.field_of_view_rad;
    let mut observations = Vec::new();
    for landmark in scenario.landmarks() {
        let dx_m = landmark.center_m[0] - x_m;
        let dy_m = landmark.center_m[1] - y_m;
        let range_m = dx_m.hypot(dy_m);
        if range_m > model.max_range_m || range_m <= landmark.radius_m {
            continue;
        }
        let angle_in_world_rad = dy_m.atan2(dx_m);
        let bearing_rad = wrap_angle_rad(angle_in_world_rad - theta_rad);
        if bearing_rad.abs() > half_fov_rad {
            continue;
        }
        let visible = match scenario
            .world()
            .ray_cast([x_m, y_m], angle_in_world_rad, range_m)
        {
            Some(hit_m) => hit_m >= range_m - landmark.radius_m - VISIBILITY_TOLERANCE_M,
            // The ray ends inside the landmark, so it cannot miss it; treat a miss from
            // rounding as a clear line of sight.
            None => true,
        };
        if !visible {
            continue;
        }
        let range_noise_m = model.range_sigma_m * standard_normal(rng);
        let bearing_noise_rad = model.bearing_sigma_rad * standard_normal(rng);
        observations.push(SimObservation {
            landmark_id: landmark.id,
            range_m: range_m + range_noise_m,
            bearing_rad: wrap_angle_rad(bearing_rad + bearing_noise_rad),
            diameter_m: 2.0 * landmark.radius_m,
        });
    }
    observations
}

/// `[x_m, y_m, theta_rad]` of `state`.
fn pose_of(state: RobotState) -> [f64; 3] {
    [state.x_m, state.y_m, state.theta_rad]
}

/// One draw of `N(0, 1)`.
fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::WorldKind;

    /// Ten minutes in the park: 3001 steps with the default period.
    fn park(seed: u64) -> Scenario {
        Scenario::generate(WorldKind::Outdoor, seed)
    }

    #[test]
    fn same_seed_same_run_other_seed_other_noise() {
        let scenario = Scenario::generate_for(WorldKind::Outdoor, 3, 60.0);
        let model = NoiseModel::default();
        let a = simulate(&scenario, &model, 7).unwrap();
        let b = simulate(&scenario, &model, 7).unwrap();
        let c = simulate(&scenario, &model, 8).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.steps.len(), 301);
        assert_eq!(a.steps.len(), c.steps.len());
        for (sa, sc) in a.steps.iter().zip(&c.steps) {
            assert_eq!(sa.true_pose, sc.true_pose);
            let ids = |s: &SimStep| s.observations.iter().map(|o| o.landmark_id).collect();
            let (ids_a, ids_c): (Vec<u32>, Vec<u32>) = (ids(sa), ids(sc));
            assert_eq!(ids_a, ids_c);
            if sa.t_s > 0.0 {
                assert_ne!(sa.odometry, sc.odometry);
            }
            for (oa, oc) in sa.observations.iter().zip(&sc.observations) {
                assert_ne!(oa.range_m, oc.range_m);
                assert_ne!(oa.bearing_rad, oc.bearing_rad);
            }
        }
        // The odometry noise does not depend on what is observed.
        let narrow = NoiseModel {
            field_of_view_rad: 0.5,
            ..model
        };
        let d = simulate(&scenario, &narrow, 7).unwrap();
        for (sa, sd) in a.steps.iter().zip(&d.steps) {
            assert_eq!(sa.odometry, sd.odometry);
        }
    }

    #[test]
    fn timing_and_step_zero() {
        let scenario = Scenario::generate_for(WorldKind::Outdoor, 1, 10.0);
        let run = simulate(&scenario, &NoiseModel::default(), 1).unwrap();
        assert_eq!(run.steps.len(), 51);
        let first = &run.steps[0];
        assert_eq!((first.t_s, first.dt_s), (0.0, 0.0));
        assert_eq!(first.odometry, OdometryInput::default());
        assert_eq!(run.initial_pose(), Some(pose_of(scenario.pose_at(0.0))));
        for (k, step) in run.steps.iter().enumerate().skip(1) {
            assert!((step.t_s - 0.2 * k as f64).abs() < 1e-12);
            assert_eq!(step.dt_s, 0.2);
        }
        assert_eq!(SimulatedRun::default().initial_pose(), None);
    }

    #[test]
    fn rejects_an_invalid_model() {
        let scenario = Scenario::generate_for(WorldKind::Outdoor, 1, 1.0);
        let model = NoiseModel {
            max_range_m: -1.0,
            ..NoiseModel::default()
        };
        assert!(matches!(
            simulate(&scenario, &model, 0),
            Err(NoiseModelError::NotPositive {
                field: "max_range_m",
                ..
            })
        ));
    }

    #[test]
    fn observes_only_visible_landmarks_within_range_and_field_of_view() {
        let scenario = park(4);
        let model = NoiseModel::default();
        let run = simulate(&scenario, &model, 2).unwrap();
        let (mut observed, mut hidden) = (0usize, 0usize);
        for step in &run.steps {
            let [x_m, y_m, theta_rad] = step.true_pose;
            let mut seen = step.observations.iter().map(|o| o.landmark_id).peekable();
            for landmark in scenario.landmarks() {
                let dx_m = landmark.center_m[0] - x_m;
                let dy_m = landmark.center_m[1] - y_m;
                let range_m = dx_m.hypot(dy_m);
                let bearing_rad = wrap_angle_rad(dy_m.atan2(dx_m) - theta_rad);
                let in_view = range_m <= 30.0 && bearing_rad.abs() <= 0.5 * model.field_of_view_rad;
                if seen.next_if_eq(&landmark.id).is_some() {
                    assert!(in_view, "t {}: landmark {}", step.t_s, landmark.id);
                    observed += 1;
                    let o = step
                        .observations
                        .iter()
                        .find(|o| o.landmark_id == landmark.id)
                        .unwrap();
                    assert!((o.range_m - range_m).abs() < 6.0 * model.range_sigma_m);
                    let bearing_error_rad = wrap_angle_rad(o.bearing_rad - bearing_rad);
                    assert!(bearing_error_rad.abs() < 6.0 * model.bearing_sigma_rad);
                    assert_eq!(o.diameter_m, 2.0 * landmark.radius_m);
                } else if in_view {
                    // Not observed although in view: something blocks the line of sight.
                    let hit_m = scenario
                        .world()
                        .ray_cast([x_m, y_m], dy_m.atan2(dx_m), range_m)
                        .unwrap();
                    assert!(hit_m < range_m - landmark.radius_m - VISIBILITY_TOLERANCE_M);
                    hidden += 1;
                }
            }
            assert!(seen.next().is_none(), "observations out of id order");
        }
        let per_step = observed as f64 / run.steps.len() as f64;
        assert!(per_step > 5.0, "{per_step} landmarks per scan");
        assert!(hidden > 0, "no landmark was ever occluded");
    }

    /// Mean and standard deviation of `values`.
    fn mean_and_std(values: &[f64]) -> (f64, f64) {
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var.sqrt())
    }

    #[test]
    fn noise_matches_the_model() {
        let scenario = park(2);
        let model = NoiseModel::default();
        let run = simulate(&scenario, &model, 5).unwrap();
        let (mut speed_z, mut yaw_z) = (Vec::new(), Vec::new());
        for pair in run.steps.windows(2) {
            let truth = arc_odometry(pair[0].true_pose, pair[1].true_pose, pair[1].dt_s);
            let measured = pair[1].odometry;
            speed_z.push(
                (measured.speed_mps - truth.speed_mps) / model.speed_sigma_at_mps(truth.speed_mps),
            );
            yaw_z.push(
                (measured.yaw_rate_radps - truth.yaw_rate_radps)
                    / model.yaw_rate_sigma_at_radps(truth.yaw_rate_radps),
            );
        }
        let (mut range_z, mut bearing_z) = (Vec::new(), Vec::new());
        for step in &run.steps {
            let [x_m, y_m, theta_rad] = step.true_pose;
            for o in &step.observations {
                let landmark = scenario.landmarks()[o.landmark_id as usize];
                let dx_m = landmark.center_m[0] - x_m;
                let dy_m = landmark.center_m[1] - y_m;
                range_z.push((o.range_m - dx_m.hypot(dy_m)) / model.range_sigma_m);
                let bearing_rad = dy_m.atan2(dx_m) - theta_rad;
                bearing_z
                    .push(wrap_angle_rad(o.bearing_rad - bearing_rad) / model.bearing_sigma_rad);
            }
        }
        assert_eq!(speed_z.len(), 3000);
        for (name, z) in [
            ("speed", &speed_z),
            ("yaw rate", &yaw_z),
            ("range", &range_z),
            ("bearing", &bearing_z),
        ] {
            let (mean, std) = mean_and_std(z);
            println!(
                "{name}: {} samples, mean {mean:.4} σ, std {std:.4} σ",
                z.len()
            );
            assert!((std - 1.0).abs() < 0.1, "{name}: std {std} σ");
            assert!(
                mean.abs() < 4.0 / (z.len() as f64).sqrt(),
                "{name}: mean {mean} σ"
            );
        }
    }

    #[test]
    fn noiseless_odometry_integrates_to_the_true_trajectory() {
        let scenario = park(6);
        let run = simulate(&scenario, &NoiseModel::noiseless(), 1).unwrap();
        let mut pose = run.initial_pose().unwrap();
        let mut worst_m = 0.0_f64;
        for step in &run.steps[1..] {
            // The textbook arc, independent of `arc_step`'s chord form.
            let [x, y, th] = pose;
            let (v, w, dt) = (
                step.odometry.speed_mps,
                step.odometry.yaw_rate_radps,
                step.dt_s,
            );
            pose = if w.abs() < 1e-9 {
                [x + v * dt * th.cos(), y + v * dt * th.sin(), th + w * dt]
            } else {
                [
                    x + v / w * ((th + w * dt).sin() - th.sin()),
                    y - v / w * ((th + w * dt).cos() - th.cos()),
                    th + w * dt,
                ]
            };
            let error_m = (pose[0] - step.true_pose[0]).hypot(pose[1] - step.true_pose[1]);
            worst_m = worst_m.max(error_m);
            assert!(wrap_angle_rad(pose[2] - step.true_pose[2]).abs() < 1e-9);
        }
        println!("worst position error {worst_m:e} m");
        assert!(worst_m < 1e-6);
    }

    #[test]
    fn true_poses_follow_the_scenario() {
        let mut worst_overall_m = 0.0_f64;
        for seed in 0..4 {
            let scenario = park(seed);
            let run = simulate(&scenario, &NoiseModel::default(), 0).unwrap();
            let mut worst_m = 0.0_f64;
            for step in &run.steps {
                let state = scenario.pose_at(step.t_s);
                let [x_m, y_m, theta_rad] = step.true_pose;
                assert!(wrap_angle_rad(theta_rad - state.theta_rad).abs() < 1e-9);
                worst_m = worst_m.max((x_m - state.x_m).hypot(y_m - state.y_m));
            }
            println!("seed {seed}: worst distance from the scenario {worst_m:.4} m");
            worst_overall_m = worst_overall_m.max(worst_m);
        }
        assert!(worst_overall_m < 0.01, "{worst_overall_m} m");
    }
}
