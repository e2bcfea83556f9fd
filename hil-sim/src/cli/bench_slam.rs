//! `hil-sim bench-slam`: method 2 over every CARMEN log of a directory, one row per log.

use std::path::PathBuf;

use super::CliResult;

/// Method 2 over every CARMEN log (`*.clf`, `*.clf.gz`) of DIR, laser only, with the defaults every log
/// shares; each with `NAME.reference.tsv` and `NAME.relations` beside it when present.
///
/// Prints one row per log (scans, scans/s, seconds per 1 000 scans, the last 1 000 scans'
/// time over the first 1 000's for logs of at least 2 000 scans, the mean error between
/// consecutive scans and at revisits of the reference trajectory, the error on the published
/// relations, loop-closure searches and the closures that entered the graph) and, as its last
/// line, the same as JSON: `{"logs":[{"log":…,"scans":…,…},…]}`. Each log's outputs, as
/// `replay-carmen` writes them, go to OUT/NAME/.
#[derive(Debug, clap::Args)]
pub struct BenchSlamArgs {
    /// The directory holding the logs (e.g. ../shared/datasets/benchmark).
    dir: PathBuf,
    /// Where each log's outputs go, in a directory of its name.
    #[arg(long, default_value = "bench-slam-out")]
    out: PathBuf,
    /// Ranges at or above this are "no return", m [default: read from each log: just below
    /// its largest range when many ranges pile up there, as a sensor's saturated readings
    /// do (32.767 m, 81.91 m); else 80 m].
    #[arg(long)]
    no_return_from_m: Option<f64>,
    /// Only each log's first N scans (a short run; relations beyond them are not covered).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    first_scans: Option<u64>,
}

/// Runs every log; the table and the JSON on stdout, progress on stderr.
pub fn run(args: BenchSlamArgs) -> CliResult {
    let options = hil_sim::bench_slam::BenchSlamOptions {
        dir: args.dir,
        out: args.out,
        no_return_from_m: args.no_return_from_m,
        first_scans: args
            .first_scans
            .map(|n| usize::try_from(n).unwrap_or(usize::MAX)),
    };
    let report = hil_sim::bench_slam::bench_slam(&options, |index, count, name| {
        eprintln!("hil-sim: [{}/{count}] {name}", index + 1);
    })?;
    print!("{}", report.table());
    println!("{}", serde_json::to_string(&report)?);
    Ok(())
}
