//! End-to-end: the thumbv7em build of the firmware (`firmware/qemu`, built by `tests/run.sh`)
//! booted in QEMU's `netduinoplus2` machine by `hil-sim run --qemu`, against the firmware tasks
//! on the host executor (lock-step) in the same seeded world: ten seconds of laser and GPS,
//! one laser restart, telegrams cut short.
//!
//! What is compared. Both runs must decode exactly what was sent — every scan the host got is,
//! value for value, a scan the laser sent; no frame is damaged or lost on the link; every GPS
//! epoch reaches the host — and account for every scan the same way: delivered intact or
//! counted as lost by the firmware or the host. The counts themselves may differ a little,
//! and only as timing explains: the lock-step run reacts to each laser reply at once, the
//! emulated board on the wall clock a few milliseconds later (QEMU passes bytes one at a time
//! through its event loop; the engine polls the lines every millisecond), so each bring-up
//! ends some tens of milliseconds later, and the laser, which sends one scan every 213 ms at
//! the image's 38 400 Bd, may have sent one scan fewer per bring-up. For the same reason the
//! scans' values differ (the robot has moved on), so the comparison is by count, not value.
//!
//! Without `qemu-system-arm` or the image the test prints SKIPPED, and fails when `CI` is set.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use hil_sim::faults::FaultSpec;
use hil_sim::qemu::{self, QemuOptions, QemuReport};
use hil_sim::run::{RunOptions, RunSummary, run_with_bring_up};
use hil_sim::world::WorldKind;

/// When the laser is power-cycled, s.
const RESTART_S: f64 = 5.0;
/// Scans per bring-up by which the runs may differ (two bring-ups: power-on and restart).
const SCAN_TOLERANCE: u64 = 2;
/// GPS epochs by which the runs may differ: an epoch cut by the end of the run, and up to two
/// more epochs while the run waits for a scan that is still on the line.
const FIX_TOLERANCE: u64 = 3;

fn image() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(qemu::DEFAULT_ELF)
}

/// Whether QEMU and the image are there; SKIPPED otherwise, failing under CI.
fn prerequisites(test: &str) -> bool {
    let qemu = Command::new("qemu-system-arm").arg("--version").output();
    let why = match (qemu, image().is_file()) {
        (Ok(out), true) if out.status.success() => return true,
        (Ok(out), _) if out.status.success() => format!(
            "{} is missing (cd firmware/qemu && cargo build --release)",
            image().display()
        ),
        _ => "qemu-system-arm is not installed (apt-get install qemu-system-arm)".to_owned(),
    };
    assert!(
        !datasets::in_ci(),
        "{test}: {why}; failing because CI is set"
    );
    println!("SKIPPED {test}: {why}");
    false
}

fn options(name: &str) -> RunOptions {
    let out = std::env::temp_dir().join(format!("hil-qemu-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&out);
    RunOptions {
        world: WorldKind::Outdoor,
        seed: 7,
        duration_s: 10.0,
        faults: format!("truncate=0.2,laser-restart={RESTART_S}")
            .parse::<FaultSpec>()
            .expect("fault spec"),
        out,
        realtime: false,
        hardware: None,
    }
}

/// Timestamps of the scans the host received intact.
fn scan_times_s(out: &Path) -> Vec<f64> {
    fs::read_to_string(out.join("trajectory.tsv"))
        .expect("trajectory.tsv")
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .collect()
}

/// What each run must show by itself.
fn assert_decoded_and_accounted(name: &str, s: &RunSummary, out: &Path) {
    assert_eq!(s.panics, 0, "{name}: {s:#?}");
    assert!(s.counted.final_status_received, "{name}: {s:#?}");
    assert_eq!(s.counted.final_laser_state, "Streaming", "{name}: {s:#?}");
    assert_eq!(s.injected.events.laser_restarts, 1, "{name}");
    // Decoded exactly: every scan value for value, every frame intact and in sequence.
    assert_eq!(s.counted.host_scans_not_sent, 0, "{name}: {s:#?}");
    assert_eq!(s.counted.host_bad_frames, 0, "{name}: {s:#?}");
    assert_eq!(s.frames_lost_on_link, 0, "{name}: {s:#?}");
    assert_eq!(s.counted.host_scan_counter_gaps, 0, "{name}: {s:#?}");
    // Cut telegrams were sent, and none of them was delivered.
    assert!(s.injected.laser.telegrams_truncated > 0, "{name}: {s:#?}");
    assert!(
        s.telegrams_delivered_intact + s.injected.laser.telegrams_damaged <= s.telegrams_emitted,
        "{name}: {s:#?}"
    );
    // Every scan accounted for, but the one the power cycle cut off may go uncounted: its
    // bytes and the restarting sensor's noise can fall into one slot of the firmware's count.
    let counted = s.telegrams_delivered_intact + s.telegrams_counted_rejected;
    assert!(counted <= s.telegrams_emitted, "{name}: {s:#?}");
    assert!(
        s.telegrams_emitted - counted <= s.injected.scan_telegrams_cut_by_restart,
        "{name}: {s:#?}"
    );
    // Streaming again after the restart.
    let times = scan_times_s(out);
    assert!(times.iter().any(|&t| t < RESTART_S), "{name}: {times:?}");
    assert!(times.iter().any(|&t| t > RESTART_S), "{name}: {times:?}");
    // Every GPS epoch delivered, but one cut by the end of the run.
    assert!(s.gps_fixes_emitted >= 90, "{name}: {s:#?}");
    assert!(
        s.gps_fixes_delivered <= s.gps_fixes_emitted,
        "{name}: {s:#?}"
    );
    assert!(
        s.gps_fixes_delivered + 1 >= s.gps_fixes_emitted,
        "{name}: {s:#?}"
    );
}

fn assert_close(what: &str, host: u64, emulated: u64, tolerance: u64) {
    assert!(
        host.abs_diff(emulated) <= tolerance,
        "{what}: host executor {host}, QEMU {emulated} (tolerance {tolerance})"
    );
}

fn assert_measured(report: &QemuReport, emulated: &RunSummary) {
    let m = &report.measurements;
    assert!(
        m.stack_used_bytes > 0 && m.stack_used_bytes < m.stack_bytes,
        "{report:#?}"
    );
    // One sample per scan frame sent, and the board sent every scan the host got.
    assert_eq!(
        m.latency_samples, emulated.telegrams_delivered_intact,
        "{report:#?}"
    );
    assert!(m.latency_max_cycles > 0, "{report:#?}");
    assert_eq!(m.core_hz, 168_000_000);
}

#[test]
fn the_thumbv7em_image_in_qemu_decodes_and_accounts_as_the_host_executor_does() {
    if !prerequisites("qemu_chain") {
        return;
    }
    let host_options = options("host");
    let host = run_with_bring_up(&host_options, None, Some(qemu::image_bring_up()))
        .expect("host-executor run");
    let emulated_options = options("qemu");
    let (emulated, report) =
        qemu::run(&emulated_options, &QemuOptions::new(image())).expect("QEMU run");
    println!("host executor: {host:#?}");
    println!("QEMU: {emulated:#?}");
    println!("measured: {report:#?}");

    assert_decoded_and_accounted("host executor", &host, &host_options.out);
    assert_decoded_and_accounted("QEMU", &emulated, &emulated_options.out);
    assert_measured(&report, &emulated);
    assert!(emulated_options.out.join("qemu.json").is_file());

    assert_close(
        "scans emitted",
        host.telegrams_emitted,
        emulated.telegrams_emitted,
        SCAN_TOLERANCE,
    );
    assert_close(
        "scans delivered intact",
        host.telegrams_delivered_intact,
        emulated.telegrams_delivered_intact,
        SCAN_TOLERANCE,
    );
    assert_close(
        "scans counted lost",
        host.telegrams_counted_rejected,
        emulated.telegrams_counted_rejected,
        SCAN_TOLERANCE,
    );
    assert_close(
        "GPS fixes delivered",
        host.gps_fixes_delivered,
        emulated.gps_fixes_delivered,
        FIX_TOLERANCE,
    );
    for out in [&host_options.out, &emulated_options.out] {
        let _ = fs::remove_dir_all(out);
    }
}
