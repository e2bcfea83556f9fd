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
    let timing = &summary.pipeline;
    eprintln!(
        "hil-sim: the pipeline took {:.2} ms per scan on average; p50 {:.2}, p99 {:.2}, max {:.2} ms \
         over {} scans; first 1000 {:.2} ms, last 1000 {:.2} ms; peak memory {} (performance.json)",
        timing.mean_ms,
        timing.p50_ms,
        timing.p99_ms,
        timing.max_ms,
        timing.scans,
        timing.first_1000_mean_ms,
        timing.last_1000_mean_ms,
        timing
            .peak_resident_mib
            .map_or("not known".to_string(), |mib| format!("{mib:.0} MiB")),
    );
    if timing.mean_ms_by_tenth.len() > 1 {
        let tenths: Vec<String> = timing
            .mean_ms_by_tenth
            .iter()
            .map(|ms| format!("{ms:.2}"))
            .collect();
        eprintln!(
            "hil-sim: per scan over each tenth of the run, ms: {}",
            tenths.join(" ")
        );
    }
    if let (Some(frames), Some(camera)) = (&timing.camera_frames, &summary.camera) {
        let metres = |v: Option<f64>| v.map_or("—".to_string(), |m| format!("{m:.2} m"));
        eprintln!(
            "hil-sim: the camera method took {:.1} ms per frame on average; p50 {:.1}, p99 {:.1}, \
             max {:.1} ms over {} frames; GPS scale {} against the truth's ({} fixes); position \
             error {} RMS, {} at the end, over {:.0} m; the geo-referenced path's scale {}",
            frames.mean_ms,
            frames.p50_ms,
            frames.p99_ms,
            frames.max_ms,
            frames.scans,
            camera
                .scale_error
                .map_or("not fixed".to_string(), |e| format!("{:+.2} %", e * 100.0)),
            camera.fixes_paired,
            metres(camera.rms_position_m),
            metres(camera.final_position_m),
            camera.travelled_m,
            camera
                .geo_referenced_scale_error
                .map_or("—".to_string(), |e| format!("{:+.2} %", e * 100.0)),
        );
    }
    if let Some(parts) = &timing.slam_parts_s {
        eprintln!(
            "hil-sim: the SLAM's time by part: tracking {:.2} s, choosing loop closures {:.2} s, \
             searching them {:.2} s, optimising {:.2} s, settling places {:.2} s, refining \
             settled places {:.2} s, the end of the run {:.2} s",
            parts.tracking_s,
            parts.closure_candidates_s,
            parts.closure_searches_s,
            parts.optimization_s,
            parts.settling_s,
            parts.refining_ahead_s,
            parts.finish_s,
        );
    }
    if let (Some(first), Some(last)) = (
        &timing.slam_parts_first_1000_s,
        &timing.slam_parts_last_1000_s,
    ) {
        let window = timing
            .scans
            .clamp(1, hil_sim::run::host_side::TIMING_WINDOW) as f64;
        let in_run = |parts: &host::slam::SlamTimings| {
            [
                parts.tracking_s,
                parts.closure_candidates_s,
                parts.closure_searches_s,
                parts.optimization_s,
                parts.settling_s,
                parts.refining_ahead_s,
            ]
        };
        let [first, last] = [in_run(first), in_run(last)]
            .map(|parts| parts.map(|s| format!("{:.2}", s * 1000.0 / window)));
        eprintln!(
            "hil-sim: the same per scan over the first 1000 scans and the last 1000, ms: \
             tracking {} / {}, choosing {} / {}, searching {} / {}, optimising {} / {}, \
             settling {} / {}, refining {} / {}",
            first[0],
            last[0],
            first[1],
            last[1],
            first[2],
            last[2],
            first[3],
            last[3],
            first[4],
            last[4],
            first[5],
            last[5],
        );
    }
    if let Some(work) = &timing.slam_work {
        eprintln!(
            "hil-sim: the SLAM's work: {} nodes of {} scans, {} submaps, {} loop-closure \
             searches ({} over an uncertain pose's wide window), {} closures, {} optimisations, \
             {} nodes fixed where {} submaps settled",
            work.nodes,
            work.scans,
            work.submaps,
            work.loop_closure_searches,
            work.uncertain_closure_searches,
            work.loop_closures,
            work.optimizations,
            work.fixed_nodes,
            work.settled_submaps,
        );
    }
    if summary.accounting_balanced {
        Ok(())
    } else {
        Err("telegrams unaccounted for: delivered intact + counted rejected != emitted".into())
    }
}
