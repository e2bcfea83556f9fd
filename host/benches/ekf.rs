//! EKF SLAM (`host::ekf_slam`) on a synthetic avenue: trees in two rows 3 m either side of a
//! circular road, 3 m apart along each row (jittered by a fixed LCG), a differential-drive
//! robot driving counter-clockwise along the road with exact odometry, and a range-bearing
//! sensor that returns the eight nearest trees within 15 m, without noise. The filter is told
//! its odometry and sensor are precise (a fifth to a tenth of the default standard deviations),
//! which keeps the drift at the end of a lap well below the tree spacing, so the loop closes
//! onto the right trees.
//!
//! * `ekf_update/landmarks/N`, N ∈ {10, 50, 100, 200, 400}: one scan step (predict, then gate,
//!   JCBB and update with eight observations of mapped landmarks) of a single global EKF
//!   (`max_landmarks_per_local_map = usize::MAX`) that already holds N landmarks, mapped by
//!   driving down an avenue of 1000 trees one tree per row per step. The update costs
//!   O(n² m) in the state size n.
//! * `ekf_step/global_vs_submaps/{global,submaps}`: a whole run of 600 steps around an avenue
//!   of 310 trees and back onto its start, with one global EKF and with local maps of 30
//!   landmarks. Each time is for the whole run; divide by 600 for the mean cost per step
//!   (criterion's throughput line gives steps per second).
//!
//! An unoptimised build (`cargo test -p host --benches`, which runs every bench once as a
//! check) uses N ∈ {10, 50} and a run of 120 steps around 60 trees, which take seconds there
//! where the full sizes take minutes.
//!
//! Run with `cargo bench -p host --bench ekf`.

use std::f64::consts::{FRAC_PI_2, TAU};
use std::hint::black_box;
use std::time::Duration;

use criterion::{
    BatchSize, BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use host::ekf_slam::{
    DifferentialDriveInput, DifferentialDriveModel, LandmarkObservation, RangeBearingModel,
    SubmapSlam, SubmapSlamOptions,
};
use host::geometry::{Pose2, wrap_angle_rad};

/// Distance between neighbouring trees along a row, metres.
const SPACING_M: f64 = 3.0;
/// Distance of each row from the road's centre line, metres.
const ROW_OFFSET_M: f64 = 3.0;
/// Largest offset of a tree from its place in the row, across and along it, metres.
const JITTER_M: f64 = 0.5;
/// Duration of a step, seconds.
const DT_S: f64 = 0.5;
/// Landmarks observed per scan (the nearest ones in range).
const OBSERVATIONS_PER_SCAN: usize = 8;
/// Range of the sensor, metres.
const MAX_RANGE_M: f64 = 15.0;

/// Landmark counts of the single-EKF step bench (small ones only in an unoptimised build).
const LANDMARK_COUNTS: &[usize] = if cfg!(debug_assertions) {
    &[10, 50]
} else {
    &[10, 50, 100, 200, 400]
};
/// Trees of the avenue the single-EKF maps are built on: more than the largest map, so the
/// robot never comes back to its start.
const BUILD_LANDMARKS: usize = 1000;
/// Step length while building the single-EKF maps, metres: one tree per row per step.
const BUILD_STEP_M: f64 = SPACING_M;

/// Trees of the whole-run comparison; an unoptimised build drives a short avenue.
const RUN_LANDMARKS: usize = if cfg!(debug_assertions) { 60 } else { 310 };
/// Steps of the whole-run comparison: about 1.15 laps.
const RUN_STEPS: usize = if cfg!(debug_assertions) { 120 } else { 600 };
/// Step length of the whole-run comparison, metres.
const RUN_STEP_M: f64 = 0.9;
/// Local-map size of the submap filter in the whole-run comparison.
const SUBMAP_LANDMARKS: usize = 30;

/// A 64-bit linear congruential generator (Knuth's MMIX constants) for a fixed layout.
struct Lcg(u64);

impl Lcg {
    /// A number in `[-1, 1)`.
    fn next_signed(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Trees in two rows along a circular road centred on the origin.
struct Avenue {
    landmarks_in_world: Vec<[f64; 2]>,
    track_radius_m: f64,
    step_m: f64,
}

impl Avenue {
    /// `landmark_count` trees, alternately inside and outside the road, and a robot that
    /// drives `step_m` per step.
    fn new(landmark_count: usize, step_m: f64) -> Avenue {
        let columns = landmark_count.div_ceil(2);
        let track_radius_m = columns as f64 * SPACING_M / TAU;
        let mut lcg = Lcg(landmark_count as u64);
        let landmarks_in_world = (0..landmark_count)
            .map(|i| {
                let side = if i % 2 == 0 { -1.0 } else { 1.0 };
                let radius_m = track_radius_m + side * ROW_OFFSET_M + JITTER_M * lcg.next_signed();
                let along_m = (i / 2) as f64 * SPACING_M + JITTER_M * lcg.next_signed();
                let (sin, cos) = (along_m / track_radius_m).sin_cos();
                [radius_m * cos, radius_m * sin]
            })
            .collect();
        Avenue {
            landmarks_in_world,
            track_radius_m,
            step_m,
        }
    }

    /// Where the robot starts: on the road, heading counter-clockwise.
    fn start_pose_in_world(&self) -> Pose2 {
        Pose2 {
            x_m: self.track_radius_m,
            y_m: 0.0,
            theta_rad: FRAC_PI_2,
        }
    }

    /// The odometry of every step: constant speed and turn rate along the road.
    fn odometry(&self) -> DifferentialDriveInput {
        let speed_mps = self.step_m / DT_S;
        DifferentialDriveInput {
            speed_mps,
            yaw_rate_radps: speed_mps / self.track_radius_m,
        }
    }

    /// Steps in one lap of the road.
    fn steps_per_lap(&self) -> usize {
        (TAU * self.track_radius_m / self.step_m).ceil() as usize
    }

    /// The pose after one step from `pose_in_world`, moved as the filter's motion model moves
    /// it (along the chord, at the mid-point heading), so the odometry is exact. The heading
    /// is not wrapped.
    fn step(&self, pose_in_world: Pose2) -> Pose2 {
        let turn_rad = self.odometry().yaw_rate_radps * DT_S;
        let Pose2 {
            x_m: x,
            y_m: y,
            theta_rad: theta,
        } = pose_in_world;
        let (sin, cos) = (theta + 0.5 * turn_rad).sin_cos();
        Pose2 {
            x_m: x + self.step_m * cos,
            y_m: y + self.step_m * sin,
            theta_rad: theta + turn_rad,
        }
    }

    /// The `OBSERVATIONS_PER_SCAN` nearest trees within `MAX_RANGE_M` of the robot at
    /// `pose_in_world` among those `usable` accepts, exact, with their indices.
    fn scan(
        &self,
        pose_in_world: Pose2,
        usable: impl Fn(usize) -> bool,
    ) -> Vec<(usize, LandmarkObservation)> {
        let Pose2 {
            x_m: x,
            y_m: y,
            theta_rad: theta,
        } = pose_in_world;
        let mut seen: Vec<(usize, LandmarkObservation)> = self
            .landmarks_in_world
            .iter()
            .enumerate()
            .filter(|&(i, _)| usable(i))
            .map(|(i, &[lx, ly])| {
                let observation = LandmarkObservation {
                    range_m: (lx - x).hypot(ly - y),
                    bearing_rad: wrap_angle_rad((ly - y).atan2(lx - x) - theta),
                    diameter_m: None,
                };
                (i, observation)
            })
            .filter(|(_, observation)| observation.range_m <= MAX_RANGE_M)
            .collect();
        seen.sort_by(|a, b| a.1.range_m.total_cmp(&b.1.range_m));
        seen.truncate(OBSERVATIONS_PER_SCAN);
        seen
    }

    /// A filter at the start of the road with local maps of `max_landmarks_per_local_map`,
    /// whose motion and sensor models trust the exact odometry and observations.
    fn filter(&self, max_landmarks_per_local_map: usize) -> SubmapSlam<DifferentialDriveModel> {
        SubmapSlam::new(
            DifferentialDriveModel {
                sigma_speed_mps: 0.005,
                sigma_yaw_rate_radps: 0.1f64.to_radians(),
                sigma_speed_per_speed: 0.002,
                sigma_yaw_rate_per_yaw_rate: 0.002,
                ..DifferentialDriveModel::default()
            },
            RangeBearingModel {
                sigma_range_m: 0.02,
                sigma_bearing_rad: 0.2f64.to_radians(),
                ..RangeBearingModel::default()
            },
            SubmapSlamOptions {
                max_landmarks_per_local_map,
                ..SubmapSlamOptions::default()
            },
            self.start_pose_in_world(),
        )
    }
}

/// The true run down an avenue: the robot's pose and the trees it has observed so far.
struct Drive<'a> {
    avenue: &'a Avenue,
    pose_in_world: Pose2,
    observed: Vec<bool>,
}

impl Drive<'_> {
    /// The robot at the start, nothing observed yet.
    fn new(avenue: &Avenue) -> Drive<'_> {
        Drive {
            avenue,
            pose_in_world: avenue.start_pose_in_world(),
            observed: vec![false; avenue.landmarks_in_world.len()],
        }
    }

    /// Moves the robot one step.
    fn advance(&mut self) {
        self.pose_in_world = self.avenue.step(self.pose_in_world);
    }

    /// The scan from the current pose, with at most `max_new` trees not observed before
    /// (the nearest ones).
    fn scan(&mut self, max_new: usize) -> Vec<LandmarkObservation> {
        let mut new = 0;
        let mut scan = Vec::with_capacity(OBSERVATIONS_PER_SCAN);
        for (i, observation) in self.avenue.scan(self.pose_in_world, |_| true) {
            if !self.observed[i] {
                if new == max_new {
                    continue;
                }
                new += 1;
                self.observed[i] = true;
            }
            scan.push(observation);
        }
        scan
    }

    /// The scan from the current pose restricted to trees already observed.
    fn scan_of_observed(&self) -> Vec<LandmarkObservation> {
        self.avenue
            .scan(self.pose_in_world, |i| self.observed[i])
            .into_iter()
            .map(|(_, observation)| observation)
            .collect()
    }
}

/// A global EKF that holds `landmark_count` landmarks, and the odometry and the observations
/// (of mapped landmarks only) of its next step.
fn global_filter_holding(
    landmark_count: usize,
) -> (
    SubmapSlam<DifferentialDriveModel>,
    DifferentialDriveInput,
    Vec<LandmarkObservation>,
) {
    let avenue = Avenue::new(BUILD_LANDMARKS, BUILD_STEP_M);
    let input = avenue.odometry();
    let mut filter = avenue.filter(usize::MAX);
    let mut drive = Drive::new(&avenue);
    filter.observe(&drive.scan(landmark_count));
    while filter.local_landmark_count() < landmark_count {
        drive.advance();
        filter.predict(&input, DT_S);
        filter.observe(&drive.scan(landmark_count - filter.local_landmark_count()));
    }
    assert_eq!(
        filter.local_landmark_count(),
        landmark_count,
        "every observed tree is mapped once"
    );
    drive.advance();
    (filter, input, drive.scan_of_observed())
}

fn bench_update(c: &mut Criterion) {
    let mut group = c.benchmark_group("ekf_update");
    group.sample_size(20);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(3));
    for &landmark_count in LANDMARK_COUNTS {
        let (filter, input, observations) = global_filter_holding(landmark_count);
        let mut check = filter.clone();
        check.predict(&input, DT_S);
        let report = check.observe(&observations);
        assert_eq!(
            (report.associated, report.new_landmarks),
            (OBSERVATIONS_PER_SCAN, 0),
            "every observation of the timed step pairs with a mapped landmark"
        );
        group.bench_with_input(
            BenchmarkId::new("landmarks", landmark_count),
            &(filter, input, observations),
            |b, (filter, input, observations)| {
                b.iter_batched(
                    || filter.clone(),
                    |mut filter| {
                        filter.predict(input, DT_S);
                        let report = filter.observe(black_box(observations));
                        // Returned so that freeing the covariance is not timed.
                        (filter, report)
                    },
                    BatchSize::LargeInput,
                );
            },
        );
    }
    group.finish();
}

/// Runs a filter with local maps of `max_landmarks_per_local_map` over `first_scan` and then
/// one predict and one observe per scan of `scans`.
fn run(
    avenue: &Avenue,
    max_landmarks_per_local_map: usize,
    first_scan: &[LandmarkObservation],
    scans: &[Vec<LandmarkObservation>],
) -> SubmapSlam<DifferentialDriveModel> {
    let input = avenue.odometry();
    let mut filter = avenue.filter(max_landmarks_per_local_map);
    filter.observe(first_scan);
    for scan in scans {
        filter.predict(&input, DT_S);
        filter.observe(scan);
    }
    filter
}

fn bench_run(c: &mut Criterion) {
    let avenue = Avenue::new(RUN_LANDMARKS, RUN_STEP_M);
    assert!(
        avenue.steps_per_lap() < RUN_STEPS,
        "the run comes back onto its start"
    );
    let mut drive = Drive::new(&avenue);
    let first_scan = drive.scan(usize::MAX);
    let scans: Vec<Vec<LandmarkObservation>> = (0..RUN_STEPS)
        .map(|_| {
            drive.advance();
            drive.scan(usize::MAX)
        })
        .collect();

    let variants = [("global", usize::MAX), ("submaps", SUBMAP_LANDMARKS)];
    for (name, max_landmarks_per_local_map) in variants {
        let filter = run(&avenue, max_landmarks_per_local_map, &first_scan, &scans);
        let (estimate_in_world, _) = filter.pose_in_map();
        let truth_in_world = drive.pose_in_world;
        let stats = filter.stats();
        println!(
            "{name}: {} landmarks in the global map and {} in the open local map, \
             {} associations, {} joins, {} loop closures, final position error {:.3} m",
            filter.global_landmark_count(),
            filter.local_landmark_count(),
            stats.observations.associated,
            stats.joins,
            stats.loop_closures,
            (estimate_in_world.x_m - truth_in_world.x_m)
                .hypot(estimate_in_world.y_m - truth_in_world.y_m)
        );
    }

    let mut group = c.benchmark_group("ekf_step");
    group.sample_size(10);
    group.sampling_mode(SamplingMode::Flat);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(5));
    group.throughput(Throughput::Elements(RUN_STEPS as u64));
    for (name, max_landmarks_per_local_map) in variants {
        group.bench_function(BenchmarkId::new("global_vs_submaps", name), |b| {
            b.iter(|| {
                run(
                    &avenue,
                    max_landmarks_per_local_map,
                    black_box(&first_scan),
                    black_box(&scans),
                )
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_update, bench_run);
criterion_main!(benches);
