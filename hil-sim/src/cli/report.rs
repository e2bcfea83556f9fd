//! The output of a run of the whole chain (`run`, `replay`): the summary as JSON on stdout,
//! a line on stderr, and failure when the telegrams do not add up.

use super::CliResult;

/// Prints `summary` (JSON on stdout, timing and `out` on stderr); an error when the
/// telegrams are not all accounted for.
pub fn report(summary: &hil_sim::run::RunSummary, out: &std::path::Path) -> CliResult {
    println!("{}", serde_json::to_string_pretty(summary)?);
    eprintln!(
        "hil-sim: {} s of sensor output in {:.2} s; outputs in {}",
        summary.duration_s,
        summary.wall_s,
        out.display()
    );
    if summary.accounting_balanced {
        Ok(())
    } else {
        Err("telegrams unaccounted for: delivered intact + counted rejected != emitted".into())
    }
}
