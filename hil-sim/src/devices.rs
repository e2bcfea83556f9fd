//! Adapters that run an emulator on the device end of a [`PtyLink`] in a thread: the only
//! place where the emulators meet a wall clock and a port.
//!
//! Each adapter loops until its stop flag is set: it reads the host's bytes (waiting at most
//! until the emulator's next output, and never longer than [`MAX_WAIT_US`]) and passes them
//! to the emulator with the baud rate the board end is set to ([`PtyLink::board_baud`]); it
//! writes the bytes the emulator has sent by now, garbled ([`garble`]) when they were sent at
//! another rate than the board end listens at. Time is µs since the adapter started
//! ([`Instant`]), so the emulator sees it powered on when the thread starts.
//!
//! A pty carries bytes as fast as it can, so pacing comes from the emulator; the output
//! reaches the board in bursts of up to [`MAX_WAIT_US`]. When the board does not read and the
//! pty's buffer is full for [`WRITE_TIMEOUT_US`], the bytes are dropped and counted, as a
//! UART receiver overrun would lose them.
//!
//! The thread returns the emulator (with its counters), the link, and the I/O error that
//! ended it, if any. A channel of [`LmsCommand`]s / [`GpsCommand`]s steers the emulator
//! from outside (power cycle, move the sensor, lose the fix), and
//! [`LmsDeviceOptions::power_cycle_at_us`] schedules a power cycle.

use std::io::{self, Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use serialport::SerialPort;

use crate::emulators::{GpsEmulator, GpsTruth, Lms2xx, TxRun, garble};
use crate::pty::PtyLink;
use crate::world::{SensorPose, World};

/// The longest the adapter waits before looking at the stop flag and commands again, µs.
pub const MAX_WAIT_US: u64 = 2_000;
/// The shortest wait, µs.
const MIN_WAIT_US: u64 = 50;
/// How long a write may wait for room in the pty before its bytes are dropped, µs.
pub const WRITE_TIMEOUT_US: u64 = 20_000;

/// A command to a running LMS emulator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LmsCommand {
    /// Switch the sensor off and on now.
    PowerCycle,
    /// Move the sensor.
    SetPose(SensorPose),
}

/// A command to a running GPS emulator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GpsCommand {
    /// Gain (`true`) or lose the fix.
    SetFix(bool),
    /// Set the true position and motion.
    SetTruth(GpsTruth),
}

/// How to run an LMS adapter.
#[derive(Debug, Default)]
pub struct LmsDeviceOptions {
    /// Power-cycle the sensor once, this many µs after the adapter started.
    pub power_cycle_at_us: Option<u64>,
    /// Commands from outside, carried out as they arrive.
    pub commands: Option<Receiver<LmsCommand>>,
}

/// How to run a GPS adapter.
#[derive(Debug, Default)]
pub struct GpsDeviceOptions {
    /// Commands from outside, carried out as they arrive.
    pub commands: Option<Receiver<GpsCommand>>,
}

/// What an adapter thread returns.
pub struct DeviceExit<E> {
    /// The emulator, with its counters.
    pub emulator: E,
    /// The pty link.
    pub link: PtyLink,
    /// Bytes dropped because the board did not read them.
    pub bytes_dropped: u64,
    /// The longest the adapter woke later than it asked to, µs: how long the machine left it
    /// without a core. The emulated line pauses that long where a real sensor's never does.
    pub longest_stall_us: u64,
    /// The I/O error that ended the adapter; `None` when it was stopped.
    pub error: Option<io::Error>,
}

impl<E: core::fmt::Debug> core::fmt::Debug for DeviceExit<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("DeviceExit")
            .field("emulator", &self.emulator)
            .field("link", &self.link.board_path())
            .field("bytes_dropped", &self.bytes_dropped)
            .field("longest_stall_us", &self.longest_stall_us)
            .field("error", &self.error)
            .finish()
    }
}

/// What the adapter loop needs from an emulator.
trait Emulated {
    fn receive(&mut self, bytes: &[u8], host_baud: u32, now_us: u64);
    fn poll_runs(&mut self, now_us: u64) -> Vec<TxRun>;
    fn next_us(&self) -> Option<u64>;
}

impl<W: World> Emulated for Lms2xx<W> {
    fn receive(&mut self, bytes: &[u8], host_baud: u32, now_us: u64) {
        Lms2xx::receive(self, bytes, host_baud, now_us);
    }

    fn poll_runs(&mut self, now_us: u64) -> Vec<TxRun> {
        self.poll_output_runs(now_us)
    }

    fn next_us(&self) -> Option<u64> {
        self.next_output_us()
    }
}

impl Emulated for GpsEmulator {
    fn receive(&mut self, _bytes: &[u8], _host_baud: u32, _now_us: u64) {
        // Configuration sentences from the host are not emulated.
    }

    fn poll_runs(&mut self, now_us: u64) -> Vec<TxRun> {
        self.poll_output_runs(now_us)
    }

    fn next_us(&self) -> Option<u64> {
        self.next_output_us()
    }
}

/// Runs `lms` on `link` until `stop` is set.
pub fn spawn_lms<W: World + Send + 'static>(
    link: PtyLink,
    lms: Lms2xx<W>,
    stop: Arc<AtomicBool>,
) -> JoinHandle<DeviceExit<Lms2xx<W>>> {
    spawn_lms_with(link, lms, stop, LmsDeviceOptions::default())
}

/// Runs `lms` on `link` until `stop` is set, with a scheduled power cycle and commands.
pub fn spawn_lms_with<W: World + Send + 'static>(
    link: PtyLink,
    lms: Lms2xx<W>,
    stop: Arc<AtomicBool>,
    options: LmsDeviceOptions,
) -> JoinHandle<DeviceExit<Lms2xx<W>>> {
    thread::spawn(move || {
        let mut power_cycle_at_us = options.power_cycle_at_us;
        run(link, lms, &stop, move |lms: &mut Lms2xx<W>, now_us| {
            if power_cycle_at_us.is_some_and(|at_us| now_us >= at_us) {
                power_cycle_at_us = None;
                lms.power_cycle(now_us);
            }
            for command in options.commands.iter().flat_map(Receiver::try_iter) {
                match command {
                    LmsCommand::PowerCycle => lms.power_cycle(now_us),
                    LmsCommand::SetPose(pose) => lms.set_pose(pose),
                }
            }
        })
    })
}

/// Runs `gps` on `link` until `stop` is set.
pub fn spawn_gps(
    link: PtyLink,
    gps: GpsEmulator,
    stop: Arc<AtomicBool>,
) -> JoinHandle<DeviceExit<GpsEmulator>> {
    spawn_gps_with(link, gps, stop, GpsDeviceOptions::default())
}

/// Runs `gps` on `link` until `stop` is set, with commands.
pub fn spawn_gps_with(
    link: PtyLink,
    gps: GpsEmulator,
    stop: Arc<AtomicBool>,
    options: GpsDeviceOptions,
) -> JoinHandle<DeviceExit<GpsEmulator>> {
    thread::spawn(move || {
        run(link, gps, &stop, move |gps: &mut GpsEmulator, _now_us| {
            for command in options.commands.iter().flat_map(Receiver::try_iter) {
                match command {
                    GpsCommand::SetFix(has_fix) => gps.set_fix(has_fix),
                    GpsCommand::SetTruth(truth) => gps.set_truth_state(truth),
                }
            }
        })
    })
}

/// The adapter loop. `on_tick` runs before each poll with the current time.
fn run<E: Emulated>(
    mut link: PtyLink,
    mut emulator: E,
    stop: &AtomicBool,
    mut on_tick: impl FnMut(&mut E, u64),
) -> DeviceExit<E> {
    let start = Instant::now();
    let now_us = || u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX);
    let mut bytes_dropped = 0;
    let mut longest_stall_us = 0;
    // When the last wait was to end at the latest.
    let mut wake_by_us: Option<u64> = None;
    let mut buf = [0u8; 4096];
    let error = loop {
        if stop.load(Ordering::Relaxed) {
            break None;
        }
        let now = now_us();
        if let Some(by_us) = wake_by_us {
            longest_stall_us = longest_stall_us.max(now.saturating_sub(by_us));
        }
        on_tick(&mut emulator, now);
        let board_baud = match link.board_baud() {
            Ok(baud) => baud,
            Err(e) => break Some(e),
        };
        let runs = emulator.poll_runs(now);
        match write_runs(&mut link, &runs, board_baud) {
            Ok(dropped) => bytes_dropped += dropped,
            Err(e) => break Some(e),
        }
        let wait_us = emulator
            .next_us()
            .map_or(MAX_WAIT_US, |at_us| at_us.saturating_sub(now_us()))
            .clamp(MIN_WAIT_US, MAX_WAIT_US);
        if let Err(e) = link.device.set_timeout(Duration::from_micros(wait_us)) {
            break Some(io::Error::other(e));
        }
        wake_by_us = Some(now_us() + wait_us);
        match link.device.read(&mut buf) {
            Ok(n) => {
                let host_baud = match link.board_baud() {
                    Ok(baud) => baud,
                    Err(e) => break Some(e),
                };
                emulator.receive(&buf[..n], host_baud, now_us());
            }
            Err(e) if is_transient(&e) => {}
            Err(e) => break Some(e),
        }
    };
    DeviceExit {
        emulator,
        link,
        bytes_dropped,
        longest_stall_us,
        error,
    }
}

/// Writes the runs as the board end hears them; returns the bytes dropped for lack of room.
fn write_runs(link: &mut PtyLink, runs: &[TxRun], board_baud: u32) -> io::Result<u64> {
    if runs.is_empty() {
        return Ok(0);
    }
    link.device
        .set_timeout(Duration::from_micros(WRITE_TIMEOUT_US))
        .map_err(io::Error::other)?;
    let mut dropped = 0;
    for run in runs {
        let heard = garble(&run.bytes, run.baud, board_baud);
        let mut rest = &heard[..];
        while !rest.is_empty() {
            match link.device.write(rest) {
                Ok(0) => break,
                Ok(n) => rest = &rest[n..],
                Err(e) if is_transient(&e) => break,
                Err(e) => return Err(e),
            }
        }
        dropped += rest.len() as u64;
    }
    Ok(dropped)
}

/// Errors that only mean "nothing happened in time".
fn is_transient(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::{GpsEmulatorOptions, Lms2xxOptions};
    use firmware::nmea::GpsReceiver;
    use firmware::sick::{Reply, Telegram};
    use serialport::TTYPort;
    use std::path::Path;
    use std::sync::mpsc;

    const STATUS_REQUEST: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12];

    fn open_board(path: &Path, baud: u32) -> TTYPort {
        let mut port = serialport::new(path.to_string_lossy(), baud)
            .timeout(Duration::from_millis(50))
            .open_native()
            .unwrap();
        port.set_exclusive(false).unwrap();
        port
    }

    /// Reads until `len` bytes arrived or `timeout` passed.
    fn read_for(port: &mut TTYPort, len: usize, timeout: Duration) -> Vec<u8> {
        let deadline = Instant::now() + timeout;
        let mut got = Vec::new();
        let mut buf = [0u8; 1024];
        while got.len() < len && Instant::now() < deadline {
            match port.read(&mut buf) {
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(e) if is_transient(&e) => {}
                Err(e) => panic!("{e}"),
            }
        }
        got
    }

    fn quiet_lms() -> Lms2xx {
        Lms2xx::new(Lms2xxOptions {
            send_power_on: false,
            ..Lms2xxOptions::default()
        })
    }

    #[test]
    fn status_request_over_a_pty() {
        let link = PtyLink::open().unwrap();
        let path = link.board_path().to_owned();
        let mut port = open_board(&path, 9_600);
        let stop = Arc::new(AtomicBool::new(false));
        let handle = spawn_lms(link, quiet_lms(), Arc::clone(&stop));
        port.write_all(&STATUS_REQUEST).unwrap();
        let got = read_for(&mut port, 1 + 160, Duration::from_secs(3));
        assert_eq!(got.len(), 161);
        assert_eq!(got[0], 0x06);
        let telegram = Telegram::new_checked(&got[1..]).unwrap();
        assert_eq!(telegram.check_crc(), Ok(()));
        let Ok(Reply::Status(status)) = Reply::parse(&telegram) else {
            panic!("{got:02X?}")
        };
        assert_eq!(status.baud_code, 0x8067);
        // At another rate the request is not understood.
        port.set_baud_rate(38_400).unwrap();
        port.write_all(&STATUS_REQUEST).unwrap();
        assert!(read_for(&mut port, 1, Duration::from_millis(300)).is_empty());
        stop.store(true, Ordering::Relaxed);
        let exit = handle.join().unwrap();
        assert!(exit.error.is_none(), "{:?}", exit.error);
        let c = exit.emulator.counters();
        assert_eq!((c.requests, c.acks, c.replies), (1, 1, 1));
        assert_eq!(c.garbage_bytes, 7);
        assert_eq!(c.bytes_sent, 161);
    }

    #[test]
    fn power_cycle_command_over_a_pty() {
        let link = PtyLink::open().unwrap();
        let mut port = open_board(link.board_path(), 9_600);
        let stop = Arc::new(AtomicBool::new(false));
        let (commands, receiver) = mpsc::channel();
        let options = LmsDeviceOptions {
            power_cycle_at_us: None,
            commands: Some(receiver),
        };
        let handle = spawn_lms_with(link, quiet_lms(), Arc::clone(&stop), options);
        commands.send(LmsCommand::PowerCycle).unwrap();
        // 90h after 0.7 s: 29 bytes at 9 600 Bd.
        let got = read_for(&mut port, 29, Duration::from_secs(3));
        let telegram = Telegram::new_checked(&got[..]).unwrap();
        assert!(matches!(Reply::parse(&telegram), Ok(Reply::PowerOn { .. })));
        stop.store(true, Ordering::Relaxed);
        let exit = handle.join().unwrap();
        assert_eq!(exit.emulator.counters().power_on_messages, 1);
    }

    #[test]
    fn gps_sentences_over_a_pty() {
        let link = PtyLink::open().unwrap();
        let mut port = open_board(link.board_path(), 115_200);
        let stop = Arc::new(AtomicBool::new(false));
        let gps = GpsEmulator::new(GpsEmulatorOptions::default());
        let handle = spawn_gps(link, gps, Arc::clone(&stop));
        let got = read_for(&mut port, 2_000, Duration::from_millis(700));
        stop.store(true, Ordering::Relaxed);
        let exit = handle.join().unwrap();
        assert!(exit.error.is_none());
        let mut receiver = GpsReceiver::new();
        let mut fixes = 0;
        receiver.push(&got, 0, |s| fixes += usize::from(s.fix.is_some()));
        assert!(fixes >= 4, "{fixes} fixes in {} bytes", got.len());
        assert_eq!(receiver.stats().bad_checksum, 0);
    }
}
