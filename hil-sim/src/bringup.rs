//! A bring-up run on the wall clock: a freshly powered emulated LMS200 and a GPS receiver →
//! the firmware tasks on the host executor → the host link, read as the robot computer reads it.
//!
//! Everything runs through pseudo-terminals, so the firmware sees serial devices exactly as
//! it sees UARTs on the board; the emulators answer with the firmware's own emit code. The run
//! reports what each side counted, so that every scan and fix is accounted for: sent by the
//! emulator, received by the firmware, delivered to the host or dropped and counted.

use std::io::{self, Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use firmware::sick::BringUpConfig;
use firmware::tasks::gps::GpsOptions;
use host::link::{LinkReader, TimeSync};
use protocol::{Encoder, GpsFixMsg, LaserState, MAX_WIRE_LEN, Message, StatusMsg};
use serde::Serialize;
use serialport::SerialPort;

use crate::board::{self, BoardConfig};
use crate::devices::{self, GpsDeviceOptions, LmsDeviceOptions};
use crate::emulators::{GpsEmulator, GpsEmulatorOptions, GpsTruth, Lms2xx, Lms2xxOptions};
use crate::pty::PtyLink;

/// Options of the bring-up run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BringUpOptions {
    /// How long to run, seconds.
    pub seconds: f64,
    /// GPS epochs per second (1–10).
    pub gps_rate_hz: u32,
    /// Power-cycle the laser this many seconds into the run.
    pub laser_restart_s: Option<f64>,
    /// Seed of the emulators' noise.
    pub seed: u64,
    /// Print the laser state changes on stderr as they happen.
    pub progress: bool,
}

impl Default for BringUpOptions {
    fn default() -> Self {
        BringUpOptions {
            seconds: 8.0,
            gps_rate_hz: 10,
            laser_restart_s: None,
            seed: 1,
            progress: true,
        }
    }
}

/// What the laser side counted.
#[derive(Debug, Clone, Serialize)]
pub struct LaserReport {
    /// Final bring-up state.
    pub state: LaserState,
    /// Final baud rate.
    pub baud: u32,
    /// Seconds from the start until the first scan reached the host.
    pub first_scan_s: Option<f64>,
    /// Scans the emulated sensor sent.
    pub emulator_scans_sent: u64,
    /// Scans the emulated sensor could not send because the line was busy (low baud).
    pub emulator_scans_skipped: u64,
    /// Scans that reached the host.
    pub host_scans: u64,
    /// Scans per second, from the board time stamps of the first and the last scan.
    pub scans_per_s: f64,
    /// Bytes the emulated sensor could not deliver because the firmware did not read them in
    /// time (what a UART overrun loses on hardware).
    pub emulator_bytes_dropped: u64,
    /// Gaps in the firmware's scan counter seen by the host (scans dropped on the board).
    pub scan_counter_gaps: u64,
    /// Range values per scan in the last scan.
    pub values_per_scan: usize,
}

/// What the GPS side counted.
#[derive(Debug, Clone, Serialize)]
pub struct GpsReport {
    /// Epochs the emulated receiver sent.
    pub emulator_epochs: u64,
    /// Fix reports that reached the host (one per GGA and one per RMC).
    pub host_fixes: u64,
    /// Bytes the emulated receiver could not deliver because the firmware did not read them.
    pub emulator_bytes_dropped: u64,
    /// The last position received, degrees.
    pub last_lat_deg: Option<f64>,
    /// The last position received, degrees.
    pub last_lon_deg: Option<f64>,
}

/// The outcome of a bring-up run.
#[derive(Debug, Clone, Serialize)]
pub struct BringUpReport {
    /// Seconds run.
    pub seconds: f64,
    /// Laser accounting.
    pub laser: LaserReport,
    /// GPS accounting.
    pub gps: GpsReport,
    /// Frames received by the host.
    pub host_frames: u64,
    /// Frames the host found missing (sequence gaps).
    pub host_lost_frames: u64,
    /// Frames the host rejected (CRC, COBS, malformed).
    pub host_bad_frames: u64,
    /// The board's last status report.
    pub board_status: Option<StatusMsg>,
    /// Drift of the board clock against the host's, ppm (the same clock here: near 0).
    pub clock_drift_ppm: f64,
    /// The longest an emulator, the firmware or the host's reader was left without a core
    /// beyond its own wait, ms. A real sensor's line never pauses and a real host keeps reading; on a busy
    /// machine the emulation can, and a pause longer than the telegram timeout (35 ms) or the
    /// board's outgoing queue loses scans, which the board then counts.
    pub longest_stall_ms: f64,
}

/// A circle of 20 m radius around the datum at 1.5 m/s.
fn trajectory(t_us: u64) -> GpsTruth {
    let radius_m = 20.0;
    let speed_mps = 1.5;
    let angle = speed_mps / radius_m * (t_us as f64 * 1e-6);
    GpsTruth {
        east_m: radius_m * angle.cos(),
        north_m: radius_m * angle.sin(),
        up_m: 0.0,
        speed_mps,
        course_deg: (360.0 - angle.to_degrees()).rem_euclid(360.0),
    }
}

/// Runs the bring-up and returns its report.
///
/// # Errors
/// When a pty cannot be opened or the host link fails.
pub fn run(options: BringUpOptions) -> io::Result<BringUpReport> {
    let laser_link = PtyLink::open()?;
    let gps_link = PtyLink::open()?;
    let mut host_link = PtyLink::open()?;

    let gps_options = GpsEmulatorOptions {
        rate_hz: options.gps_rate_hz,
        seed: options.seed,
        ..GpsEmulatorOptions::default()
    };
    let gps_baud = gps_options.baud;
    let board = board::spawn(BoardConfig {
        laser_path: laser_link.board_path().into(),
        gps_path: gps_link.board_path().into(),
        host_path: host_link.board_path().into(),
        gps_baud,
        laser: BringUpConfig::default(),
        gps: GpsOptions::default(),
    })?;

    let stop = Arc::new(AtomicBool::new(false));
    let lms = Lms2xx::new(Lms2xxOptions {
        seed: options.seed,
        ..Lms2xxOptions::default()
    });
    let lms_thread = devices::spawn_lms_with(
        laser_link,
        lms,
        stop.clone(),
        LmsDeviceOptions {
            power_cycle_at_us: options.laser_restart_s.map(|s| (s * 1e6) as u64),
            ..LmsDeviceOptions::default()
        },
    );
    let mut gps = GpsEmulator::new(gps_options);
    gps.set_trajectory(trajectory);
    let gps_thread =
        devices::spawn_gps_with(gps_link, gps, stop.clone(), GpsDeviceOptions::default());

    let host = read_host(&mut host_link.device, &options, &stop)?;
    let board_stall_us = board.executor.longest_wake_delay_us();
    board.stop();

    let lms = lms_thread
        .join()
        .map_err(|_| io::Error::other("laser emulator thread panicked"))?;
    let gps = gps_thread
        .join()
        .map_err(|_| io::Error::other("GPS emulator thread panicked"))?;
    let lms_counters = lms.emulator.counters();
    let gps_counters = gps.emulator.counters();

    let stats = host.reader.stats();
    let scan_span_s = match (host.first_scan_stamp_us, host.last_scan_stamp_us) {
        (Some(a), Some(b)) if b > a => (b - a) as f64 * 1e-6,
        _ => 0.0,
    };
    Ok(BringUpReport {
        seconds: options.seconds,
        laser: LaserReport {
            state: host
                .status
                .map_or(LaserState::DetectingBaud, |s| s.laser_state),
            baud: host.status.map_or(0, |s| s.laser_baud),
            first_scan_s: host.first_scan_s,
            emulator_scans_sent: u64::from(lms_counters.scans_sent),
            emulator_scans_skipped: u64::from(lms_counters.scans_skipped),
            host_scans: host.scans,
            scans_per_s: if scan_span_s > 0.0 {
                (host.scans.saturating_sub(1)) as f64 / scan_span_s
            } else {
                0.0
            },
            scan_counter_gaps: host.scan_counter_gaps,
            values_per_scan: host.values_per_scan,
            emulator_bytes_dropped: lms.bytes_dropped,
        },
        gps: GpsReport {
            emulator_epochs: u64::from(gps_counters.epochs),
            host_fixes: host.fixes,
            emulator_bytes_dropped: gps.bytes_dropped,
            last_lat_deg: host.last_fix.and_then(|f| f.position).map(|p| p.lat_deg()),
            last_lon_deg: host.last_fix.and_then(|f| f.position).map(|p| p.lon_deg()),
        },
        host_frames: stats.frames,
        host_lost_frames: stats.lost,
        host_bad_frames: stats.crc_errors
            + stats.cobs_errors
            + stats.malformed
            + stats.truncated
            + stats.oversize,
        board_status: host.status,
        clock_drift_ppm: host.sync.clock().drift_ppm(),
        longest_stall_ms: lms
            .longest_stall_us
            .max(gps.longest_stall_us)
            .max(host.longest_stall_us)
            .max(board_stall_us) as f64
            * 1e-3,
    })
}

/// What the host side saw.
struct HostView {
    reader: LinkReader,
    sync: TimeSync,
    status: Option<StatusMsg>,
    scans: u64,
    first_scan_s: Option<f64>,
    first_scan_stamp_us: Option<u64>,
    last_scan_stamp_us: Option<u64>,
    last_scan_counter: Option<u32>,
    scan_counter_gaps: u64,
    values_per_scan: usize,
    fixes: u64,
    last_fix: Option<GpsFixMsg>,
    /// The longest a read returned after its timeout, µs (see
    /// [`BringUpReport::longest_stall_ms`]).
    longest_stall_us: u64,
}

/// After the sensors stop, how long the host keeps reading so that what is in flight arrives.
const DRAIN_S: f64 = 0.5;
/// The longest the host drains after the sensors stopped, s.
const MAX_DRAIN_S: f64 = 5.0;

/// Reads the host link for the run's duration, pinging the board once a second; then stops
/// the sensors (`stop`) and reads on until no scan or fix came for [`DRAIN_S`] (at most
/// [`MAX_DRAIN_S`]), so that what a busy machine held back still arrives.
fn read_host(
    port: &mut serialport::TTYPort,
    options: &BringUpOptions,
    stop: &AtomicBool,
) -> io::Result<HostView> {
    let read_timeout = Duration::from_millis(20);
    port.set_timeout(read_timeout).map_err(io::Error::other)?;
    let start = Instant::now();
    let mut view = HostView {
        reader: LinkReader::new(),
        sync: TimeSync::new(),
        status: None,
        scans: 0,
        first_scan_s: None,
        first_scan_stamp_us: None,
        last_scan_stamp_us: None,
        last_scan_counter: None,
        scan_counter_gaps: 0,
        values_per_scan: 0,
        fixes: 0,
        last_fix: None,
        longest_stall_us: 0,
    };
    let mut encoder = Encoder::new();
    let mut next_ping_s = 0.5;
    let mut last_state = None;
    let mut buf = [0u8; 8192];
    let mut last_reading_s = 0.0_f64;
    loop {
        let elapsed_s = start.elapsed().as_secs_f64();
        let drained = elapsed_s >= options.seconds + DRAIN_S
            && elapsed_s >= last_reading_s.max(options.seconds) + DRAIN_S;
        if drained || elapsed_s >= options.seconds + MAX_DRAIN_S {
            break;
        }
        let now_s = start.elapsed().as_secs_f64();
        if now_s >= options.seconds {
            stop.store(true, Ordering::Relaxed);
        }
        if now_s >= next_ping_s {
            next_ping_s += 1.0;
            let mut out = [0u8; MAX_WIRE_LEN];
            let ping = view.sync.ping(encoder.next_seq(), now_s);
            let frame = encoder
                .encode(&ping, &mut out)
                .map_err(|e| io::Error::other(e.to_string()))?;
            port.write_all(frame)?;
        }
        let read_started = Instant::now();
        let read = port.read(&mut buf);
        let late = read_started.elapsed().saturating_sub(read_timeout);
        view.longest_stall_us = view
            .longest_stall_us
            .max(u64::try_from(late.as_micros()).unwrap_or(u64::MAX));
        let n = match read {
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::TimedOut => continue,
            Err(e) => return Err(e),
        };
        let recv_s = start.elapsed().as_secs_f64();
        for received in view.reader.feed(&buf[..n]) {
            view.sync.observe(&received.message, recv_s);
            match received.message {
                Message::Scan(scan) => {
                    last_reading_s = recv_s;
                    view.scans += 1;
                    view.first_scan_s.get_or_insert(recv_s);
                    view.first_scan_stamp_us.get_or_insert(scan.stamp_us);
                    view.last_scan_stamp_us = Some(scan.stamp_us);
                    if let Some(last) = view.last_scan_counter {
                        view.scan_counter_gaps +=
                            u64::from(scan.scan_counter.wrapping_sub(last).saturating_sub(1));
                    }
                    view.last_scan_counter = Some(scan.scan_counter);
                    view.values_per_scan = scan.values.len();
                }
                Message::GpsFix(fix) => {
                    last_reading_s = recv_s;
                    view.fixes += 1;
                    view.last_fix = Some(fix);
                }
                Message::Status(status) => {
                    let state = (status.laser_state, status.laser_baud);
                    if options.progress && last_state != Some(state) {
                        eprintln!("[{recv_s:6.2} s] laser {:?} at {} Bd", state.0, state.1);
                    }
                    last_state = Some(state);
                    view.status = Some(status);
                }
                _ => {}
            }
        }
    }
    Ok(view)
}
