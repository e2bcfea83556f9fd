//! `hil-sim bench-match`: the reference raster matcher against the fast one on consecutive
//! scan pairs of a CARMEN log.

use std::path::PathBuf;

use super::CliResult;

/// Match consecutive scan pairs of a CARMEN log with the reference raster matcher and the
/// fast matcher on the same table; prints per-pair timings on stderr and, as the last
/// line on stdout, `{"pairs":N,"identical":K,"reference_s":…,"fast_s":…}`.
#[derive(Debug, clap::Args)]
pub struct BenchMatchArgs {
    /// The CARMEN log.
    log: PathBuf,
    /// Scan pairs to match (scan k against scan k + 1).
    #[arg(long, default_value_t = 100)]
    pairs: usize,
}

/// Matches the pairs; per-pair timings on stderr, the report as the last line on stdout.
pub fn run(args: BenchMatchArgs) -> CliResult {
    let options = hil_sim::bench_match::BenchMatchOptions {
        pairs: args.pairs,
        ..Default::default()
    };
    let report = hil_sim::bench_match::bench_match(&args.log, &options)?;
    for pair in &report.details.pair_results {
        eprintln!(
            "scan {}: reference {:.4} s, fast {:.6} s, identical {}",
            pair.reference_scan,
            pair.reference_s,
            pair.fast_s,
            pair.identical()
        );
    }
    println!("{}", serde_json::to_string(&report)?);
    Ok(())
}
