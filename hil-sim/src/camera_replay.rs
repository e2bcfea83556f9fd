//! `hil-sim replay-camera`: the camera method ([`host::camera::MonoSlam`]) over a recorded
//! sequence (KITTI or TUM layout), with the trajectory, the map, a picture of what it tracked
//! and, where the folder has ground truth, the error after a similarity alignment.

use std::collections::HashSet;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use host::camera::sequence::TruePose;
use host::camera::{
    CameraSequence, FrameReport, MonoSlam, MonoSlamOptions, SequenceError, TargetError,
    TrajectoryError, parse_known_target, trajectory_error,
};
use image::{GrayImage, Rgb, RgbImage};
use nalgebra::{UnitQuaternion, Vector3};
use serde::Serialize;

/// What to replay and where to write.
#[derive(Clone, Debug)]
pub struct CameraReplayOptions {
    pub sequence: PathBuf,
    pub out: PathBuf,
    /// Only the first N frames.
    pub first_frames: Option<usize>,
    /// A known target file (see [`host::camera::known_target`]).
    pub target: Option<PathBuf>,
    pub slam: MonoSlamOptions,
    /// Show a progress bar on stderr.
    pub progress: bool,
}

/// The run's `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct CameraReplaySummary {
    pub sequence: PathBuf,
    pub frames: usize,
    pub wall_s: f64,
    pub frames_per_second: f64,
    /// Mean features that updated the filter per frame.
    pub features_measured_per_frame: f64,
    /// Mean features searched for per frame.
    pub features_searched_per_frame: f64,
    pub features_added: usize,
    pub features_deleted: usize,
    pub features_converted_to_euclidean: usize,
    /// Matches that 1-point RANSAC and the rescue refused.
    pub matches_rejected: usize,
    /// Features deleted as moving: matched, but refused by the consensus frame after frame.
    pub features_rejected_as_moving: usize,
    /// Corners not taken as features because they moved on their own between two frames.
    pub corners_rejected_as_moving: usize,
    /// Corners of the known target the run started from.
    pub target_corners: Option<usize>,
    /// Local maps the run made (each at most `max_features` features).
    pub local_maps: usize,
    /// Places of earlier local maps the history memory recognised, and those it tested and
    /// refused.
    pub places_recognised: usize,
    pub places_refused: usize,
    /// Features of earlier local maps tracked again.
    pub features_recalled: usize,
    /// Features in the final map.
    pub map_points: usize,
    /// With the movers' masks of a rendered sequence (`movers/`, see `render-camera`): the
    /// features started on a pixel that saw a mover, and the points of the final map that
    /// were.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub features_started_on_movers: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub map_points_on_movers: Option<usize>,
    /// The forward-motion prior's sideslip, degrees (standard deviation), when the camera
    /// was taken to look forward from a vehicle.
    pub sideslip_sigma_deg: Option<f64>,
    /// Against the folder's ground truth, after the best similarity transform.
    pub error: Option<ErrorSummary>,
}

/// [`TrajectoryError`] as written.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ErrorSummary {
    pub poses: usize,
    pub ate_rmse_m: f64,
    /// The ATE as a share of the true path's length.
    pub ate_over_path: f64,
    pub scale: f64,
    pub rotation_error_deg: f64,
    pub true_path_m: f64,
}

impl From<TrajectoryError> for ErrorSummary {
    fn from(e: TrajectoryError) -> Self {
        ErrorSummary {
            poses: e.poses,
            ate_rmse_m: e.ate_rmse_m,
            ate_over_path: if e.true_path_m > 0.0 {
                e.ate_rmse_m / e.true_path_m
            } else {
                0.0
            },
            scale: e.scale,
            rotation_error_deg: e.rotation_error_deg,
            true_path_m: e.true_path_m,
        }
    }
}

/// What can stop a replay.
#[derive(Debug, thiserror::Error)]
pub enum CameraReplayError {
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    #[error("{path}: {source}")]
    Target { path: PathBuf, source: TargetError },
    #[error("{path}: {source}")]
    Read { path: PathBuf, source: io::Error },
    #[error("{path}: {source}")]
    Write { path: PathBuf, source: io::Error },
}

fn write_error(path: &Path) -> impl FnOnce(io::Error) -> CameraReplayError + '_ {
    move |source| CameraReplayError::Write {
        path: path.to_path_buf(),
        source,
    }
}

/// A progress bar over `frames` frames on stderr, hidden unless `shown`.
pub fn frames_bar(frames: usize, shown: bool) -> indicatif::ProgressBar {
    let bar = if shown {
        indicatif::ProgressBar::new(frames as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} frames, {per_sec}, {eta} left",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// Frames drawn into `tracks.png`: four spread over the run.
fn drawn_frames(frames: usize) -> [usize; 4] {
    let last = frames.saturating_sub(1);
    [last / 4, last / 2, 3 * last / 4, last]
}

/// Runs the camera method over the sequence and writes `OUT/trajectory.tum`,
/// `OUT/map.ply`, `OUT/tracks.png` and `OUT/summary.json`.
///
/// # Errors
/// A sequence that cannot be read, or an output that cannot be written.
pub fn replay_camera(
    options: &CameraReplayOptions,
) -> Result<CameraReplaySummary, CameraReplayError> {
    let sequence = CameraSequence::open(&options.sequence)?;
    let frames = options
        .first_frames
        .map_or(sequence.frames.len(), |n| n.min(sequence.frames.len()));
    fs::create_dir_all(&options.out).map_err(write_error(&options.out))?;
    let mut slam = MonoSlam::new(sequence.camera, options.slam);
    let target = match &options.target {
        Some(path) => {
            let text = fs::read_to_string(path).map_err(|source| CameraReplayError::Read {
                path: path.clone(),
                source,
            })?;
            let target = parse_known_target(&text).map_err(|source| CameraReplayError::Target {
                path: path.clone(),
                source,
            })?;
            if frames > 0 {
                slam.add_target(&sequence.load(0)?, &target)
                    .map_err(|source| CameraReplayError::Target {
                        path: path.clone(),
                        source,
                    })?;
            }
            Some(target.corners.len())
        }
        None => None,
    };
    let bar = frames_bar(frames, options.progress);
    let drawn = drawn_frames(frames);
    let mut pictures: Vec<RgbImage> = Vec::new();
    let mut reports: Vec<FrameReport> = Vec::with_capacity(frames);
    let masks = options.sequence.join("movers");
    let masks = masks.is_dir().then_some(masks);
    let mut started_on_movers: HashSet<(usize, [i64; 2])> = HashSet::new();
    let start = Instant::now();
    for index in 0..frames {
        let image = sequence.load(index)?;
        let report = slam.process(sequence.frames[index].time_s, &image);
        if let Some(masks) = &masks {
            let mask = mover_mask(masks, &sequence.frames[index].path)?;
            for pixel in &report.added_pixels {
                let at = [pixel[0].round() as i64, pixel[1].round() as i64];
                let on_mover = u32::try_from(at[0])
                    .ok()
                    .zip(u32::try_from(at[1]).ok())
                    .and_then(|(x, y)| mask.get_pixel_checked(x, y))
                    .is_some_and(|v| v[0] > 127);
                if on_mover {
                    started_on_movers.insert((index, at));
                }
            }
        }
        if drawn.contains(&index) && pictures.len() < drawn.len() {
            pictures.push(draw_tracks(&image, &slam));
        }
        reports.push(report);
        bar.inc(1);
    }
    let wall_s = start.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let trajectory_path = options.out.join("trajectory.tum");
    write_trajectory(&trajectory_path, &reports).map_err(write_error(&trajectory_path))?;
    let map_points = slam.map_points();
    let map_points_on_movers = masks.as_ref().map(|_| {
        slam.map_sightings()
            .into_iter()
            .filter(|(frame, pixel)| {
                started_on_movers
                    .contains(&(*frame, [pixel[0].round() as i64, pixel[1].round() as i64]))
            })
            .count()
    });
    let map_path = options.out.join("map.ply");
    write_ply(&map_path, &map_points).map_err(write_error(&map_path))?;
    let tracks_path = options.out.join("tracks.png");
    stack(&pictures)
        .save(&tracks_path)
        .map_err(|e| CameraReplayError::Write {
            path: tracks_path.clone(),
            source: io::Error::other(e),
        })?;

    let error = {
        let pairs = associate(&reports, &sequence.truth);
        let (estimate, truth): (Vec<_>, Vec<_>) = pairs.into_iter().unzip();
        trajectory_error(&estimate, &truth).map(ErrorSummary::from)
    };
    let stats = slam.stats();
    let per_frame = |n: usize| n as f64 / frames.max(1) as f64;
    let summary = CameraReplaySummary {
        sequence: options.sequence.clone(),
        frames,
        wall_s,
        frames_per_second: frames as f64 / wall_s.max(1e-9),
        features_measured_per_frame: per_frame(stats.measured),
        features_searched_per_frame: per_frame(reports.iter().map(|r| r.searched).sum()),
        features_added: stats.added,
        features_deleted: stats.deleted,
        features_converted_to_euclidean: stats.converted_to_euclidean,
        matches_rejected: stats.rejected_matches,
        features_rejected_as_moving: stats.features_rejected_as_moving,
        corners_rejected_as_moving: stats.corners_rejected_as_moving,
        target_corners: target,
        local_maps: stats.local_maps,
        places_recognised: stats.places_recognised,
        places_refused: stats.places_refused,
        features_recalled: stats.features_recalled,
        map_points: map_points.len(),
        features_started_on_movers: masks.as_ref().map(|_| started_on_movers.len()),
        map_points_on_movers,
        sideslip_sigma_deg: options
            .slam
            .forward_motion
            .map(|prior| (prior.sideslip_sigma_rad.to_degrees() * 1e9).round() / 1e9),
        error,
    };
    let summary_path = options.out.join("summary.json");
    let json = serde_json::to_string_pretty(&summary).map_err(io::Error::other);
    json.and_then(|j| fs::write(&summary_path, j + "\n"))
        .map_err(write_error(&summary_path))?;
    Ok(summary)
}

/// The movers' mask of the frame whose image is `image_path`: the file of the same name in
/// `masks`.
fn mover_mask(masks: &Path, image_path: &Path) -> Result<GrayImage, CameraReplayError> {
    let path = masks.join(image_path.file_name().unwrap_or_default());
    image::open(&path)
        .map(|i| i.into_luma8())
        .map_err(|e| CameraReplayError::Read {
            path,
            source: io::Error::other(e),
        })
}

type Pose = (Vector3<f64>, UnitQuaternion<f64>);

/// Each estimated pose with the true pose at its time (within 20 ms), in order.
fn associate(reports: &[FrameReport], truth: &[TruePose]) -> Vec<(Pose, Pose)> {
    reports
        .iter()
        .filter_map(|r| {
            let at = truth.partition_point(|t| t.time_s < r.time_s);
            let nearest = [at.checked_sub(1), Some(at)]
                .into_iter()
                .flatten()
                .filter_map(|i| truth.get(i))
                .min_by(|a, b| {
                    (a.time_s - r.time_s)
                        .abs()
                        .total_cmp(&(b.time_s - r.time_s).abs())
                })?;
            ((nearest.time_s - r.time_s).abs() <= 0.02).then_some((
                (r.position_m, r.orientation),
                (nearest.position_m, nearest.orientation),
            ))
        })
        .collect()
}

/// `t tx ty tz qx qy qz qw` per frame (TUM format).
fn write_trajectory(path: &Path, reports: &[FrameReport]) -> io::Result<()> {
    let mut out = BufWriter::new(fs::File::create(path)?);
    for r in reports {
        let (p, q) = (r.position_m, r.orientation);
        writeln!(
            out,
            "{:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6}",
            r.time_s, p.x, p.y, p.z, q.i, q.j, q.k, q.w
        )?;
    }
    out.flush()
}

/// The map's points as an ASCII PLY.
fn write_ply(path: &Path, points: &[Vector3<f64>]) -> io::Result<()> {
    let mut out = BufWriter::new(fs::File::create(path)?);
    writeln!(
        out,
        "ply\nformat ascii 1.0\nelement vertex {}",
        points.len()
    )?;
    writeln!(
        out,
        "property float x\nproperty float y\nproperty float z\nend_header"
    )?;
    for p in points {
        writeln!(out, "{:.5} {:.5} {:.5}", p.x, p.y, p.z)?;
    }
    out.flush()
}

/// The frame with each feature in view: its predicted pixel and its 3σ search ellipse (red),
/// and each corner found moving on its own, with the way it came (blue).
fn draw_tracks(image: &GrayImage, slam: &MonoSlam) -> RgbImage {
    let mut picture = RgbImage::from_fn(image.width(), image.height(), |x, y| {
        let v = image.get_pixel(x, y)[0];
        Rgb([v, v, v])
    });
    let colour = Rgb([255, 40, 40]);
    for (pixel, covariance) in slam.feature_ellipses() {
        let centre = (pixel[0].round() as i32, pixel[1].round() as i32);
        imageproc::drawing::draw_cross_mut(&mut picture, colour, centre.0, centre.1);
        // The ellipse's axes from the covariance's eigen-decomposition, drawn as a polygon.
        let eigen = covariance.symmetric_eigen();
        let axis = |k: usize| -> [f64; 2] {
            let scale = 3.0 * eigen.eigenvalues[k].max(0.0).sqrt();
            [
                eigen.eigenvectors[(0, k)] * scale,
                eigen.eigenvectors[(1, k)] * scale,
            ]
        };
        let (a, b) = (axis(0), axis(1));
        let points: Vec<(f32, f32)> = (0..=32)
            .map(|i| {
                let t = f64::from(i) / 32.0 * std::f64::consts::TAU;
                let (s, c) = t.sin_cos();
                (
                    (pixel[0] + c * a[0] + s * b[0]) as f32,
                    (pixel[1] + c * a[1] + s * b[1]) as f32,
                )
            })
            .collect();
        for pair in points.windows(2) {
            imageproc::drawing::draw_line_segment_mut(&mut picture, pair[0], pair[1], colour);
        }
    }
    let blue = Rgb([40, 120, 255]);
    for &(now, before) in slam.moving_corners() {
        let (x, y) = (now[0].round() as i32, now[1].round() as i32);
        imageproc::drawing::draw_hollow_rect_mut(
            &mut picture,
            imageproc::rect::Rect::at(x - 4, y - 4).of_size(9, 9),
            blue,
        );
        imageproc::drawing::draw_line_segment_mut(
            &mut picture,
            (now[0] as f32, now[1] as f32),
            (before[0] as f32, before[1] as f32),
            blue,
        );
    }
    picture
}

/// The pictures one above the other.
fn stack(pictures: &[RgbImage]) -> RgbImage {
    let width = pictures.iter().map(RgbImage::width).max().unwrap_or(1);
    let height = pictures.iter().map(RgbImage::height).sum::<u32>().max(1);
    let mut out = RgbImage::new(width, height);
    let mut top = 0;
    for picture in pictures {
        image::imageops::replace(&mut out, picture, 0, i64::from(top));
        top += picture.height();
    }
    out
}
