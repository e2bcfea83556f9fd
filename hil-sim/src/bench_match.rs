//! `bench-match`: the reference and the fast raster-overlap scan matcher
//! ([`ReferenceMatcher`], [`FastMatcher`]) on consecutive scan pairs of a recorded CARMEN log,
//! timed and compared answer by answer.
//!
//! For each of the first `pairs` pairs of consecutive laser scans (`k` the reference, `k + 1`
//! the new scan) both matchers search the same [`SearchTable`] on the same [`RasterOptions`]
//! around the same guess: the motion between the two scans' logged poses
//! (`inverse(pose_k) * pose_k+1`), which is the identity when the log's pose fields are zero.
//! In `benchmark/*.clf` those fields hold raw odometry (or zeros); in the GMapping-corrected
//! logs they hold the corrected pose, which makes the guess unrealistically good.
//!
//! A beam is "no return" when its range is not finite, not positive, above
//! [`BenchMatchOptions::max_range_m`], or (for `ROBOTLASER1`) at or above the laser's logged
//! maximum range. `FLASER` logs do not record their "no return" value, but every one in
//! `shared/datasets` uses a value above 50 m (81.83 m in Intel), beyond the default 40 m.
//!
//! The report counts a pair as identical when both matchers return the same table index and
//! score, the contract [`FastMatcher`] promises. Times are wall-clock totals over all pairs,
//! measured around each match call only (reading the log and building the scans are not timed);
//! build with `--release` for numbers worth quoting.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use host::geometry::Pose2;
use host::scan_match::{
    FastMatcher, MatchResult, RasterOptions, ReferenceMatcher, Scan, ScanMatchError, ScanMatcher,
    SearchTable,
};
use serde::Serialize;

use crate::replay::{CarmenLog, LaserRecord, LogError, LoggedPose};

/// What to match, and how.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchMatchOptions {
    /// Number of consecutive pairs to match (fewer when the log runs out of scans).
    pub pairs: usize,
    /// Index of the first reference scan among the log's laser records, from 0.
    pub first_scan: usize,
    /// The raster both matchers draw into.
    pub raster: RasterOptions,
    /// The candidate table both matchers search.
    pub table: SearchTable,
    /// Ranges above this many metres are treated as "no return".
    pub max_range_m: f64,
    /// Whether the guess is the motion between the logged poses (otherwise the identity).
    pub odometry_guess: bool,
}

impl Default for BenchMatchOptions {
    /// 100 pairs from the first scan; a 256 × 256 raster of 5 cm pixels joining beams up to
    /// 0.5 m apart; ±10 pixels × ±15 half-degree steps (21 × 21 × 31 candidates); ranges up to
    /// 40 m; the logged motion as the guess.
    fn default() -> Self {
        BenchMatchOptions {
            pairs: 100,
            first_scan: 0,
            raster: RasterOptions::default(),
            table: SearchTable::default(),
            max_range_m: 40.0,
            odometry_guess: true,
        }
    }
}

/// What `bench-match` measured. Serialized as exactly
/// `{"pairs":N,"identical":K,"reference_s":…,"fast_s":…}`; the rest is in
/// [`BenchMatchReport::details`], which is not serialized.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BenchMatchReport {
    /// Number of pairs matched.
    pub pairs: usize,
    /// Pairs on which both matchers returned the same table index and score.
    pub identical: usize,
    /// Total time of the reference matcher over all pairs, seconds.
    pub reference_s: f64,
    /// Total time of the fast matcher over all pairs, seconds.
    pub fast_s: f64,
    /// Everything else: the log, the guesses and each pair's results. Not serialized.
    #[serde(skip)]
    pub details: BenchMatchDetails,
}

/// The part of a [`BenchMatchReport`] that is not serialized.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchMatchDetails {
    /// The log that was read.
    pub log_path: PathBuf,
    /// Number of laser records in the log.
    pub scans_in_log: usize,
    /// Whether any pair's guess came from non-zero logged poses.
    pub odometry_guess: bool,
    /// Number of candidates in the table (each reference match scores all of them).
    pub candidates_per_match: usize,
    /// One entry per pair, in log order.
    pub pair_results: Vec<PairResult>,
}

/// Both matchers' answers on one pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairResult {
    /// Index of the reference scan among the log's laser records; the new scan is the next.
    pub reference_scan: usize,
    /// Timestamp of the reference scan, seconds.
    pub reference_timestamp_s: f64,
    /// The guess both matchers searched around.
    pub initial_reference_from_new: Pose2,
    /// The reference matcher's answer.
    pub reference: MatchResult,
    /// The fast matcher's answer.
    pub fast: MatchResult,
    /// Time of the reference matcher on this pair, seconds.
    pub reference_s: f64,
    /// Time of the fast matcher on this pair, seconds.
    pub fast_s: f64,
}

impl PairResult {
    /// Whether both matchers returned the same table index and score.
    pub fn identical(&self) -> bool {
        (self.reference.table_index, self.reference.score_px)
            == (self.fast.table_index, self.fast.score_px)
    }
}

/// Why `bench-match` could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchMatchError {
    /// The log could not be read; the error names the file (and line).
    #[error(transparent)]
    Log(#[from] LogError),
    /// The raster or table options were rejected by the matchers.
    #[error("bench-match options: {0}")]
    Options(#[source] ScanMatchError),
    /// A matcher failed on one pair.
    #[error("{}: scans {reference_scan} and {}: {source}", path.display(), reference_scan + 1)]
    Match {
        /// The log.
        path: PathBuf,
        /// Index of the pair's reference scan among the log's laser records.
        reference_scan: usize,
        /// What the matcher said.
        #[source]
        source: ScanMatchError,
    },
}

/// Matches consecutive scan pairs of the CARMEN log at `log_path` (gzip when the name ends in
/// `.gz`) with both matchers as `options` say; see the [module documentation](self).
///
/// If the log has fewer than `first_scan + pairs + 1` laser records, the pairs it has are
/// matched and [`BenchMatchReport::pairs`] says how many.
///
/// # Errors
/// [`BenchMatchError::Log`] when the log cannot be read (a missing file names its path),
/// [`BenchMatchError::Options`] when the raster or table is out of range, and
/// [`BenchMatchError::Match`] when a matcher fails on a pair.
pub fn bench_match(
    log_path: impl AsRef<Path>,
    options: &BenchMatchOptions,
) -> Result<BenchMatchReport, BenchMatchError> {
    let log = CarmenLog::read(log_path.as_ref())?;
    bench_match_log(&log, options)
}

/// [`bench_match`] on a log already in memory.
///
/// # Errors
/// [`BenchMatchError::Options`] and [`BenchMatchError::Match`] as for [`bench_match`].
pub fn bench_match_log(
    log: &CarmenLog,
    options: &BenchMatchOptions,
) -> Result<BenchMatchReport, BenchMatchError> {
    let reference_matcher =
        ReferenceMatcher::new(options.raster, options.table).map_err(BenchMatchError::Options)?;
    let fast_matcher =
        FastMatcher::new(options.raster, options.table).map_err(BenchMatchError::Options)?;

    let lasers: Vec<&LaserRecord> = log.lasers().collect();
    let selected: Vec<&LaserRecord> = lasers
        .iter()
        .skip(options.first_scan)
        .take(options.pairs.saturating_add(1))
        .copied()
        .collect();
    let scans: Vec<Scan> = selected
        .iter()
        .map(|laser| to_scan(laser, options.max_range_m))
        .collect();
    let odometry_guess = options.odometry_guess
        && selected
            .iter()
            .any(|laser| laser.robot_pose != LoggedPose::default());

    let mut pair_results = Vec::with_capacity(scans.len().saturating_sub(1));
    let mut reference_total = Duration::ZERO;
    let mut fast_total = Duration::ZERO;
    for (k, (lasers, scans)) in selected.windows(2).zip(scans.windows(2)).enumerate() {
        let reference_scan = options.first_scan + k;
        let initial_reference_from_new = if odometry_guess {
            pose(lasers[0].robot_pose).inverse() * pose(lasers[1].robot_pose)
        } else {
            Pose2::IDENTITY
        };
        let failed = |source| BenchMatchError::Match {
            path: log.path.clone(),
            reference_scan,
            source,
        };

        let start = Instant::now();
        let reference = reference_matcher
            .match_scans(&scans[0], &scans[1], initial_reference_from_new)
            .map_err(failed)?;
        let reference_time = start.elapsed();
        let start = Instant::now();
        let fast = fast_matcher
            .match_scans(&scans[0], &scans[1], initial_reference_from_new)
            .map_err(failed)?;
        let fast_time = start.elapsed();

        reference_total += reference_time;
        fast_total += fast_time;
        pair_results.push(PairResult {
            reference_scan,
            reference_timestamp_s: lasers[0].timestamp_s,
            initial_reference_from_new,
            reference,
            fast,
            reference_s: reference_time.as_secs_f64(),
            fast_s: fast_time.as_secs_f64(),
        });
    }

    Ok(BenchMatchReport {
        pairs: pair_results.len(),
        identical: pair_results.iter().filter(|p| p.identical()).count(),
        reference_s: reference_total.as_secs_f64(),
        fast_s: fast_total.as_secs_f64(),
        details: BenchMatchDetails {
            log_path: log.path.clone(),
            scans_in_log: lasers.len(),
            odometry_guess,
            candidates_per_match: options.table.len(),
            pair_results,
        },
    })
}

/// The scan of `laser` in the robot frame: beams without a return (see the
/// [module documentation](self)) become `None`.
fn to_scan(laser: &LaserRecord, max_range_m: f64) -> Scan {
    // `ROBOTLASER1` logs its maximum range, which is also its "no return" value.
    let no_return_from_m = laser.max_range_m.unwrap_or(f64::INFINITY);
    let ranges_m: Vec<f64> = laser
        .ranges_m
        .iter()
        .map(|&range_m| {
            if range_m >= no_return_from_m {
                f64::NAN
            } else {
                range_m
            }
        })
        .collect();
    Scan::from_ranges(
        &ranges_m,
        laser.start_angle_rad,
        laser.resolution_rad,
        max_range_m,
    )
}

fn pose(logged: LoggedPose) -> Pose2 {
    Pose2::new(logged.x_m, logged.y_m, logged.theta_rad)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A log of `count` FLASER scans of a room seen from a robot creeping forward, 4 beams
    /// over 180° (1 m to the right, 2 m ahead, `far_m` ahead-left, 1.5 m to the left).
    fn small_log(count: usize, far_m: f64, poses: bool) -> CarmenLog {
        let mut text = String::new();
        for k in 0..count {
            let x = if poses { 0.01 * k as f64 } else { 0.0 };
            let ahead = 2.0 - 0.01 * k as f64;
            text.push_str(&format!(
                "FLASER 4 1.0 {ahead} {far_m} 1.5 {x} 0 0 {x} 0 0 {}.5 host 0\n",
                100 + k
            ));
        }
        CarmenLog::parse(&text, "mem.clf").expect("well-formed test log")
    }

    fn small_options(pairs: usize) -> BenchMatchOptions {
        BenchMatchOptions {
            pairs,
            raster: RasterOptions {
                resolution_m: 0.1,
                width_px: 64,
                height_px: 64,
                max_gap_m: 3.0,
            },
            table: SearchTable {
                x_half_steps: 2,
                y_half_steps: 2,
                translation_step_px: 1,
                rotation_half_steps: 2,
                rotation_step_rad: 0.02,
            },
            ..BenchMatchOptions::default()
        }
    }

    #[test]
    fn test_json_has_exactly_the_four_fields() {
        let report = bench_match_log(&small_log(3, 2.5, true), &small_options(2)).unwrap();
        let json = serde_json::to_string(&report).unwrap();
        let value: serde_json::Value = serde_json::from_str(&json).unwrap();
        let keys: Vec<&str> = value
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        assert_eq!(keys.len(), 4, "{json}");
        assert!(
            json.starts_with(r#"{"pairs":2,"identical":2,"reference_s":"#),
            "{json}"
        );
        assert!(json.contains(r#","fast_s":"#), "{json}");
    }

    #[test]
    fn test_short_log_reports_the_true_count() {
        let log = small_log(4, 2.5, true);
        let report = bench_match_log(&log, &small_options(10)).unwrap();
        assert_eq!((report.pairs, report.identical), (3, 3));
        assert_eq!(report.details.scans_in_log, 4);
        assert_eq!(report.details.pair_results.len(), 3);
        assert_eq!(report.details.candidates_per_match, 5 * 5 * 5);
        let starting_late = BenchMatchOptions {
            first_scan: 2,
            ..small_options(10)
        };
        let report = bench_match_log(&log, &starting_late).unwrap();
        assert_eq!(report.pairs, 1);
        assert_eq!(report.details.pair_results[0].reference_scan, 2);
        let past_the_end = BenchMatchOptions {
            first_scan: 9,
            ..small_options(10)
        };
        let report = bench_match_log(&log, &past_the_end).unwrap();
        assert_eq!((report.pairs, report.identical), (0, 0));
        assert_eq!((report.reference_s, report.fast_s), (0.0, 0.0));
    }

    #[test]
    fn test_guess_is_the_logged_motion_or_identity() {
        let report = bench_match_log(&small_log(2, 2.5, true), &small_options(1)).unwrap();
        assert!(report.details.odometry_guess);
        let guess = report.details.pair_results[0].initial_reference_from_new;
        assert!(
            (guess.x_m - 0.01).abs() < 1e-12 && guess.y_m == 0.0,
            "{guess:?}"
        );
        let no_odometry = BenchMatchOptions {
            odometry_guess: false,
            ..small_options(1)
        };
        let report = bench_match_log(&small_log(2, 2.5, true), &no_odometry).unwrap();
        assert!(!report.details.odometry_guess);
        let guess = report.details.pair_results[0].initial_reference_from_new;
        assert_eq!(guess, Pose2::IDENTITY);
        // Zero poses in the log: identity, and the report says the log had no odometry.
        let report = bench_match_log(&small_log(2, 2.5, false), &small_options(1)).unwrap();
        assert!(!report.details.odometry_guess);
        let guess = report.details.pair_results[0].initial_reference_from_new;
        assert_eq!(guess, Pose2::IDENTITY);
    }

    #[test]
    fn test_long_ranges_are_no_return() {
        let laser = small_log(1, 81.83, true).lasers().next().unwrap().clone();
        let scan = to_scan(&laser, 40.0);
        let points = scan.points_in_robot();
        assert_eq!(points.len(), 4);
        assert!(points[2].is_none());
        // Beam 0 looks right (−90°), beam 1 ahead-left (−45°).
        let [x, y] = points[0].unwrap();
        assert!(x.abs() < 1e-12 && (y + 1.0).abs() < 1e-12);
        assert!(points[1].is_some() && points[3].is_some());
        // A ROBOTLASER1 range at its logged maximum is no return too.
        let mut robot_laser = laser;
        robot_laser.max_range_m = Some(1.5);
        let scan = to_scan(&robot_laser, 40.0);
        assert!(scan.points_in_robot()[3].is_none());
        assert!(scan.points_in_robot()[0].is_some());
    }

    #[test]
    fn test_errors_name_their_cause() {
        let err = bench_match("/no/such/log.clf", &BenchMatchOptions::default()).unwrap_err();
        assert!(matches!(err, BenchMatchError::Log(LogError::Io { .. })));
        assert!(err.to_string().contains("/no/such/log.clf"), "{err}");
        let bad = BenchMatchOptions {
            raster: RasterOptions {
                resolution_m: 0.0,
                ..RasterOptions::default()
            },
            ..BenchMatchOptions::default()
        };
        let err = bench_match_log(&small_log(2, 2.5, true), &bad).unwrap_err();
        assert!(matches!(err, BenchMatchError::Options(_)), "{err}");
        assert!(err.to_string().contains("resolution_m"), "{err}");
    }

    #[test]
    fn intel_three_pairs_are_identical() {
        let Some(path) =
            datasets::require("benchmark/intel.clf", "intel_three_pairs_are_identical")
        else {
            return;
        };
        // The default raster, a smaller table: the reference costs a raster per candidate,
        // which a debug build pays dearly for (`bench-match` runs the full table).
        let options = BenchMatchOptions {
            pairs: 3,
            table: SearchTable {
                x_half_steps: 4,
                y_half_steps: 4,
                translation_step_px: 1,
                rotation_half_steps: 4,
                rotation_step_rad: 0.5f64.to_radians(),
            },
            ..BenchMatchOptions::default()
        };
        let report = bench_match(&path, &options).unwrap();
        eprintln!(
            "intel.clf, 3 pairs: {} (fast scored {:?} of {} candidates)",
            serde_json::to_string(&report).unwrap(),
            report
                .details
                .pair_results
                .iter()
                .map(|p| p.fast.candidates_evaluated)
                .collect::<Vec<_>>(),
            report.details.candidates_per_match
        );
        assert_eq!(report.pairs, 3);
        assert_eq!(report.identical, report.pairs);
        assert_eq!(report.details.scans_in_log, 910);
        assert!(report.details.odometry_guess);
    }
}
