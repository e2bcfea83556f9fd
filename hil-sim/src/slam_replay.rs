//! `hil-sim replay-carmen`: method 2 ([`host::slam::GridPipeline`]) over a CARMEN laser log,
//! its map exported, and its accuracy measured on ground-truth relations when they are given.
//!
//! Outputs in the output directory:
//!
//! * `trajectory.tsv`: one line per scan, the log's timestamp exactly as printed, then
//!   `x_m y_m theta_rad` of the optimised pose (map frame: the first scan's pose) and `lost`
//!   (1 when local tracking could not place the scan, [`GridPipeline::lost`]);
//! * `map.pgm`, `map.yaml` (the ROS `map_server` format) and `map.png`: the global occupancy
//!   grid, every scan inserted at its optimised pose;
//! * `summary.json`: `scans`, `wall_s` (the SLAM's own time: tracking, loop closure, pose
//!   graph, not reading the log or writing the map), `scans_per_second`, `timing` (per-scan
//!   percentiles, the run's end, and the last 1 000 scans against the first), `slam_parts_s`
//!   (the SLAM's time by part, [`host::slam::SlamTimings`]), what the pipeline did, and the
//!   error on each set of relations given ([`host::evaluation`], Kümmerle et al. 2009); for
//!   a relations file, also which of its relations the log's own scans dispute and
//!   the error without them (`relations_agreement`, [`host::evaluation::AgreementReport`]);
//! * with [`SlamReplayOptions::check_tracking`] and a reference, `tracking_check.tsv`: for
//!   every scan, the motion tracking chose and the reference's, each with its score as a
//!   candidate ([`host::slam::TrackingCheck`]), and their count in `summary.json`
//!   (`tracking_check`): where tracking chose elsewhere, whether the search missed the
//!   reference's pose, that pose scored lower, or it scored as a pose tracking refuses.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use host::evaluation::{
    AgreementReport, PairingOptions, ReferenceRelationOptions, ReferenceRelations, Relation,
    RelationEvaluation, StampedPose, Trajectory, evaluate_relations,
};
use host::geometry::Pose2;
use host::grid::{MapExport, MapExportOptions};
use host::scan_match::Scan;
use host::slam::{
    GridPipeline, GridPipelineOptions, SlamOptions, SlamStats, SlamTimings, TrackingCheck,
    TrackingVerdict,
};
use serde::Serialize;

use crate::closure_check::ClosureCheck;
use crate::replay::{
    CarmenLog, LaserRecord, LogError, detect_no_return_from_m, read_reference, read_relations,
};

/// Cell size of the exported map, metres.
const MAP_RESOLUTION_M: f64 = 0.05;

/// What to run.
#[derive(Debug, Clone)]
pub struct SlamReplayOptions {
    /// The CARMEN log.
    pub log: PathBuf,
    /// Where the outputs go (created if missing).
    pub out: PathBuf,
    /// Use the poses the log records as odometry; `false` ignores every pose in the log.
    pub odometry: bool,
    /// Ranges at or above this are no return, metres (the logs write their maximum, e.g.
    /// 81.83 m for Intel, for "no echo"); `None` reads it from the log's ranges
    /// ([`detect_no_return_from_m`]).
    pub no_return_from_m: Option<f64>,
    /// Ground-truth relations to evaluate against (`t1 t2 x y z roll pitch yaw`).
    pub relations: Option<PathBuf>,
    /// A reference trajectory (`timestamp x y theta`) to build consecutive and revisit
    /// relations from.
    pub reference: Option<PathBuf>,
    /// The SLAM's options.
    pub slam: SlamOptions,
    /// Only the log's first this many scans (a short run); `None` takes them all.
    pub first_scans: Option<usize>,
    /// With a reference: score the reference's motion into every scan as tracking scores
    /// its candidates, and write `tracking_check.tsv` (see the [module documentation](self)).
    pub check_tracking: bool,
}

/// A motion tracking chose this far from the reference's (or farther) counts as elsewhere
/// in [`TrackingCheckSummary`]: translation (m), rotation (rad).
pub const CHOSE_ELSEWHERE_BEYOND: [f64; 2] = [0.3, 3.0 * std::f64::consts::PI / 180.0];

/// What the tracking check found ([`SlamReplayOptions::check_tracking`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct TrackingCheckSummary {
    /// Scans whose motion from the scan before the reference gives.
    pub scans_checked: usize,
    /// Of those, where tracking chose a motion farther than [`CHOSE_ELSEWHERE_BEYOND`] from
    /// the reference's.
    pub chose_elsewhere: usize,
    /// Of those, where the reference's motion scored higher than every candidate, and high
    /// enough to be taken: the search did not reach it.
    pub reference_scored_higher: usize,
    /// Of those, where it scored lower than the best candidate, though high enough to be
    /// taken: the score preferred a wrong pose.
    pub reference_scored_lower: usize,
    /// Of those, where it scored as a pose tracking refuses (at most 0): the scan fits the
    /// submap too little there to be placed at all.
    pub reference_refused: usize,
}

/// `summary.json`.
#[derive(Debug, Clone, Serialize)]
pub struct SlamReplaySummary {
    /// Scans in the log, each with a pose.
    pub scans: usize,
    /// Seconds the SLAM took.
    pub wall_s: f64,
    /// `scans / wall_s`.
    pub scans_per_second: f64,
    /// How the time was spent along the run.
    pub timing: ScanTiming,
    /// Where the SLAM's time went, part by part (wall time on this machine).
    pub slam_parts_s: SlamTimings,
    /// The log.
    pub log: String,
    /// Whether the log's poses were used as odometry.
    pub odometry: bool,
    /// Ranges at or above this were taken as no return, m (given, or read from the log).
    pub no_return_from_m: f64,
    /// What the pipeline did.
    pub slam: SlamStats,
    /// Cell size the map was drawn at, metres: the finest at which it fits whole
    /// ([`GridPipeline::global_grid`]).
    pub map_resolution_m: f64,
    /// Error on the given relations, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relations: Option<RelationEvaluation>,
    /// Which of the given relations the log's scans dispute, and the error without them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relations_agreement: Option<AgreementReport>,
    /// Error on relations between consecutive scans of the reference, if given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_consecutive: Option<RelationEvaluation>,
    /// Error on revisits of the reference (scans at least 50 apart within 2 m and 45°).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_revisits: Option<RelationEvaluation>,
    /// With a reference: the loop closures that entered the graph against the reference's
    /// relative poses, and those far from them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub closure_check: Option<ClosureCheck>,
    /// What the tracking check found, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracking_check: Option<TrackingCheckSummary>,
}

/// How a run's time was spent: whether a scan costs more as the map grows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScanTiming {
    /// Median time to add one scan, milliseconds.
    pub scan_p50_ms: f64,
    /// 99th percentile of the time to add one scan, milliseconds.
    pub scan_p99_ms: f64,
    /// The longest time to add one scan, milliseconds.
    pub scan_max_ms: f64,
    /// The end of the run: the last optimisation and the final refinement of the nodes not
    /// aligned during the run, seconds.
    pub finish_s: f64,
    /// Seconds the first 1 000 scans took (all of them in a shorter log).
    pub first_1000_scans_s: f64,
    /// Seconds the last 1 000 scans took, the end of the run included.
    pub last_1000_scans_s: f64,
    /// `last_1000_scans_s / first_1000_scans_s`, for a log of at least 2 000 scans (the two
    /// spans apart).
    pub last_to_first_1000: Option<f64>,
}

impl ScanTiming {
    /// Scans per span compared.
    const SPAN: usize = 1000;

    /// The timing of a run whose scans took `scan_s` seconds each and whose end took
    /// `finish_s`.
    pub fn of(scan_s: &[f64], finish_s: f64) -> ScanTiming {
        let mut sorted = scan_s.to_vec();
        sorted.sort_by(f64::total_cmp);
        let percentile_ms = |q: f64| {
            let index = (q * sorted.len() as f64).ceil() as usize;
            1000.0 * sorted.get(index.saturating_sub(1)).copied().unwrap_or(0.0)
        };
        let span = Self::SPAN.min(scan_s.len());
        let first_1000_scans_s = scan_s[..span].iter().sum::<f64>();
        let last_1000_scans_s = scan_s[scan_s.len() - span..].iter().sum::<f64>() + finish_s;
        ScanTiming {
            scan_p50_ms: percentile_ms(0.5),
            scan_p99_ms: percentile_ms(0.99),
            scan_max_ms: percentile_ms(1.0),
            finish_s,
            first_1000_scans_s,
            last_1000_scans_s,
            last_to_first_1000: (scan_s.len() >= 2 * Self::SPAN && first_1000_scans_s > 0.0)
                .then(|| last_1000_scans_s / first_1000_scans_s),
        }
    }
}

/// Why a replay failed.
#[derive(Debug, thiserror::Error)]
pub enum SlamReplayError {
    /// A log, relations or reference file could not be read.
    #[error(transparent)]
    Log(#[from] LogError),
    /// The log holds no laser scan.
    #[error("{0}: no laser scans")]
    NoScans(PathBuf),
    /// Odometry asked for, but the log has none.
    #[error("{0}: every pose in the log is zero (a laser-only log): run it with --odometry none")]
    NoOdometry(PathBuf),
    /// The SLAM options are invalid.
    #[error("invalid SLAM options: {0}")]
    Options(#[from] host::scan_match::ScanMatchError),
    /// An output could not be written.
    #[error("{path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: io::Error,
    },
}

/// The beam end points of `laser` in the robot frame; ranges at or above `no_return_from_m`
/// (or not positive) have no return.
pub fn scan_of(laser: &LaserRecord, no_return_from_m: f64) -> Scan {
    let ranges_m: Vec<f64> = laser
        .ranges_m
        .iter()
        .map(|&r| if r < no_return_from_m { r } else { f64::NAN })
        .collect();
    Scan::from_ranges(
        &ranges_m,
        laser.start_angle_rad,
        laser.resolution_rad,
        f64::INFINITY,
    )
}

/// Runs the SLAM over the log and writes the outputs.
///
/// # Errors
/// See [`SlamReplayError`].
pub fn replay_carmen_slam(
    options: &SlamReplayOptions,
) -> Result<SlamReplaySummary, SlamReplayError> {
    let log = CarmenLog::read(&options.log)?;
    let lasers: Vec<&LaserRecord> = log
        .lasers()
        .take(options.first_scans.unwrap_or(usize::MAX))
        .collect();
    if lasers.is_empty() {
        return Err(SlamReplayError::NoScans(options.log.clone()));
    }
    let odometry_is_zero = lasers.iter().all(|l| {
        let p = l.robot_pose;
        p.x_m == 0.0 && p.y_m == 0.0 && p.theta_rad == 0.0
    });
    if options.odometry && odometry_is_zero {
        return Err(SlamReplayError::NoOdometry(options.log.clone()));
    }
    let no_return_from_m = options
        .no_return_from_m
        .unwrap_or_else(|| detect_no_return_from_m(lasers.iter().copied()));
    let scans: Vec<Scan> = lasers
        .iter()
        .map(|l| scan_of(l, no_return_from_m))
        .collect();

    let reference: Option<Trajectory> = match &options.reference {
        Some(path) => Some(
            read_reference(path)?
                .iter()
                .map(|r| {
                    let p = r.pose;
                    StampedPose::new(r.timestamp_s, Pose2::new(p.x_m, p.y_m, p.theta_rad))
                })
                .collect(),
        ),
        None => None,
    };
    let pairing = PairingOptions::default();
    // For every scan, the reference's pose at its time (empty without a reference).
    let reference_poses: Vec<Option<Pose2>> = reference.as_ref().map_or_else(Vec::new, |r| {
        lasers
            .iter()
            .map(|l| {
                r.pose_near(l.timestamp_s, pairing.timestamp_tolerance_s)
                    .map(|p| p.pose_in_map)
            })
            .collect()
    });
    // For every scan, the reference's motion into it from the scan before, when checked.
    let motions_to_check: Vec<Option<Pose2>> = if options.check_tracking && reference.is_some() {
        std::iter::once(None)
            .chain(reference_poses.windows(2).map(|pair| match pair {
                [Some(before), Some(at)] => Some(before.inverse() * *at),
                _ => None,
            }))
            .collect()
    } else {
        Vec::new()
    };
    let mut checks: Vec<Option<TrackingCheck>> = Vec::with_capacity(motions_to_check.len());

    let started = Instant::now();
    let mut pipeline = GridPipeline::new(GridPipelineOptions {
        slam: options.slam.clone(),
        map_resolution_m: MAP_RESOLUTION_M,
        ..GridPipelineOptions::default()
    })?;
    let mut scan_s = Vec::with_capacity(scans.len());
    for (index, (laser, scan)) in lasers.iter().zip(&scans).enumerate() {
        let odometry = options.odometry.then(|| {
            let p = laser.robot_pose;
            Pose2::new(p.x_m, p.y_m, p.theta_rad)
        });
        let motion_to_check = motions_to_check.get(index).copied().flatten();
        if let Some(motion) = motion_to_check {
            pipeline.check_next_motion(motion);
        }
        let adding = Instant::now();
        pipeline.add_scan(laser.timestamp_s, scan, odometry);
        scan_s.push(adding.elapsed().as_secs_f64());
        if !motions_to_check.is_empty() {
            checks.push(motion_to_check.and(pipeline.last_check().copied()));
        }
    }
    let finishing = Instant::now();
    pipeline.finish();
    let timing = ScanTiming::of(&scan_s, finishing.elapsed().as_secs_f64());
    let wall_s = started.elapsed().as_secs_f64();
    let poses_in_map = pipeline.poses_in_map();

    let write_error = |path: &Path| {
        let path = path.to_path_buf();
        move |source| SlamReplayError::Write { path, source }
    };
    fs::create_dir_all(&options.out).map_err(write_error(&options.out))?;
    let trajectory_path = options.out.join("trajectory.tsv");
    write_trajectory(&trajectory_path, &lasers, &poses_in_map, pipeline.lost())
        .map_err(write_error(&trajectory_path))?;
    let tracking_check = if motions_to_check.is_empty() {
        None
    } else {
        let path = options.out.join("tracking_check.tsv");
        write_tracking_check(&path, &lasers, &checks, pipeline.lost())
            .map_err(write_error(&path))?;
        Some(TrackingCheckSummary::of(checks.iter().flatten()))
    };
    // The map holds the beams the SLAM trusted.
    let global_grid = pipeline.global_grid();
    let export = MapExport::from_grid(&global_grid, &MapExportOptions::default());
    for (name, save) in [
        (
            "map.pgm",
            MapExport::save_pgm as fn(&MapExport, &Path) -> io::Result<()>,
        ),
        ("map.png", MapExport::save_png),
        ("map.yaml", MapExport::save_ros_map),
    ] {
        let path = options.out.join(name);
        save(&export, &path).map_err(write_error(&path))?;
    }

    let trajectory: Trajectory = lasers
        .iter()
        .zip(&poses_in_map)
        .map(|(l, pose)| StampedPose::new(l.timestamp_s, *pose))
        .collect();
    let scan_at = |t_s: f64| {
        let index = lasers
            .iter()
            .position(|l| (l.timestamp_s - t_s).abs() <= pairing.timestamp_tolerance_s)?;
        scans.get(index)
    };
    let (relations, relations_agreement) = match &options.relations {
        Some(path) => {
            let relations: Vec<Relation> = read_relations(path)?
                .iter()
                .map(|r| Relation::new(r.t1_s, r.t2_s, Pose2::new(r.x_m, r.y_m, r.yaw_rad)))
                .collect();
            let evaluation = evaluate_relations(&relations, &trajectory, &pairing);
            let agreement =
                AgreementReport::new(&relations, &evaluation, &trajectory, &pairing, scan_at);
            (Some(evaluation), Some(agreement))
        }
        None => (None, None),
    };
    let (reference_consecutive, reference_revisits) = match &reference {
        Some(reference) => {
            let built = ReferenceRelations::build(reference, &ReferenceRelationOptions::default());
            let (consecutive, revisits) = built.relations.split_at(built.consecutive);
            (
                Some(evaluate_relations(consecutive, &trajectory, &pairing)),
                Some(evaluate_relations(revisits, &trajectory, &pairing)),
            )
        }
        None => (None, None),
    };

    let closure_check = reference.is_some().then(|| {
        ClosureCheck::of(pipeline.closures(), |scan| {
            reference_poses.get(scan).copied().flatten()
        })
    });

    let summary = SlamReplaySummary {
        scans: scans.len(),
        wall_s,
        scans_per_second: scans.len() as f64 / wall_s.max(1e-9),
        timing,
        slam_parts_s: pipeline.timings(),
        log: options.log.display().to_string(),
        odometry: options.odometry,
        no_return_from_m,
        slam: pipeline.stats(),
        map_resolution_m: global_grid.limits().resolution_m(),
        relations,
        relations_agreement,
        reference_consecutive,
        reference_revisits,
        closure_check,
        tracking_check,
    };
    let summary_path = options.out.join("summary.json");
    let json = serde_json::to_string_pretty(&summary).map_err(io::Error::other);
    json.and_then(|json| fs::write(&summary_path, json + "\n"))
        .map_err(write_error(&summary_path))?;
    Ok(summary)
}

fn write_trajectory(
    path: &Path,
    lasers: &[&LaserRecord],
    poses: &[Pose2],
    lost: &[bool],
) -> io::Result<()> {
    let mut out = BufWriter::new(fs::File::create(path)?);
    writeln!(
        out,
        "# timestamp x_m y_m theta_rad lost (map frame: the first scan's pose; lost = 1 where \
         tracking could not place the scan)"
    )?;
    for (index, (laser, pose)) in lasers.iter().zip(poses).enumerate() {
        let lost = lost.get(index).copied().unwrap_or(false);
        writeln!(
            out,
            "{} {:.6} {:.6} {:.6} {}",
            laser.timestamp_text,
            pose.x_m,
            pose.y_m,
            pose.theta_rad,
            u8::from(lost)
        )?;
    }
    out.flush()
}

impl TrackingCheckSummary {
    /// The counts over `checks`.
    pub fn of<'a>(checks: impl IntoIterator<Item = &'a TrackingCheck>) -> Self {
        let [max_m, max_rad] = CHOSE_ELSEWHERE_BEYOND;
        let mut summary = TrackingCheckSummary::default();
        for check in checks {
            summary.scans_checked += 1;
            let verdict = check.verdict(max_m, max_rad);
            summary.chose_elsewhere += usize::from(verdict != TrackingVerdict::Agrees);
            match verdict {
                TrackingVerdict::Agrees => {}
                TrackingVerdict::SearchMissed => summary.reference_scored_higher += 1,
                TrackingVerdict::ScoredLower => summary.reference_scored_lower += 1,
                TrackingVerdict::Refused => summary.reference_refused += 1,
            }
        }
        summary
    }
}

/// Writes `tracking_check.tsv`: one line per scan checked.
fn write_tracking_check(
    path: &Path,
    lasers: &[&LaserRecord],
    checks: &[Option<TrackingCheck>],
    lost: &[bool],
) -> io::Result<()> {
    let mut out = BufWriter::new(fs::File::create(path)?);
    writeln!(
        out,
        "# timestamp chosen_x_m chosen_y_m chosen_theta_deg reference_x_m reference_y_m \
         reference_theta_deg best_score reference_score reference_surface_fraction \
         reference_free_fraction lost elsewhere (motions from the scan before, in its frame; \
         scores as tracking scores a candidate, nan where there was none)"
    )?;
    let [max_m, max_rad] = CHOSE_ELSEWHERE_BEYOND;
    for (index, (laser, check)) in lasers.iter().zip(checks).enumerate() {
        let Some(check) = check else {
            continue;
        };
        let (chosen, reference) = (check.chosen_motion, check.checked_motion);
        let fit = check.checked_fit;
        writeln!(
            out,
            "{} {:.3} {:.3} {:.2} {:.3} {:.3} {:.2} {:.3} {:.3} {:.3} {:.3} {} {}",
            laser.timestamp_text,
            chosen.x_m,
            chosen.y_m,
            host::geometry::wrap_angle_rad(chosen.theta_rad).to_degrees(),
            reference.x_m,
            reference.y_m,
            host::geometry::wrap_angle_rad(reference.theta_rad).to_degrees(),
            check.best_score.unwrap_or(f64::NAN),
            check.checked_score.unwrap_or(f64::NAN),
            fit.map_or(f64::NAN, |f| f.surface_fraction),
            fit.map_or(f64::NAN, |f| f.free_fraction),
            u8::from(lost.get(index).copied().unwrap_or(false)),
            u8::from(check.verdict(max_m, max_rad) != TrackingVerdict::Agrees),
        )?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_compares_the_last_thousand_scans_with_the_first() {
        // 2 500 scans: the first 1 000 take 1 ms each, the last 1 000 take 3 ms, and the end
        // of the run 0.5 s.
        let scan_s: Vec<f64> = (0..2500)
            .map(|i| if i < 1500 { 0.001 } else { 0.003 })
            .collect();
        let timing = ScanTiming::of(&scan_s, 0.5);
        assert!((timing.first_1000_scans_s - 1.0).abs() < 1e-9);
        assert!((timing.last_1000_scans_s - 3.5).abs() < 1e-9);
        assert!((timing.last_to_first_1000.unwrap() - 3.5).abs() < 1e-9);
        assert!((timing.scan_p50_ms - 1.0).abs() < 1e-9);
        assert!((timing.scan_p99_ms - 3.0).abs() < 1e-9);
        assert!((timing.scan_max_ms - 3.0).abs() < 1e-9);
    }

    #[test]
    fn a_short_run_has_no_ratio() {
        let timing = ScanTiming::of(&[0.002; 1999], 0.1);
        assert_eq!(timing.last_to_first_1000, None);
        let empty = ScanTiming::of(&[], 0.0);
        assert_eq!(empty.scan_max_ms, 0.0);
        assert_eq!(empty.last_to_first_1000, None);
    }
}
