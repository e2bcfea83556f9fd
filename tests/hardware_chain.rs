//! End-to-end: `hil-sim run --hardware`, the wall-clock wiring that drives a flashed board on
//! real serial ports. A board the engine cannot look inside is stood in for by the firmware
//! tasks on wall-clock time behind pseudo-terminals; the engine sees only the device ends of
//! the lines, as it would see USB serial adapters, follows the laser's baud switches on them
//! and learns the board's counters from its status report.
//!
//! This file is its own process: the firmware here runs on the wall clock, which a virtual
//! session elsewhere in the process would take over.

use std::fs;

use firmware::sick::BringUpConfig;
use firmware::tasks::gps::GpsOptions;
use hil_sim::board::{self, BoardConfig};
use hil_sim::pty::PtyLink;
use hil_sim::run::{Line, RunOptions, WallLines, run_on};
use hil_sim::world::WorldKind;
use protocol::RangeUnit;

#[test]
fn a_board_on_serial_lines_is_driven_on_the_wall_clock_and_accounts_for_every_scan() {
    let out = std::env::temp_dir().join(format!("hil-hardware-{}", std::process::id()));
    let _ = fs::remove_dir_all(&out);
    let (laser, gps, host) = (
        PtyLink::open().expect("pty"),
        PtyLink::open().expect("pty"),
        PtyLink::open().expect("pty"),
    );
    // The board as flashed: GPS UART at 9 600 Bd, millimetre ranges indoors.
    let gps_baud = 9_600;
    let mut laser_config = BringUpConfig::default();
    laser_config.laser.unit = RangeUnit::Mm;
    let board = board::spawn(BoardConfig {
        laser_path: laser.board_path().into(),
        gps_path: gps.board_path().into(),
        host_path: host.board_path().into(),
        gps_baud,
        laser: laser_config,
        gps: GpsOptions::default(),
    })
    .expect("firmware");
    let options = RunOptions {
        world: WorldKind::Outdoor,
        seed: 3,
        duration_s: 8.0,
        // No byte faults: the firmware's slot count needs a line whose bytes arrive when they
        // are sent, which a loaded host's ptys do not promise; the lock-step runs
        // (run_chain.rs) test the count under faults.
        faults: hil_sim::faults::FaultSpec::default(),
        out: out.clone(),
        realtime: false,
        hardware: None,
        grid_every_scan: false,
        camera: None,
    };
    let lines = WallLines {
        laser: Line::Pty(laser),
        gps: Line::Pty(gps),
        host: Line::Pty(host),
        gps_baud,
        start: None,
    };
    let started = std::time::Instant::now();
    let summary = run_on(&options, Some(lines)).expect("run");
    board.stop();

    // Paced by the wall clock, not as fast as possible.
    assert!(started.elapsed().as_secs_f64() >= options.duration_s);
    assert!(summary.counted.final_status_received, "{summary:#?}");
    assert_eq!(summary.counted.final_laser_state, "Streaming");
    // The laser was brought up through its baud switch and streamed for seconds.
    assert!(summary.telegrams_emitted > 100, "{summary:#?}");
    assert_eq!(
        summary.telegrams_delivered_intact + summary.telegrams_counted_rejected,
        summary.telegrams_emitted,
        "{summary:#?}"
    );
    assert!(summary.accounting_balanced);
    // GPS at 9 600 Bd: fewer epochs fit, each delivered.
    assert!(summary.gps_fixes_emitted > 0);
    assert_eq!(summary.gps_fixes_delivered, summary.gps_fixes_emitted);
    assert!(out.join("trajectory.tsv").exists());
    let _ = fs::remove_dir_all(&out);
}
