//! End-to-end: `hil-sim run` on seeded worlds, with and without faults. Emulated sensors →
//! ptys → the firmware tasks → host link → the host's estimate, compared with the truth; every
//! telegram accounted for; the same arguments give the same bytes.
//!
//! The runs share one virtual clock per process, so they take turns (`VirtualClock::begin`).

use std::fs;
use std::path::{Path, PathBuf};

use hil_sim::faults::FaultSpec;
use hil_sim::run::{RunOptions, RunSummary, run};
use hil_sim::world::WorldKind;

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hil-run-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    dir
}

fn run_world(
    world: WorldKind,
    seed: u64,
    duration_s: f64,
    faults: &str,
    name: &str,
) -> (RunSummary, PathBuf) {
    let out = out_dir(name);
    let options = RunOptions {
        world,
        seed,
        duration_s,
        faults: faults.parse::<FaultSpec>().expect("fault spec"),
        out: out.clone(),
        realtime: false,
        hardware: None,
        grid_every_scan: false,
        camera: None,
    };
    let summary = run(&options).expect("run");
    (summary, out)
}

/// Reads `timestamp x y theta` lines.
fn read_poses(path: &Path) -> Vec<[f64; 4]> {
    fs::read_to_string(path)
        .expect("readable")
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|f| f.parse().expect("number"))
                .collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

fn assert_accounted(summary: &RunSummary) {
    assert_eq!(summary.panics, 0);
    assert!(summary.telegrams_emitted > 0);
    assert_eq!(
        summary.telegrams_delivered_intact + summary.telegrams_counted_rejected,
        summary.telegrams_emitted,
        "{summary:#?}"
    );
    assert!(summary.accounting_balanced);
    assert!(summary.counted.final_status_received);
    assert_eq!(summary.counted.host_scans_not_sent, 0);
}

#[test]
fn indoor_run_without_faults_delivers_everything_and_tracks_the_robot() {
    let (summary, out) = run_world(WorldKind::Indoor, 7, 15.0, "", "indoor");
    assert_accounted(&summary);
    assert_eq!(summary.telegrams_counted_rejected, 0);
    assert_eq!(summary.frames_lost_on_link, 0);
    // 0.5° scans stream at 37.5 Hz once the laser is up (about 3 s of bring-up).
    assert!(summary.telegrams_emitted > 37 * 10, "{summary:#?}");
    // Indoors there is no GPS fix.
    assert_eq!(summary.gps_fixes_emitted, 0);

    let estimate = read_poses(&out.join("trajectory.tsv"));
    let truth = read_poses(&out.join("ground_truth.tsv"));
    assert_eq!(estimate.len() as u64, summary.telegrams_delivered_intact);
    assert_eq!(estimate.len(), truth.len());
    for (e, t) in estimate.iter().zip(&truth) {
        assert_eq!(e[0], t[0], "same timestamps");
    }
    // Method 2 keeps the robot within a few centimetres a metre over a few metres.
    assert!(summary.estimate.travelled_m > 3.0, "{:?}", summary.estimate);
    let last = (estimate.last().unwrap(), truth.last().unwrap());
    let error_m = (last.0[1] - last.1[1]).hypot(last.0[2] - last.1[2]);
    assert!(
        error_m < 0.1 * summary.estimate.travelled_m + 0.2,
        "final error {error_m} m after {} m",
        summary.estimate.travelled_m
    );
}

#[test]
fn outdoor_run_with_every_fault_accounts_for_every_telegram() {
    let faults = "ber=2e-5,drop=1e-4,truncate=0.05,laser-restart=6,gps-outage=4:2,link-replug=9";
    let (summary, _) = run_world(WorldKind::Outdoor, 3, 12.0, faults, "outdoor-faults");
    assert_accounted(&summary);
    let injected = &summary.injected;
    assert!(injected.laser.telegrams_damaged > 0 && injected.laser.bits_flipped > 0);
    assert_eq!(injected.events.laser_restarts, 1);
    assert_eq!(injected.events.gps_outages, 1);
    assert_eq!(injected.events.link_replugs, 1);
    // The firmware saw the damage and brought the laser back after the power cycle.
    assert!(summary.counted.firmware_scans_missed > 0);
    assert!(summary.counted.firmware_laser_crc_errors > 0);
    assert_eq!(summary.counted.final_laser_state, "Streaming");
    // GPS: 10 Hz with a fix outdoors, less the outage; every fix that arrived was sent.
    assert!(summary.gps_fixes_emitted > 80, "{summary:#?}");
    assert!(summary.gps_fixes_delivered <= summary.gps_fixes_emitted);
    assert!(summary.gps_fixes_delivered > summary.gps_fixes_emitted / 2);
    // The landmark map is scored against the world's trees, each tree recorded once.
    let map = summary.map.expect("the EKF method's map is scored");
    assert!(map.trees_mapped > 10, "{map:?}");
    assert_eq!(map.extra_records, 0, "{map:?}");
}

#[test]
fn link_replug_losses_are_counted_by_the_host() {
    let (summary, _) = run_world(WorldKind::Indoor, 2, 8.0, "link-replug=5", "replug");
    assert_accounted(&summary);
    assert!(summary.counted.host_bytes_while_unplugged > 0);
    // 0.3 s unplugged at 37.5 scans per second.
    assert!(
        (8..=14).contains(&summary.counted.host_scan_counter_gaps),
        "{summary:#?}"
    );
    // Fewer than 1 000 scans: the first and the last window are the whole run, and hold what
    // the SLAM spent during it.
    let timing = &summary.pipeline;
    assert!(timing.scans > 100 && timing.scans < 1000, "{timing:?}");
    let whole = timing.slam_parts_s.expect("the grid method's parts");
    let first = timing.slam_parts_first_1000_s.expect("first window");
    assert_eq!(timing.slam_parts_last_1000_s, Some(first));
    assert_eq!(first.tracking_s, whole.tracking_s);
    assert_eq!(first.closure_searches_s, whole.closure_searches_s);
    assert_eq!(first.optimization_s, whole.optimization_s);
    assert!(first.tracking_s > 0.0 && first.finish_s == 0.0, "{first:?}");
}

#[test]
fn same_arguments_give_identical_outputs() {
    let faults = "ber=1e-5,truncate=0.02,laser-restart=5";
    let (_, a) = run_world(WorldKind::Outdoor, 11, 8.0, faults, "same-a");
    let (_, b) = run_world(WorldKind::Outdoor, 11, 8.0, faults, "same-b");
    for file in [
        "trajectory.tsv",
        "ground_truth.tsv",
        "summary.json",
        "landmarks.tsv",
        "world.tsv",
        "map.tsv",
    ] {
        let (x, y) = (
            fs::read(a.join(file)).unwrap(),
            fs::read(b.join(file)).unwrap(),
        );
        assert!(!x.is_empty(), "{file} is empty");
        assert!(x == y, "{file} differs between two runs of the same seed");
    }
    // The pipeline's time per scan is written beside them, for every scan the host received.
    let timing: serde_json::Value =
        serde_json::from_slice(&fs::read(a.join("performance.json")).unwrap()).unwrap();
    assert!(timing["scans"].as_u64().unwrap() > 0, "{timing}");
    assert!(timing["p99_ms"].as_f64().unwrap() >= timing["p50_ms"].as_f64().unwrap());
    let (_, c) = run_world(WorldKind::Outdoor, 12, 8.0, faults, "same-c");
    assert_ne!(
        fs::read(a.join("trajectory.tsv")).unwrap(),
        fs::read(c.join("trajectory.tsv")).unwrap()
    );
}

#[test]
fn carmen_log_replays_through_the_chain() {
    let Some(log) = datasets::require(
        "benchmark/intel.clf",
        "carmen_log_replays_through_the_chain",
    ) else {
        return;
    };
    let out = out_dir("intel");
    let options = hil_sim::run::ReplayOptions {
        source: hil_sim::run::ReplaySource::Carmen(log),
        pace: hil_sim::emulators::ReplayPace::AsFastAsPossible,
        // Read from the log: its 81.83 m readings pile up at its largest range.
        no_return_from_m: None,
        seed: 5,
        faults: "ber=1e-5,truncate=0.02".parse().expect("fault spec"),
        out: out.clone(),
        realtime: false,
        hardware: None,
    };
    let summary = hil_sim::run::replay(&options).expect("replay");
    assert_accounted(&summary);
    assert_eq!(
        summary.telegrams_emitted, 910,
        "every scan of the log is sent once"
    );
    assert!(summary.telegrams_counted_rejected > 0);
    // The logged pose of each scan delivered is written beside the estimate.
    let truth = read_poses(&out.join("ground_truth.tsv"));
    assert_eq!(truth.len() as u64, summary.telegrams_delivered_intact);
}

fn replay_capture(name: &str) -> Option<RunSummary> {
    let file = format!("benchmark/lms200/{name}.lms-to-host.bin");
    let path = datasets::require(&file, "raw_captures_replay_byte_for_byte")?;
    let options = hil_sim::run::ReplayOptions {
        source: hil_sim::run::ReplaySource::Capture { path, baud: 38_400 },
        pace: hil_sim::emulators::ReplayPace::AsFastAsPossible,
        no_return_from_m: None,
        seed: 1,
        faults: FaultSpec::default(),
        out: out_dir(name),
        realtime: false,
        hardware: None,
    };
    Some(hil_sim::run::replay(&options).expect("replay"))
}

#[test]
fn raw_captures_replay_byte_for_byte() {
    // A clean AtlasBuggy session: every scan telegram of the capture arrives intact.
    let Some(summary) = replay_capture("2017_Aug_05_18-52-56") else {
        return;
    };
    assert_accounted(&summary);
    assert_eq!(summary.telegrams_emitted, 165);
    assert_eq!(summary.telegrams_delivered_intact, 165);
    // A session whose one scan was read out of step when it was recorded: it goes out as
    // recorded, and the firmware counts it (CRC error, scan missed).
    let Some(summary) = replay_capture("2017_Aug_05_19-07-55") else {
        return;
    };
    assert!(summary.accounting_balanced, "{summary:#?}");
    assert_eq!(summary.telegrams_emitted, 1);
    assert_eq!(summary.telegrams_delivered_intact, 0);
    assert_eq!(summary.counted.firmware_laser_crc_errors, 1);
    assert_eq!(summary.counted.firmware_scans_missed, 1);
}
