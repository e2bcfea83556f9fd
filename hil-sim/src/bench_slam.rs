//! `hil-sim bench-slam`: method 2 over every CARMEN log of a directory, laser only, with one
//! set of defaults, and one row of figures per log.
//!
//! Each `NAME.clf` (or `NAME.clf.gz`) runs as `replay-carmen NAME.clf --odometry none` does
//! ([`crate::slam_replay`]), with `NAME.reference.tsv` and `NAME.relations` beside it when
//! present, its outputs in `OUT/NAME/`. The table judges a change on every building at once.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use host::evaluation::RelationEvaluation;
use host::slam::SlamOptions;
use serde::Serialize;

use crate::slam_replay::{SlamReplayError, SlamReplayOptions, replay_carmen_slam};

/// What to run.
#[derive(Debug, Clone)]
pub struct BenchSlamOptions {
    /// The directory holding the `*.clf` logs.
    pub dir: PathBuf,
    /// Where each log's outputs go, in a directory of its name.
    pub out: PathBuf,
    /// Ranges at or above this are no return, metres; `None` reads it from each log
    /// ([`detect_no_return_from_m`](crate::replay::detect_no_return_from_m)).
    pub no_return_from_m: Option<f64>,
    /// Only each log's first this many scans; all when `None`.
    pub first_scans: Option<usize>,
}

/// A mean error over a set of relations.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeanError {
    /// Relations covered.
    pub relations: usize,
    /// Mean translational error, metres.
    pub translation_m: f64,
    /// Mean rotational error, degrees.
    pub rotation_deg: f64,
}

impl MeanError {
    fn of(evaluation: Option<&RelationEvaluation>) -> Option<MeanError> {
        evaluation.map(|e| MeanError {
            relations: e.summary.count,
            translation_m: e.summary.mean_translation_m,
            rotation_deg: e.summary.mean_rotation_deg,
        })
    }
}

/// One log's figures.
#[derive(Debug, Clone, Serialize)]
pub struct BenchSlamRow {
    /// The log's name (its file name without `.clf`).
    pub log: String,
    /// Scans.
    pub scans: usize,
    /// Seconds the SLAM took (not reading the log or writing the outputs).
    pub wall_s: f64,
    /// Scans per second.
    pub scans_per_second: f64,
    /// Seconds per 1 000 scans.
    pub seconds_per_1000_scans: f64,
    /// Seconds the last 1 000 scans took (the run's end included) over seconds the first
    /// 1 000 took, for a log of at least 2 000 scans: whether a scan costs more as the map
    /// grows.
    pub last_to_first_1000: Option<f64>,
    /// Error between consecutive scans of the reference trajectory.
    pub consecutive: Option<MeanError>,
    /// Error on the reference's revisits (scans at least 50 apart within 2 m and 45°).
    pub revisits: Option<MeanError>,
    /// Error on the log's published relations (`NAME.relations`).
    pub relations: Option<MeanError>,
    /// Loop-closure searches (in submaps and in chains of earlier scans).
    pub loop_closure_searches: usize,
    /// Loop-closure constraints that entered the pose graph.
    pub loop_closures: usize,
    /// Loop closures found but rejected: no second match agreed with them, or the graph's
    /// robust kernel switched them off.
    pub rejected_closures: usize,
    /// Of the loop closures and refinement constraints in the graph, those at least
    /// [`OFF_REFERENCE_FROM`](crate::closure_check::OFF_REFERENCE_FROM) from the reference's
    /// relative pose (`None` without a reference).
    pub closures_off_reference: Option<usize>,
    /// Scans local tracking could not place (flagged lost).
    pub lost_scans: usize,
    /// Constraints of the final refinement.
    pub refinement_constraints: usize,
    /// Nodes of the pose graph (the scans the motion filter inserted).
    pub nodes: usize,
    /// Of those, the nodes fixed because every submap they went into settled.
    pub fixed_nodes: usize,
}

/// The whole table.
#[derive(Debug, Clone, Serialize)]
pub struct BenchSlamReport {
    /// One row per log, in name order.
    pub logs: Vec<BenchSlamRow>,
}

/// Why the benchmark failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchSlamError {
    /// The directory cannot be listed.
    #[error("{path}: {source}")]
    Dir {
        /// The directory.
        path: PathBuf,
        /// What went wrong.
        source: io::Error,
    },
    /// The directory holds no `*.clf` log.
    #[error("{0} holds no CARMEN log (*.clf)")]
    NoLogs(PathBuf),
    /// A log failed.
    #[error("{log}: {source}")]
    Log {
        /// The log.
        log: PathBuf,
        /// What went wrong.
        source: Box<SlamReplayError>,
    },
}

/// The log's name: its file name without `.clf` or `.clf.gz`; `None` for another file.
fn log_name(path: &Path) -> Option<String> {
    let file = path.file_name()?.to_str()?;
    file.strip_suffix(".clf")
        .or_else(|| file.strip_suffix(".clf.gz"))
        .map(str::to_owned)
}

/// The `*.clf` and `*.clf.gz` files of `dir`, sorted by name.
///
/// # Errors
/// The directory cannot be listed, or holds no log.
pub fn logs_in(dir: &Path) -> Result<Vec<PathBuf>, BenchSlamError> {
    let entries = fs::read_dir(dir).map_err(|source| BenchSlamError::Dir {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut logs: Vec<PathBuf> = entries
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|path| log_name(path).is_some() && path.is_file())
        .collect();
    logs.sort();
    if logs.is_empty() {
        return Err(BenchSlamError::NoLogs(dir.to_path_buf()));
    }
    Ok(logs)
}

/// Runs every log of `options.dir`, calling `progress(index, count, name)` before each.
///
/// # Errors
/// See [`BenchSlamError`]; the first log that fails stops the run.
pub fn bench_slam(
    options: &BenchSlamOptions,
    mut progress: impl FnMut(usize, usize, &str),
) -> Result<BenchSlamReport, BenchSlamError> {
    let logs = logs_in(&options.dir)?;
    let mut rows = Vec::with_capacity(logs.len());
    for (index, log) in logs.iter().enumerate() {
        let name = log_name(log).unwrap_or_default();
        progress(index, logs.len(), &name);
        let beside = |suffix: &str| {
            let path = log.with_file_name(format!("{name}.{suffix}"));
            path.exists().then_some(path)
        };
        let replay = SlamReplayOptions {
            log: log.clone(),
            out: options.out.join(&name),
            odometry: false,
            no_return_from_m: options.no_return_from_m,
            relations: beside("relations"),
            reference: beside("reference.tsv"),
            slam: SlamOptions::default(),
            first_scans: options.first_scans,
            check_tracking: false,
        };
        let summary = replay_carmen_slam(&replay).map_err(|source| BenchSlamError::Log {
            log: log.clone(),
            source: Box::new(source),
        })?;
        let stats = summary.slam;
        rows.push(BenchSlamRow {
            log: name,
            scans: summary.scans,
            wall_s: summary.wall_s,
            scans_per_second: summary.scans_per_second,
            seconds_per_1000_scans: 1000.0 * summary.wall_s / summary.scans.max(1) as f64,
            last_to_first_1000: summary.timing.last_to_first_1000,
            consecutive: MeanError::of(summary.reference_consecutive.as_ref()),
            revisits: MeanError::of(summary.reference_revisits.as_ref()),
            relations: MeanError::of(summary.relations.as_ref()),
            loop_closure_searches: stats.loop_closure_searches + stats.chain_closure_searches,
            loop_closures: stats.loop_closures,
            rejected_closures: stats.rejected_closures + stats.switched_off_closures,
            closures_off_reference: summary
                .closure_check
                .as_ref()
                .map(|c| c.off_reference.len()),
            lost_scans: stats.lost_scans,
            refinement_constraints: stats.refinement_constraints,
            nodes: stats.nodes,
            fixed_nodes: stats.fixed_nodes,
        });
    }
    Ok(BenchSlamReport { logs: rows })
}

impl BenchSlamReport {
    /// The table as text, one row per log.
    pub fn table(&self) -> String {
        let error = |e: Option<MeanError>| {
            e.map_or_else(
                || "—".to_string(),
                |e| format!("{:.3} m {:.2}°", e.translation_m, e.rotation_deg),
            )
        };
        let mut text = format!(
            "{:<18} {:>6} {:>8} {:>8} {:>10} {:>17} {:>17} {:>17} {:>9} {:>8} {:>8} {:>7} {:>6}\n",
            "log",
            "scans",
            "scans/s",
            "s/1000",
            "last/first",
            "consecutive",
            "revisits",
            "relations",
            "searches",
            "closures",
            "rejected",
            "off ref",
            "lost"
        );
        for row in &self.logs {
            text.push_str(&format!(
                "{:<18} {:>6} {:>8.0} {:>8.2} {:>10} {:>17} {:>17} {:>17} {:>9} {:>8} {:>8} {:>7} {:>6}\n",
                row.log,
                row.scans,
                row.scans_per_second,
                row.seconds_per_1000_scans,
                row.last_to_first_1000
                    .map_or_else(|| "—".to_string(), |r| format!("{r:.2}×")),
                error(row.consecutive),
                error(row.revisits),
                error(row.relations),
                row.loop_closure_searches,
                row.loop_closures,
                row.rejected_closures,
                row.closures_off_reference
                    .map_or_else(|| "—".to_string(), |n| n.to_string()),
                row.lost_scans,
            ));
        }
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_directory_without_logs_is_an_error_that_names_it() {
        let dir = std::env::temp_dir().join(format!("bench-slam-empty-{}", std::process::id()));
        fs::create_dir_all(&dir).expect("temp dir");
        fs::write(dir.join("notes.txt"), "not a log").expect("write");
        let error = logs_in(&dir).expect_err("no logs");
        assert!(matches!(error, BenchSlamError::NoLogs(_)));
        assert!(error.to_string().contains("bench-slam-empty"), "{error}");
        let missing = logs_in(&dir.join("missing")).expect_err("no dir");
        assert!(matches!(missing, BenchSlamError::Dir { .. }), "{missing}");
        fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn logs_are_named_without_their_extensions() {
        assert_eq!(log_name(Path::new("d/intel.clf")).as_deref(), Some("intel"));
        assert_eq!(
            log_name(Path::new("d/fr079.clf.gz")).as_deref(),
            Some("fr079")
        );
        assert_eq!(log_name(Path::new("d/intel.reference.tsv")), None);
    }

    #[test]
    fn the_table_shows_a_dash_where_a_log_has_no_reference() {
        let report = BenchSlamReport {
            logs: vec![BenchSlamRow {
                log: "hall".into(),
                scans: 10,
                wall_s: 0.5,
                scans_per_second: 20.0,
                seconds_per_1000_scans: 50.0,
                last_to_first_1000: None,
                consecutive: Some(MeanError {
                    relations: 9,
                    translation_m: 0.0123,
                    rotation_deg: 0.5,
                }),
                revisits: None,
                relations: None,
                loop_closure_searches: 3,
                loop_closures: 1,
                rejected_closures: 2,
                closures_off_reference: None,
                lost_scans: 4,
                refinement_constraints: 0,
                nodes: 9,
                fixed_nodes: 0,
            }],
        };
        let table = report.table();
        let row = table.lines().nth(1).expect("a row");
        assert!(row.starts_with("hall"), "{row}");
        assert!(row.contains("0.012 m 0.50°") && row.contains('—'), "{row}");
    }
}
