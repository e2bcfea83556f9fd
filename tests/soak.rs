//! The daemon's soak, short: `robot-host run` as its own process through the whole emulated
//! chain with every kind of fault for 90 s of simulated time (`hil-sim soak` runs an hour,
//! docs/soak.md). Every check of the long run must pass: the simulation's accounting, every
//! frame counted by the daemon, memory within 10 % of the first minute's, threads flat, every
//! 10 MiB request answered 413, and the recording readable after the `kill -9`.

use std::path::PathBuf;
use std::time::Duration;

use hil_sim::soak::{SoakOptions, run};
use hil_sim::world::WorldKind;

/// The `robot-host` binary `cargo test` built beside this test.
fn robot_host() -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows where it is");
    // target/PROFILE/deps/soak-HASH → target/PROFILE/robot-host
    let profile_dir = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("the test runs from target/PROFILE/deps");
    profile_dir.join("robot-host")
}

#[test]
fn daemon_soak_with_every_fault_kind_keeps_its_accounting_memory_and_recording() {
    let daemon = robot_host();
    assert!(
        daemon.is_file(),
        "{} is missing: `cargo test --workspace` builds it",
        daemon.display()
    );
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("soak");
    let _ = std::fs::remove_dir_all(&out);
    let options = SoakOptions {
        world: WorldKind::Outdoor,
        seed: 4,
        duration_s: 90.0,
        faults: None,
        daemon,
        out: out.clone(),
        sample_interval: Duration::from_millis(250),
        part_length_s: None,
    };
    let report = run(&options, |_| {}).expect("the soak runs");
    let summary = serde_json::to_string_pretty(&report).unwrap_or_default();
    assert!(report.passed(), "{:?}\n{summary}", report.failures);
    // Each memory reading covers the time since the sample before.
    assert!(report.high_water_mark_resets, "{summary}");
    // Every fault kind was injected.
    let events = &report.simulation.injected.events;
    assert!(events.laser_restarts > 0 && events.gps_outages > 0 && events.link_replugs > 0);
    assert!(
        report.simulation.injected.laser.telegrams_damaged > 0,
        "{summary}"
    );
    assert!(report.oversized_requests > 0, "{summary}");
    assert!(report.recording.truncated, "{summary}");
    assert!(report.recording.frames > 0, "{summary}");
    assert!(out.join("soak.tsv").is_file());
}
