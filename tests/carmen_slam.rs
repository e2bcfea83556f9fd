//! Method 2 on a real laser log: the occupancy-grid SLAM over the Freiburg building 101 log
//! without odometry, scored on relations built from its reference trajectory. The full table
//! over every benchmark log is the `replay-carmen` command's (README, "Method 2").

use hil_sim::slam_replay::{SlamReplayOptions, replay_carmen_slam};
use host::slam::SlamOptions;

#[test]
fn freiburg_101_closes_its_loops_without_odometry() {
    let Some(log) = datasets::require(
        "benchmark/freiburg-101.clf",
        "freiburg_101_closes_its_loops_without_odometry",
    ) else {
        return;
    };
    let Some(reference) = datasets::require(
        "benchmark/freiburg-101.reference.tsv",
        "freiburg_101_closes_its_loops_without_odometry",
    ) else {
        return;
    };
    let out = std::env::temp_dir().join(format!("carmen-slam-{}", std::process::id()));
    let options = SlamReplayOptions {
        log,
        out: out.clone(),
        odometry: false,
        no_return_from_m: 80.0,
        relations: None,
        reference: Some(reference),
        slam: SlamOptions::default(),
        first_scans: None,
    };
    let summary = replay_carmen_slam(&options).expect("replay");
    assert_eq!(summary.scans, 292);
    assert!(summary.slam.loop_closures > 0, "{:?}", summary.slam);
    assert!(
        summary.slam.refinement_constraints > 0,
        "{:?}",
        summary.slam
    );
    let revisits = summary
        .reference_revisits
        .map(|e| e.summary)
        .expect("revisit relations");
    let consecutive = summary
        .reference_consecutive
        .map(|e| e.summary)
        .expect("consecutive relations");
    // Measured: 0.039 m over 101 revisits, 0.032 m over 291 consecutive pairs.
    assert!(revisits.mean_translation_m <= 0.10, "{revisits:?}");
    assert!(consecutive.mean_translation_m <= 0.05, "{consecutive:?}");
    for file in [
        "trajectory.tsv",
        "map.pgm",
        "map.yaml",
        "map.png",
        "summary.json",
    ] {
        assert!(out.join(file).is_file(), "{file} written");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// ACES's first loop: the robot leaves its start through a long corridor, where local
/// tracking slides by metres, and comes back to it at scan 250. Only the chain closures,
/// with the slide's constraints loose along the corridor, close it (3.9 m before them).
#[test]
fn aces_closes_its_loop_round_the_start_without_odometry() {
    let name = "aces_closes_its_loop_round_the_start_without_odometry";
    let Some(log) = datasets::require("benchmark/aces.clf", name) else {
        return;
    };
    let Some(reference) = datasets::require("benchmark/aces.reference.tsv", name) else {
        return;
    };
    let out = std::env::temp_dir().join(format!("carmen-aces-{}", std::process::id()));
    let options = SlamReplayOptions {
        log,
        out: out.clone(),
        odometry: false,
        no_return_from_m: 80.0,
        relations: None,
        reference: Some(reference),
        slam: SlamOptions::default(),
        first_scans: Some(280),
    };
    let summary = replay_carmen_slam(&options).expect("replay");
    assert_eq!(summary.scans, 280);
    assert!(summary.slam.chain_closures > 0, "{:?}", summary.slam);
    let revisits = summary
        .reference_revisits
        .map(|e| e.summary)
        .expect("revisit relations");
    // Measured: 0.037 m over 114 revisits, all between scans 0–25 and 225–275.
    assert_eq!(revisits.count, 114, "{revisits:?}");
    assert!(revisits.mean_translation_m <= 0.10, "{revisits:?}");
    let _ = std::fs::remove_dir_all(&out);
}
