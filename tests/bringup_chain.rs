//! The whole chain on emulated sensors, in real time over pseudo-terminals: the firmware
//! brings a freshly powered LMS200 up from 9 600 Bd to 500 kBd streaming at 0.5°, forwards
//! every scan and the 10 Hz GPS fixes, and the host receives them all; after a power cycle
//! of the sensor the firmware notices and brings it up again.

use std::sync::Mutex;

use hil_sim::bringup::{self, BringUpOptions};
use protocol::LaserState;

/// Each chain runs in real time on pseudo-terminals. Two at once on a two-core machine compete
/// for the cores its timing depends on (the emulated board stamps bytes when its threads read
/// them), so the tests take turns.
static REAL_TIME: Mutex<()> = Mutex::new(());

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
    // The sensors stop, then the host drains the link: at most the scan the stop cut short
    // is missing.
    assert!(
        laser.emulator_scans_sent - laser.host_scans <= 1,
        "{report:#?}"
    );
    assert!((laser.scans_per_s - 37.5).abs() < 1.0, "{report:#?}");
    assert_eq!(laser.scan_counter_gaps, 0);
    // No byte was lost for want of reading (the pty model of a UART overrun).
    assert_eq!(
        laser.emulator_bytes_dropped + report.gps.emulator_bytes_dropped,
        0
    );
    assert!(
        report.gps.host_fixes >= 2 * (report.gps.emulator_epochs - 1),
        "{report:#?}"
    );
    assert_eq!((report.host_lost_frames, report.host_bad_frames), (0, 0));
    let status = report.board_status.unwrap();
    assert_eq!(
        status.laser.crc_errors + status.laser.uart_overruns + status.laser.dropped_frames,
        0
    );
    assert_eq!(
        status.gps.crc_errors + status.gps.uart_overruns + status.gps.dropped_frames,
        0
    );
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
    assert!(
        laser.emulator_scans_sent - laser.host_scans <= 2,
        "{report:#?}"
    );
    assert_eq!(report.host_lost_frames, 0);
}
