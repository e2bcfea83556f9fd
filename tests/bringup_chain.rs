//! The whole chain on emulated sensors, in real time over pseudo-terminals: the firmware
//! brings a freshly powered LMS200 up from 9 600 Bd to 500 kBd streaming at 0.5°, forwards
//! every scan and the 10 Hz GPS fixes, and the host receives them all; after a power cycle
//! of the sensor the firmware notices and brings it up again.
//!
//! A real sensor's line never pauses and a real host keeps reading; on a busy machine the
//! emulation's threads can be left without a core for longer than the telegram timeout or the
//! board's queue allows. The run measures that ([`bringup::BringUpReport::longest_stall_ms`]);
//! past [`STALL_BUDGET_MS`] the losses the board counted are excused, and only those.

use std::sync::Mutex;

use hil_sim::bringup::{self, BringUpOptions};
use protocol::LaserState;

/// Each chain runs in real time on pseudo-terminals. Two at once on a two-core machine compete
/// for the cores its timing depends on (the emulated board stamps bytes when its threads read
/// them), so the tests take turns.
static REAL_TIME: Mutex<()> = Mutex::new(());

/// The longest the machine may leave the emulation without a core for a run to be held to
/// losing nothing, ms: below the laser receiver's 35 ms inter-byte timeout, and far below
/// what the board's outgoing queue and the pty hold.
const STALL_BUDGET_MS: f64 = 30.0;
/// Scans a starved firmware's count of those it missed may be short by.
const WALL_CLOCK_COUNT_SLACK: u64 = 2;

/// What the board counted as lost in a run the machine starved (see
/// [`bringup::BringUpReport::longest_stall_ms`]), else nothing: `(scans, fixes)`. Losses the
/// board did not count are never excused.
fn excused_losses(report: &bringup::BringUpReport) -> (u64, u64) {
    if report.longest_stall_ms <= STALL_BUDGET_MS {
        return (0, 0);
    }
    println!(
        "the machine left the emulation without a core for {:.0} ms: the losses the board \
         counted are excused",
        report.longest_stall_ms
    );
    // The firmware counts the scans it missed by their stamps, which a starved board takes
    // late: the count may be off by the same slack as the QEMU run's (`tests/qemu_chain.rs`).
    report.board_status.map_or((0, 0), |status| {
        (
            u64::from(status.laser.missed)
                + u64::from(status.laser.dropped_frames)
                + WALL_CLOCK_COUNT_SLACK,
            u64::from(status.gps.dropped_frames),
        )
    })
}

#[test]
fn every_scan_and_fix_reaches_the_host() {
    let _turn = REAL_TIME
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let report = bringup::run(BringUpOptions {
        seconds: 7.0,
        progress: false,
        ..BringUpOptions::default()
    })
    .unwrap();
    let laser = &report.laser;
    assert_eq!(
        (laser.state, laser.baud),
        (LaserState::Streaming, 500_000),
        "{report:#?}"
    );
    assert_eq!(laser.values_per_scan, 361);
    assert!(laser.host_scans >= 60, "{report:#?}");
    let (excused_scans, excused_fixes) = excused_losses(&report);
    // The sensors stop, then the host drains the link: at most the scan the stop cut short
    // is missing.
    assert!(
        laser.emulator_scans_sent - laser.host_scans <= 1 + excused_scans,
        "{report:#?}"
    );
    if excused_scans == 0 {
        assert!((laser.scans_per_s - 37.5).abs() < 1.0, "{report:#?}");
    }
    let status = report.board_status.unwrap();
    // A gap in the scan counter is a scan the board dropped for a full queue, and counted.
    assert!(
        laser.scan_counter_gaps <= u64::from(status.laser.dropped_frames),
        "{report:#?}"
    );
    // No byte was lost for want of reading (the pty model of a UART overrun), unless the
    // firmware was left without a core: then the scans it cut are counted missed.
    if (excused_scans, excused_fixes) == (0, 0) {
        assert_eq!(
            laser.emulator_bytes_dropped + report.gps.emulator_bytes_dropped,
            0
        );
    }
    assert!(
        report.gps.host_fixes + excused_fixes >= 2 * (report.gps.emulator_epochs - 1),
        "{report:#?}"
    );
    // Frames go missing on the link only as the board dropped them for a full queue.
    let dropped = u64::from(status.laser.dropped_frames) + u64::from(status.gps.dropped_frames);
    assert!(report.host_lost_frames <= dropped, "{report:#?}");
    assert_eq!(report.host_bad_frames, 0);
    assert_eq!(
        status.laser.crc_errors + status.laser.uart_overruns,
        0,
        "{report:#?}"
    );
    assert_eq!(status.gps.crc_errors + status.gps.uart_overruns, 0);
    if (excused_scans, excused_fixes) == (0, 0) {
        assert_eq!(
            status.laser.dropped_frames + status.gps.dropped_frames,
            0,
            "{report:#?}"
        );
    }
}

#[test]
fn laser_power_cycle_is_recovered() {
    let _turn = REAL_TIME
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let report = bringup::run(BringUpOptions {
        seconds: 14.0,
        laser_restart_s: Some(5.0),
        progress: false,
        ..BringUpOptions::default()
    })
    .unwrap();
    let laser = &report.laser;
    assert_eq!(
        (laser.state, laser.baud),
        (LaserState::Streaming, 500_000),
        "{report:#?}"
    );
    // Streaming before the restart (about 2 s) and again after it.
    assert!(laser.host_scans >= 150, "{report:#?}");
    // Missing at most: the scan the power cut short and the one the stop cut short.
    let (excused_scans, excused_fixes) = excused_losses(&report);
    assert!(
        laser.emulator_scans_sent - laser.host_scans <= 2 + excused_scans,
        "{report:#?}"
    );
    // Frames go missing on the link only as the board dropped them (and only when excused).
    assert!(
        report.host_lost_frames <= excused_scans + excused_fixes,
        "{report:#?}"
    );
}
