//! `hil-sim nees --method camera`: the consistency of the camera method's filter, measured by
//! Monte-Carlo runs in rendered worlds.
//!
//! Run `r` renders the world of seed `seed + r` (each run its own park, so the runs are
//! independent) as the camera on the robot sees it ([`CameraView`]) and runs the camera
//! method ([`MonoSlam`]) on the frames as they are rendered, with nothing written to disk.
//! At every frame the camera's orientation error is compared with the covariance the filter
//! claims for it, as the NEES `eᵀ P⁻¹ e` (three degrees of freedom), and averaged over the
//! runs, against the two-sided 95 % bounds of `χ²(3 N) / N`: a consistent filter stays within
//! them on about 95 % of the frames (Bar-Shalom, Li and Kirubarajan, "Estimation with
//! Applications to Tracking and Navigation", §5.4), and the product's target is 90 %.
//!
//! What is tested is what the filter estimates: the camera relative to its current local
//! map's origin. That is the camera where the map started, its pose exact there (so the
//! frame a map starts in is not counted), or, for a camera held level
//! ([`host::camera::LevelPrior`]), the level frame of its heading there: the heading is
//! relative to the map's start, the tilt from level absolute, with its uncertainty. The
//! position is left out: a single camera measures it only up to a scale the filter does not
//! observe, so its error is no test of the covariance.

use std::collections::HashMap;
use std::sync::Arc;

use host::camera::{
    CameraPipelineOptions, MeasuredFeature, MonoSlam, MonoSlamOptions, level_frame,
};
use nalgebra::{Matrix3, UnitQuaternion};
use serde::Serialize;

use crate::landmark_sim::chi_square_bounds;
use crate::world::{CameraRigOptions, CameraView, Mover, RobotState, Scenario, Walkers, WorldKind};

/// Confidence of the NEES bounds.
const CONFIDENCE: f64 = 0.95;

/// What to run.
#[derive(Clone, Debug)]
pub struct CameraNeesOptions {
    pub world: WorldKind,
    /// Monte-Carlo runs.
    pub runs: usize,
    /// The first run's world seed; run `r` renders the world of `seed + r`.
    pub seed: u64,
    /// Length of each run, s.
    pub duration_s: f64,
    /// Frames per second.
    pub rate_hz: f64,
    /// Walkers about the route.
    pub movers: usize,
    pub rig: CameraRigOptions,
    pub slam: MonoSlamOptions,
    /// Refuse every match farther than this from where the rendered truth puts its feature,
    /// px: the camera method with a front end that never errs by more than this, to measure
    /// what the larger errors cost. `None` (the default) refuses nothing.
    pub truth_gate_px: Option<f64>,
    /// Draw a progress bar on stderr.
    pub progress: bool,
}

impl Default for CameraNeesOptions {
    /// Outdoor, 10 runs of 10 s at 10 Hz from seed 1, no walkers, the default rig, and the
    /// camera method as the robot runs it (held level, [`CameraPipelineOptions`]).
    fn default() -> Self {
        CameraNeesOptions {
            world: WorldKind::Outdoor,
            runs: 10,
            seed: 1,
            duration_s: 10.0,
            rate_hz: 10.0,
            movers: 0,
            rig: CameraRigOptions::default(),
            slam: CameraPipelineOptions::default().slam,
            truth_gate_px: None,
            progress: false,
        }
    }
}

/// The result, printed as JSON.
#[derive(Clone, Debug, Serialize)]
pub struct CameraNeesReport {
    pub runs: usize,
    pub frames_per_run: usize,
    /// The 95 % bounds of the run-averaged NEES with every run counted.
    pub bounds: (f64, f64),
    /// Fraction of frames whose run-averaged camera-orientation NEES of the camera method
    /// lies within the 95 % bounds.
    pub camera_fraction_within: f64,
    /// Fraction of frames whose run-averaged NEES lies above the upper bound (the filter too
    /// sure).
    pub camera_fraction_above: f64,
    /// The run-averaged NEES's median over the frames (3 for a consistent filter).
    pub camera_median_nees: f64,
    /// Frames where at least one run's NEES was tested (a local map's first frame is not).
    pub frames_tested: usize,
    /// The run-averaged NEES at each frame (`null` where no run was tested), to plot against
    /// the bounds.
    pub camera_nees_by_frame: Vec<Option<f64>>,
    /// The same three for the filter told the true association and given the world's own
    /// points with the pixel noise it assumes ([`crate::camera_ideal`]), on the same runs:
    /// what the test yields for the filter itself, with a perfect front end.
    pub ideal_fraction_within: f64,
    pub ideal_fraction_above: f64,
    pub ideal_median_nees: f64,
    /// The ideal filter's run-averaged NEES at each frame.
    pub ideal_nees_by_frame: Vec<Option<f64>>,
    /// How far the matches that updated the camera method's filter lay from the truth, over
    /// every run ([`MatchErrors`]).
    pub camera_match_errors: MatchErrors,
    /// Each run's mean camera-orientation error in the world (first camera) frame, degrees.
    pub camera_rotation_error_deg: Vec<f64>,
    /// Each run's local maps.
    pub camera_local_maps: Vec<usize>,
    /// Each run's places recognised by the history memory (their features come back into
    /// the filter without their correlations with the camera).
    pub camera_places_recognised: Vec<usize>,
}

/// The front end's errors: each match that updated the filter against the pixel where the
/// camera, at its true pose, sees the point the feature was first seen on (the rendered
/// world's own geometry, [`CameraView::point_seen`]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct MatchErrors {
    /// Matches scored.
    pub matches: usize,
    /// The distance's median, 90th and 99th percentiles, px.
    pub median_px: f64,
    pub p90_px: f64,
    pub p99_px: f64,
    /// Share of the matches more than 3 px off.
    pub share_over_3px: f64,
    /// Correlation of a feature's error (both axes) with its error in the frame before: 0
    /// for errors independent from frame to frame, as the filter assumes.
    pub frame_to_frame_correlation: f64,
}

/// The rendered truth of one run, frame by frame: where the robot was and the walkers.
struct Truth {
    view: CameraView,
    states: Vec<RobotState>,
    movers: Vec<Vec<Mover>>,
}

impl Truth {
    /// The error of `found` in frame `frame`, px: the match less the pixel where the camera,
    /// at its true pose, sees the point the feature's first pixel saw. A first sighting on
    /// an outline may see past it while its patch follows the nearer surface, so of the
    /// first pixel and the eight about it, the one whose point's image (shifted back by the
    /// same offset) lies nearest the match is taken.
    fn error_px(&self, frame: usize, found: &MeasuredFeature) -> Option<[f64; 2]> {
        let (first_frame, first_px) = found.first_sighting;
        let (seen_from, seen_at) = (self.states.get(first_frame)?, self.states.get(frame)?);
        let (position, world_from_camera) = self.view.camera_pose(seen_at);
        let mut best: Option<[f64; 2]> = None;
        for dy in [-1.0, 0.0, 1.0] {
            for dx in [-1.0, 0.0, 1.0] {
                let pixel = [first_px[0] + dx, first_px[1] + dy];
                let Some(point) = self
                    .view
                    .point_seen(seen_from, &self.movers[first_frame], pixel)
                else {
                    continue;
                };
                let in_camera = world_from_camera.inverse() * (point - position);
                let Some(image) = self.view.camera().project(&in_camera) else {
                    continue;
                };
                let error = [
                    found.pixel[0] - (image[0] - dx),
                    found.pixel[1] - (image[1] - dy),
                ];
                if best.is_none_or(|b| error[0].hypot(error[1]) < b[0].hypot(b[1])) {
                    best = Some(error);
                }
            }
        }
        best
    }
}

/// One feature's match errors: the frame and the error, px, in the order measured.
type TrackErrors = Vec<(usize, [f64; 2])>;

/// [`MatchErrors`] from each run's features' errors.
fn match_errors(runs: &[Vec<TrackErrors>]) -> MatchErrors {
    let mut distances: Vec<f64> = runs
        .iter()
        .flatten()
        .flatten()
        .map(|(_, e)| e[0].hypot(e[1]))
        .collect();
    if distances.is_empty() {
        return MatchErrors::default();
    }
    distances.sort_by(f64::total_cmp);
    let quantile = |q: f64| distances[((distances.len() - 1) as f64 * q).round() as usize];
    let (mut product, mut before, mut after) = (0.0, 0.0, 0.0);
    for track in runs.iter().flatten() {
        for pair in track.windows(2) {
            let ((f0, e0), (f1, e1)) = (pair[0], pair[1]);
            if f1 == f0 + 1 {
                product += e0[0] * e1[0] + e0[1] * e1[1];
                before += e0[0] * e0[0] + e0[1] * e0[1];
                after += e1[0] * e1[0] + e1[1] * e1[1];
            }
        }
    }
    MatchErrors {
        matches: distances.len(),
        median_px: quantile(0.5),
        p90_px: quantile(0.9),
        p99_px: quantile(0.99),
        share_over_3px: distances.iter().filter(|&&d| d > 3.0).count() as f64
            / distances.len() as f64,
        frame_to_frame_correlation: if before > 0.0 && after > 0.0 {
            product / (before * after).sqrt()
        } else {
            0.0
        },
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CameraNeesError {
    #[error("the camera method needs the outdoor world (the indoor one has no texture to track)")]
    World,
    #[error("--runs must be at least 1")]
    Runs,
    #[error("the duration and rate must be positive and give at least two frames")]
    Frames,
    #[error("{0} frames a run are more than the {max} a sequence may hold", max = crate::camera_render::MAX_FRAMES)]
    TooManyFrames(f64),
    #[error("seed {0} and {1} runs run past the largest seed")]
    Seed(u64, usize),
}

/// One run's NEES per frame (`None` where it is not tested) and its errors.
struct RunResult {
    camera: Vec<Option<f64>>,
    ideal: Vec<Option<f64>>,
    rotation_error_deg: f64,
    local_maps: usize,
    places_recognised: usize,
    /// Each feature's match errors.
    match_errors: Vec<TrackErrors>,
}

/// Runs the Monte-Carlo runs. See the [module documentation](self).
///
/// # Errors
/// The indoor world, no runs, a duration and rate that give fewer than two frames or more
/// than a day's, or seeds past the largest.
pub fn run_camera_nees(options: &CameraNeesOptions) -> Result<CameraNeesReport, CameraNeesError> {
    if options.world != WorldKind::Outdoor {
        return Err(CameraNeesError::World);
    }
    if options.runs == 0 {
        return Err(CameraNeesError::Runs);
    }
    let periods = options.duration_s * options.rate_hz;
    if !(periods.is_finite() && periods >= 1.0 && options.rate_hz > 0.0) {
        return Err(CameraNeesError::Frames);
    }
    let frames = crate::camera_render::frame_count(options.duration_s, options.rate_hz)
        .map_err(CameraNeesError::TooManyFrames)?;
    if options.seed.checked_add(options.runs as u64 - 1).is_none() {
        return Err(CameraNeesError::Seed(options.seed, options.runs));
    }
    let bar = crate::camera_replay::frames_bar(frames * options.runs, options.progress);
    let results: Vec<RunResult> = (0..options.runs)
        .map(|run| run_one(options, options.seed + run as u64, frames, &bar))
        .collect();
    bar.finish_and_clear();

    let camera: Vec<&[Option<f64>]> = results.iter().map(|r| r.camera.as_slice()).collect();
    let camera = fractions(&camera, frames);
    let ideal: Vec<&[Option<f64>]> = results.iter().map(|r| r.ideal.as_slice()).collect();
    let ideal = fractions(&ideal, frames);
    Ok(CameraNeesReport {
        runs: options.runs,
        frames_per_run: frames,
        bounds: chi_square_bounds(3, options.runs, CONFIDENCE).unwrap_or((0.0, f64::INFINITY)),
        camera_fraction_within: camera.within,
        camera_fraction_above: camera.above,
        camera_median_nees: camera.median,
        frames_tested: camera.tested,
        camera_nees_by_frame: camera.by_frame,
        ideal_fraction_within: ideal.within,
        ideal_fraction_above: ideal.above,
        ideal_median_nees: ideal.median,
        ideal_nees_by_frame: ideal.by_frame,
        camera_match_errors: match_errors(
            &results
                .iter()
                .map(|r| r.match_errors.clone())
                .collect::<Vec<_>>(),
        ),
        camera_rotation_error_deg: results.iter().map(|r| r.rotation_error_deg).collect(),
        camera_local_maps: results.iter().map(|r| r.local_maps).collect(),
        camera_places_recognised: results.iter().map(|r| r.places_recognised).collect(),
    })
}

/// Of the frames where at least one run tested the NEES: the fraction whose run-averaged
/// NEES lies within the bounds for the runs counted there, the fraction above them, the
/// median of the run-averaged NEES, and how many frames were tested.
pub(crate) fn fractions(runs: &[&[Option<f64>]], frames: usize) -> Fractions {
    let mut tested = 0usize;
    let mut within = 0usize;
    let mut above = 0usize;
    let mut averages = Vec::with_capacity(frames);
    let mut by_frame = vec![None; frames];
    for (frame, by_frame) in by_frame.iter_mut().enumerate() {
        let values: Vec<f64> = runs
            .iter()
            .filter_map(|r| r.get(frame).copied().flatten())
            .collect();
        let Some((low, high)) = chi_square_bounds(3, values.len(), CONFIDENCE) else {
            continue;
        };
        let average = values.iter().sum::<f64>() / values.len() as f64;
        tested += 1;
        if average > high {
            above += 1;
        } else if average >= low {
            within += 1;
        }
        averages.push(average);
        *by_frame = Some(average);
    }
    averages.sort_by(f64::total_cmp);
    let median = averages
        .get(averages.len() / 2)
        .copied()
        .unwrap_or(f64::NAN);
    let share = |n: usize| n as f64 / tested.max(1) as f64;
    Fractions {
        within: share(within),
        above: share(above),
        median,
        tested,
        by_frame,
    }
}

/// What [`fractions`] finds: the shares of the tested frames within and above the bounds,
/// the median run-averaged NEES, the frames tested, and the run-averaged NEES by frame.
pub(crate) struct Fractions {
    pub(crate) within: f64,
    above: f64,
    median: f64,
    tested: usize,
    by_frame: Vec<Option<f64>>,
}

/// `eᵀ P⁻¹ e` for the orientation error `δ` with `truth = exp(δ) · estimate` (about the
/// world axes, as [`host::camera::MonoEkf::orientation_covariance`] gives `P`); `None`
/// where `P` cannot be inverted (the pose exact, as where a local map starts).
pub(crate) fn orientation_nees(
    estimate: &UnitQuaternion<f64>,
    truth: &UnitQuaternion<f64>,
    covariance: &Matrix3<f64>,
) -> Option<f64> {
    // Where a local map starts its heading is exact (and, for a camera not held level, its
    // whole orientation): a direction of variance at rounding's size tests nothing.
    if covariance.symmetric_eigenvalues().min() < 1e-12 {
        return None;
    }
    let error = (truth * estimate.inverse()).scaled_axis();
    let inverse = covariance.try_inverse()?;
    Some((error.transpose() * inverse * error)[(0, 0)])
}

/// One run: the world of `seed`, rendered and run through the camera method.
fn run_one(
    options: &CameraNeesOptions,
    seed: u64,
    frames: usize,
    bar: &indicatif::ProgressBar,
) -> RunResult {
    let scenario = Scenario::generate_for(options.world, seed, options.duration_s);
    let walkers = Walkers::new(&scenario, options.movers, seed);
    let rendered = Arc::new(Truth {
        view: CameraView::new(&scenario, options.rig),
        states: (0..frames)
            .map(|f| scenario.pose_at(f as f64 / options.rate_hz))
            .collect(),
        movers: (0..frames)
            .map(|f| walkers.at(f as f64 / options.rate_hz))
            .collect(),
    });
    let view = &rendered.view;
    let mut slam = MonoSlam::new(*view.camera(), options.slam);
    if let Some(gate_px) = options.truth_gate_px {
        let rendered = Arc::clone(&rendered);
        slam.check_matches_with(move |frame, found| {
            rendered
                .error_px(frame, found)
                .is_some_and(|e| e[0].hypot(e[1]) <= gate_px)
        });
    }
    // By first sighting: its frame and pixel (bits).
    let mut tracks: HashMap<(usize, [u64; 2]), TrackErrors> = HashMap::new();
    // `world_from_camera` at the first frame, and where the current local map started.
    let first = view.camera_pose(&rendered.states[0]).1;
    let mut origin = first;
    let mut camera_nees = Vec::with_capacity(frames);
    let mut local_maps = 1;
    let mut rotation_error_rad = 0.0;
    for frame in 0..frames {
        let t_s = frame as f64 / options.rate_hz;
        let state = &rendered.states[frame];
        let (_, truth) = view.camera_pose(state);
        let image = view.render(state, &rendered.movers[frame], frame as u64);
        let report = slam.process(t_s, &image);
        for found in &report.measurements {
            if let Some(error) = rendered.error_px(frame, found) {
                let (first_frame, first_px) = found.first_sighting;
                tracks
                    .entry((first_frame, first_px.map(f64::to_bits)))
                    .or_default()
                    .push((frame, error));
            }
        }
        if slam.stats().local_maps != local_maps {
            local_maps = slam.stats().local_maps;
            // The map's frame: the camera there or, held level, the level frame of its
            // heading (in the first camera's frame, whose y axis is down).
            origin = match options.slam.level {
                Some(_) => first * level_frame(first.inverse() * truth),
                None => truth,
            };
        }
        let filter = slam.filter();
        camera_nees.push(orientation_nees(
            &filter.orientation(),
            &(origin.inverse() * truth),
            &filter.orientation_covariance(),
        ));
        rotation_error_rad += report.orientation.angle_to(&(first.inverse() * truth));
        bar.inc(1);
    }
    let ideal = crate::camera_ideal::ideal_orientation_nees(
        &scenario,
        view,
        &options.slam,
        frames,
        options.rate_hz,
        seed,
    );
    RunResult {
        camera: camera_nees,
        ideal: ideal.into_iter().map(|(nees, _)| nees).collect(),
        rotation_error_deg: (rotation_error_rad / frames as f64).to_degrees(),
        local_maps,
        places_recognised: slam.stats().places_recognised,
        match_errors: tracks.into_values().collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn a_rotation_error_as_large_as_its_standard_deviation_scores_one_per_axis() {
        let truth = UnitQuaternion::from_euler_angles(0.1, -0.2, 0.3);
        let error = UnitQuaternion::from_scaled_axis(Vector3::new(0.01, 0.0, 0.0));
        let estimate = error.inverse() * truth;
        let covariance = Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-6, 1e-6));
        let nees = orientation_nees(&estimate, &truth, &covariance).expect("tested");
        assert!((nees - 1.0).abs() < 1e-6, "{nees}");
        assert_eq!(orientation_nees(&estimate, &truth, &Matrix3::zeros()), None);
    }

    #[test]
    fn a_short_run_tracks_the_rendered_camera_and_reports_every_frame() {
        let options = CameraNeesOptions {
            runs: 1,
            duration_s: 1.5,
            ..CameraNeesOptions::default()
        };
        let report = run_camera_nees(&options).expect("runs");
        assert_eq!(report.frames_per_run, 16);
        // Every frame but the first map's first is tested, less any frame a map starts in.
        let maps = report.camera_local_maps[0];
        assert!(report.frames_tested >= 16 - maps, "{report:?}");
        assert!(
            report.camera_median_nees.is_finite() && report.camera_median_nees > 0.0,
            "{report:?}"
        );
        assert!(report.camera_rotation_error_deg[0] < 2.0, "{report:?}");
        let errors = &report.camera_match_errors;
        assert!(errors.matches > 50 && errors.median_px < 1.0, "{errors:?}");
        // With the truth's gate no match that updated the filter lies beyond it.
        let gated = run_camera_nees(&CameraNeesOptions {
            truth_gate_px: Some(1.0),
            ..options.clone()
        })
        .expect("runs");
        let errors = &gated.camera_match_errors;
        assert!(errors.matches > 0 && errors.p99_px <= 1.0, "{errors:?}");
        let past_the_last_seed = CameraNeesOptions {
            seed: u64::MAX,
            runs: 2,
            ..options.clone()
        };
        assert!(matches!(
            run_camera_nees(&past_the_last_seed),
            Err(CameraNeesError::Seed(..))
        ));
        let two_days = CameraNeesOptions {
            duration_s: 172_800.0,
            ..options.clone()
        };
        assert!(matches!(
            run_camera_nees(&two_days),
            Err(CameraNeesError::TooManyFrames(_))
        ));
        let indoor = CameraNeesOptions {
            world: WorldKind::Indoor,
            ..options
        };
        assert!(matches!(
            run_camera_nees(&indoor),
            Err(CameraNeesError::World)
        ));
    }

    #[test]
    fn match_errors_give_their_spread_and_how_they_carry_from_frame_to_frame() {
        let steady: TrackErrors = (0..10).map(|f| (f, [1.0, 0.0])).collect();
        let errors = match_errors(&[vec![steady]]);
        assert_eq!(errors.matches, 10);
        assert_eq!(
            (errors.median_px, errors.p99_px, errors.share_over_3px),
            (1.0, 1.0, 0.0)
        );
        assert!((errors.frame_to_frame_correlation - 1.0).abs() < 1e-12);
        let flipping: TrackErrors = (0..10)
            .map(|f| (f, [0.0, if f % 2 == 0 { 4.0 } else { -4.0 }]))
            .collect();
        let errors = match_errors(&[vec![flipping]]);
        assert_eq!(errors.share_over_3px, 1.0);
        assert!((errors.frame_to_frame_correlation + 1.0).abs() < 1e-12);
        // Frames apart are no pair; nothing measured scores nothing.
        let apart = vec![(0, [1.0, 0.0]), (2, [1.0, 0.0])];
        assert_eq!(match_errors(&[vec![apart]]).frame_to_frame_correlation, 0.0);
        assert_eq!(match_errors(&[]).matches, 0);
    }

    #[test]
    fn fractions_count_frames_inside_and_above_the_bounds() {
        // Two runs, three frames: consistent, far too sure, not tested.
        let a = [Some(3.0), Some(100.0), None];
        let b = [Some(3.0), Some(100.0), None];
        let f = fractions(&[&a, &b], 3);
        assert_eq!((f.within, f.above, f.tested), (0.5, 0.5, 2));
        assert_eq!(f.median, 100.0);
        assert_eq!(f.by_frame, [Some(3.0), Some(100.0), None]);
    }
}
