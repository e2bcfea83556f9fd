//! `hil-sim run --qemu`: the firmware image for QEMU's `netduinoplus2` machine
//! (`firmware/qemu`, built for thumbv7em-none-eabihf) booted in `qemu-system-arm`, driven by
//! the same emulators and host as every run, over the wall-clock wiring of `--hardware`.
//!
//! * **Lines**: four pseudo-terminals, whose board ends QEMU opens as the machine's USART1,
//!   USART2, USART3 and UART4 (`-serial /dev/pts/N`, in that order). USART1 carries the
//!   image's debug lines (`firmware/qemu/src/debug.rs`); USART2, USART3 and UART4 are the host
//!   link, the laser and the GPS, which [`QemuBoard::start`] returns as the engine's
//!   [`WallLines`]. Bytes the image writes wait in the pty until the engine reads them.
//! * **Start-up**: QEMU starts with its CPU stopped (`-S`). When the run's clock starts (the
//!   emulated laser powers on), the lines' start hook sends the monitor's `cont` and waits for
//!   the image's `boot` line, which says that its USARTs listen and its tasks run: the board
//!   and the laser start together, as in the lock-step run.
//! * **Configuration**: the image streams the laser at [`IMAGE_LASER_BAUD`], not the board's
//!   500 kBd: QEMU's USART passes one byte per round trip through QEMU's event loop (20–27 kB/s
//!   measured on a busy host), less than a 500 kBd scan stream needs. Its `boot` line says
//!   the rate. A lock-step run with the image's configuration ([`image_bring_up`]) is
//!   [`crate::run::run_with_bring_up`].
//! * **Baud rates**: QEMU's USART passes every byte whatever its divider says. The image
//!   reports each rate it sets (`baud laser 500000`) before it sends at it, and the laser and
//!   GPS lines are [`Line::Emulated`]: bytes the emulators send at another rate are garbled as
//!   a real UART would hear them, as in the lock-step runs. The engine takes in the debug
//!   line's reports each time it asks for a rate, right after reading the board's bytes, so a
//!   request sent just after a rate change is heard at the new rate.
//! * **Time**: `-icount shift=3` runs the core at one instruction per 8 ns of QEMU's virtual
//!   clock (125 MIPS), on which the image counts its cycles: they count instructions, not the
//!   host's speed. The image's own clock is the host's, read by semihosting, since the virtual
//!   clock falls behind the wall (`firmware/qemu/src/time_driver.rs`).
//! * **Measurements**: the image's last `measure` line ([`Measurements`]), written to
//!   `OUT/qemu.json` beside the run's outputs; every debug line goes to `OUT/qemu-debug.log`.
//! * **Panics**: the image prints `panic …` on its debug line and QEMU exits; the run fails
//!   with that message.

use std::fs;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use firmware::sick::{BringUpConfig, LmsBaud};
use serde::Serialize;

use crate::pty::PtyLink;
use crate::run::{Line, ReportedBaud, RunOptions, RunSummary, WallLines, run_on};

/// Where `tests/run.sh` builds the image, relative to the repository root.
pub const DEFAULT_ELF: &str =
    "firmware/qemu/target/thumbv7em-none-eabihf/release/sensor-board-qemu";

/// The rate the image streams the laser at (`LASER_TARGET_BAUD` in `firmware/qemu`); the
/// image's `boot` line is checked against it.
pub const IMAGE_LASER_BAUD: LmsBaud = LmsBaud::B38400;

/// How the image brings the laser up: the board's default (180° at 0.5°, millimetres) at
/// [`IMAGE_LASER_BAUD`].
pub fn image_bring_up() -> BringUpConfig {
    BringUpConfig {
        target_baud: IMAGE_LASER_BAUD,
        ..BringUpConfig::default()
    }
}

/// The QEMU machine: STM32F405 at 168 MHz.
const MACHINE: &str = "netduinoplus2";
/// Virtual nanoseconds per instruction: 2^shift.
const ICOUNT_SHIFT: u32 = 3;
/// How long QEMU and the image get to start.
const START_TIMEOUT: Duration = Duration::from_secs(10);
/// The image writes its measurements every second; how long to wait for a fresh line.
const MEASURE_WAIT: Duration = Duration::from_millis(2_500);
/// Debug lines quoted in an error message.
const LOG_LINES: usize = 50;
/// How often the debug line's reader looks for new lines.
const DEBUG_POLL: Duration = Duration::from_millis(2);
/// The laser's rate at power-up, until the image says otherwise.
const LASER_POWER_UP_BAUD: u32 = 9_600;
/// The rate the image's GPS USART listens at (`GPS_BAUD` in `firmware/qemu`), and so the rate
/// the emulated receiver sends at, as in the lock-step run.
const GPS_BAUD: u32 = 115_200;

/// How to run QEMU.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct QemuOptions {
    /// The `qemu-system-arm` executable.
    pub qemu: PathBuf,
    /// The firmware image (`sensor-board-qemu` ELF).
    pub elf: PathBuf,
}

impl QemuOptions {
    /// `qemu-system-arm` from the `PATH`, booting `elf`.
    pub fn new(elf: impl Into<PathBuf>) -> QemuOptions {
        QemuOptions {
            qemu: PathBuf::from("qemu-system-arm"),
            elf: elf.into(),
        }
    }
}

/// What went wrong around QEMU.
#[derive(Debug, thiserror::Error)]
pub enum QemuError {
    /// The image file is not there.
    #[error("{}: no firmware image (build it: cd firmware/qemu && cargo build --release)", .0.display())]
    NoImage(PathBuf),
    /// QEMU could not be started.
    #[error("cannot start {}: {source}", program.display())]
    Spawn {
        /// The executable.
        program: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// The image streams the laser at another rate than [`IMAGE_LASER_BAUD`].
    #[error("the firmware image streams the laser at {image} Bd, hil-sim expects {expected} Bd")]
    LaserBaud {
        /// What the image said.
        image: u32,
        /// [`IMAGE_LASER_BAUD`].
        expected: u32,
    },
    /// The image did not print its `boot` line.
    #[error(
        "the firmware did not boot within {START_TIMEOUT:?}; its debug lines: {log:?}; \
         QEMU said: {stderr}"
    )]
    NoBoot {
        /// The debug lines received.
        log: Vec<String>,
        /// QEMU's standard error.
        stderr: String,
    },
    /// The image panicked.
    #[error("the firmware panicked: {0}")]
    Panicked(String),
    /// A port, a pipe or an output file failed.
    #[error(transparent)]
    Io(#[from] io::Error),
}

/// The image's measurements, from its last `measure` debug line.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Measurements {
    /// Deepest stack use since boot (painted stack), bytes.
    pub stack_used_bytes: u64,
    /// The stack's size, bytes.
    pub stack_bytes: u64,
    /// Longest time from a laser telegram's last byte to its scan frame's first byte on the
    /// host link, core cycles.
    pub latency_max_cycles: u64,
    /// Scan frames measured.
    pub latency_samples: u64,
    /// The core clock the cycles count, Hz.
    pub core_hz: u64,
}

impl Measurements {
    /// Parses `measure key=value …`; `None` for any other line.
    fn parse(line: &str) -> Option<Measurements> {
        let rest = line.strip_prefix("measure ")?;
        let mut m = Measurements::default();
        for pair in rest.split_whitespace() {
            let (key, value) = pair.split_once('=')?;
            let value: u64 = value.parse().ok()?;
            match key {
                "stack_used_bytes" => m.stack_used_bytes = value,
                "stack_bytes" => m.stack_bytes = value,
                "latency_max_cycles" => m.latency_max_cycles = value,
                "latency_samples" => m.latency_samples = value,
                "core_hz" => m.core_hz = value,
                _ => {}
            }
        }
        Some(m)
    }

    /// [`Self::latency_max_cycles`] in microseconds of the emulated core.
    pub fn latency_max_us(&self) -> f64 {
        if self.core_hz == 0 {
            return 0.0;
        }
        self.latency_max_cycles as f64 * 1e6 / self.core_hz as f64
    }

    /// [`Self::latency_max_cycles`] as instructions executed: under `-icount` every instruction
    /// takes 2^shift ns of the clock the cycles count.
    pub fn latency_max_instructions(&self) -> u64 {
        (self.latency_max_us() * 1e3 / f64::from(1u32 << ICOUNT_SHIFT)).round() as u64
    }
}

/// `OUT/qemu.json`: what the emulated run measured.
#[derive(Debug, Clone, Serialize)]
pub struct QemuReport {
    /// The image booted.
    pub elf: PathBuf,
    /// The machine.
    pub machine: &'static str,
    /// Virtual ns per instruction (`-icount shift`).
    pub ns_per_instruction: u32,
    /// The image's last measurements.
    pub measurements: Measurements,
    /// Longest telegram-to-frame time, µs of the emulated core.
    pub latency_max_us: f64,
    /// Longest telegram-to-frame time, instructions.
    pub latency_max_instructions: u64,
}

/// What the debug line has said so far.
#[derive(Debug, Default)]
struct DebugLog {
    booted: bool,
    /// The image's laser streaming rate, from its `boot` line.
    laser_target_baud: Option<u32>,
    panic: Option<String>,
    measurements: Option<Measurements>,
    measure_lines: u64,
    /// Every line, with the wall time since the first, s.
    all: Vec<(f64, String)>,
    started: Option<Instant>,
}

impl DebugLog {
    /// The last [`LOG_LINES`] lines.
    fn recent(&self) -> Vec<String> {
        let from = self.all.len().saturating_sub(LOG_LINES);
        self.all[from..]
            .iter()
            .map(|(_, line)| line.clone())
            .collect()
    }
}

/// The debug line's reader and what it found.
struct DebugChannel {
    /// The debug line, read by whoever needs its news first: the reader thread, or the
    /// engine asking for a UART's rate ([`ReportedUart`]).
    reader: Mutex<DebugReader>,
    log: Mutex<DebugLog>,
    changed: Condvar,
    laser_baud: Arc<AtomicU32>,
    gps_baud: Arc<AtomicU32>,
    stop: AtomicBool,
}

/// The debug pty and the start of a line not complete yet.
struct DebugReader {
    link: Option<PtyLink>,
    pending: Vec<u8>,
}

impl DebugChannel {
    fn new(link: Option<PtyLink>) -> DebugChannel {
        DebugChannel {
            reader: Mutex::new(DebugReader {
                link,
                pending: Vec::new(),
            }),
            log: Mutex::new(DebugLog::default()),
            changed: Condvar::new(),
            laser_baud: Arc::new(AtomicU32::new(LASER_POWER_UP_BAUD)),
            gps_baud: Arc::new(AtomicU32::new(GPS_BAUD)),
            stop: AtomicBool::new(false),
        }
    }

    fn lock(&self) -> MutexGuard<'_, DebugLog> {
        self.log.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Takes in every complete line the image has written so far, without waiting.
    ///
    /// # Errors
    /// When the pty fails (QEMU exited).
    fn pump(&self) -> io::Result<()> {
        let mut reader = self.reader.lock().unwrap_or_else(PoisonError::into_inner);
        let DebugReader { link, pending } = &mut *reader;
        let Some(link) = link.as_mut() else {
            return Ok(());
        };
        crate::pty::read_available(&mut link.device, pending)?;
        // In order, still holding the reader: a concurrent pump sees the lines after these.
        while let Some(end) = pending.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = pending.drain(..=end).collect();
            self.on_line(String::from_utf8_lossy(&line).trim_end());
        }
        Ok(())
    }

    fn on_line(&self, line: &str) {
        let mut log = self.lock();
        if let Some(rest) = line.strip_prefix("baud ") {
            let mut words = rest.split_whitespace();
            if let (Some(name), Some(Ok(baud))) = (words.next(), words.next().map(str::parse)) {
                match name {
                    "laser" => self.laser_baud.store(baud, Ordering::SeqCst),
                    "gps" => self.gps_baud.store(baud, Ordering::SeqCst),
                    _ => {}
                }
            }
        } else if let Some(rest) = line.strip_prefix("boot") {
            log.booted = true;
            log.laser_target_baud = rest
                .split_whitespace()
                .find_map(|pair| pair.strip_prefix("laser_target_baud="))
                .and_then(|baud| baud.parse().ok());
        } else if line.starts_with("panic") {
            log.panic = Some(line.to_owned());
        } else if let Some(m) = Measurements::parse(line) {
            log.measurements = Some(m);
            log.measure_lines += 1;
        }
        let at_s = log
            .started
            .get_or_insert_with(Instant::now)
            .elapsed()
            .as_secs_f64();
        log.all.push((at_s, line.to_owned()));
        self.changed.notify_all();
    }

    /// Waits until `done` holds or `timeout` passes; returns whether it holds.
    fn wait_for(&self, timeout: Duration, done: impl Fn(&DebugLog) -> bool) -> bool {
        let deadline = Instant::now() + timeout;
        let mut log = self.lock();
        while !done(&log) {
            let Some(left) = deadline.checked_duration_since(Instant::now()) else {
                return false;
            };
            log = self
                .changed
                .wait_timeout(log, left)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
        true
    }
}

/// Lets QEMU's CPU run and waits for the image's `boot` line.
fn release(
    monitor: &Mutex<ChildStdin>,
    debug: &DebugChannel,
    stderr: &Mutex<String>,
) -> Result<(), QemuError> {
    {
        let mut monitor = monitor.lock().unwrap_or_else(PoisonError::into_inner);
        monitor.write_all(b"cont\n")?;
        monitor.flush()?;
    }
    if !debug.wait_for(START_TIMEOUT, |log| log.booted || log.panic.is_some()) {
        let log = debug.lock().recent();
        let stderr = stderr
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        return Err(QemuError::NoBoot { log, stderr });
    }
    let log = debug.lock();
    if let Some(panic) = &log.panic {
        return Err(QemuError::Panicked(panic.clone()));
    }
    let expected = IMAGE_LASER_BAUD.baud();
    match log.laser_target_baud {
        Some(image) if image == expected => Ok(()),
        image => Err(QemuError::LaserBaud {
            image: image.unwrap_or(0),
            expected,
        }),
    }
}

/// Takes in the debug lines as they come until told to stop or the line fails.
fn read_debug(debug: Arc<DebugChannel>) {
    while !debug.stop.load(Ordering::SeqCst) {
        if debug.pump().is_err() {
            break;
        }
        thread::sleep(DEBUG_POLL);
    }
}

/// A USART's rate as the image reports it on its debug line ([`ReportedBaud`]).
struct ReportedUart {
    debug: Arc<DebugChannel>,
    baud: Arc<AtomicU32>,
}

impl ReportedBaud for ReportedUart {
    fn baud(&self) -> io::Result<u32> {
        // The image reports a new rate on its debug line before it sends at it.
        self.debug.pump()?;
        Ok(self.baud.load(Ordering::SeqCst))
    }
}

/// QEMU running the image.
pub struct QemuBoard {
    child: Child,
    /// QEMU's monitor; kept open while QEMU runs.
    monitor: Arc<Mutex<ChildStdin>>,
    stderr: Arc<Mutex<String>>,
    debug: Arc<DebugChannel>,
    reader: Option<JoinHandle<()>>,
}

impl core::fmt::Debug for QemuBoard {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("QemuBoard")
            .field("pid", &self.child.id())
            .finish_non_exhaustive()
    }
}

impl QemuBoard {
    /// Starts QEMU with the image, its CPU stopped, and returns it with the lines to its laser,
    /// GPS and host USARTs, whose start hook lets the CPU run and waits for the image to boot
    /// (failing with a [`QemuError`] inside the `io::Error` when it does not).
    ///
    /// # Errors
    /// When the image is missing, no pty is free, or QEMU cannot start.
    pub fn start(options: &QemuOptions) -> Result<(QemuBoard, WallLines), QemuError> {
        if !options.elf.is_file() {
            return Err(QemuError::NoImage(options.elf.clone()));
        }
        // In the order of QEMU's serial ports: USART1, USART2, USART3, UART4.
        let [debug, host, laser, gps] = [
            PtyLink::open()?,
            PtyLink::open()?,
            PtyLink::open()?,
            PtyLink::open()?,
        ];
        let mut command = Command::new(&options.qemu);
        command
            .args(["-M", MACHINE, "-nodefaults", "-display", "none", "-S"])
            .args(["-monitor", "stdio"])
            .args([
                "-icount".to_owned(),
                format!("shift={ICOUNT_SHIFT},align=off,sleep=on"),
            ])
            .args(["-semihosting-config", "enable=on,target=native"]);
        for link in [&debug, &host, &laser, &gps] {
            command.arg("-serial").arg(link.board_path());
        }
        command
            .arg("-kernel")
            .arg(&options.elf)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        let mut child = command.spawn().map_err(|source| QemuError::Spawn {
            program: options.qemu.clone(),
            source,
        })?;
        let (Some(monitor), Some(mut stderr_pipe)) = (child.stdin.take(), child.stderr.take())
        else {
            let _ = child.kill();
            let _ = child.wait();
            return Err(QemuError::Io(io::Error::other("QEMU's pipes are missing")));
        };
        // QEMU's standard error, kept for error messages.
        let stderr = Arc::new(Mutex::new(String::new()));
        {
            let stderr = Arc::clone(&stderr);
            thread::spawn(move || {
                let mut buf = [0u8; 1024];
                while let Ok(n @ 1..) = stderr_pipe.read(&mut buf) {
                    stderr
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner)
                        .push_str(&String::from_utf8_lossy(&buf[..n]));
                }
            });
        }
        let shared = Arc::new(DebugChannel::new(Some(debug)));
        let reader = {
            let shared = Arc::clone(&shared);
            thread::spawn(move || read_debug(shared))
        };
        let board = QemuBoard {
            child,
            monitor: Arc::new(Mutex::new(monitor)),
            stderr,
            debug: shared,
            reader: Some(reader),
        };
        let release = {
            let monitor = Arc::clone(&board.monitor);
            let debug = Arc::clone(&board.debug);
            let stderr = Arc::clone(&board.stderr);
            move || release(&monitor, &debug, &stderr).map_err(io::Error::other)
        };
        let lines = WallLines {
            laser: Line::Emulated {
                link: laser,
                board_baud: Arc::new(ReportedUart {
                    debug: Arc::clone(&board.debug),
                    baud: Arc::clone(&board.debug.laser_baud),
                }),
            },
            gps: Line::Emulated {
                link: gps,
                board_baud: Arc::new(ReportedUart {
                    debug: Arc::clone(&board.debug),
                    baud: Arc::clone(&board.debug.gps_baud),
                }),
            },
            host: Line::Pty(host),
            // The image's GPS USART, as it reports at boot (`gps_baud` above follows it).
            gps_baud: GPS_BAUD,
            start: Some(Box::new(release)),
        };
        Ok((board, lines))
    }

    /// The image's panic message, if it panicked.
    pub fn panic(&self) -> Option<String> {
        self.debug.lock().panic.clone()
    }

    /// The image's latest measurements, after waiting for a line written from now on (the
    /// image writes one every second).
    pub fn fresh_measurements(&self) -> Option<Measurements> {
        let seen = self.debug.lock().measure_lines;
        self.debug.wait_for(MEASURE_WAIT, |log| {
            log.measure_lines > seen || log.panic.is_some()
        });
        self.debug.lock().measurements
    }

    /// Every debug line so far, each after the wall-clock seconds since the first one.
    pub fn debug_log(&self) -> String {
        self.debug
            .lock()
            .all
            .iter()
            .map(|(at_s, line)| format!("{at_s:9.3} {line}\n"))
            .collect()
    }

    /// Stops QEMU.
    pub fn stop(mut self) {
        self.shut_down();
    }

    fn shut_down(&mut self) {
        self.debug.stop.store(true, Ordering::SeqCst);
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
    }
}

impl Drop for QemuBoard {
    fn drop(&mut self) {
        self.shut_down();
    }
}

/// `hil-sim run --qemu`: runs `options` against the image in QEMU, writes `OUT/qemu.json`
/// beside the run's outputs, and returns the summary and the measurements.
///
/// # Errors
/// As [`QemuBoard::start`]; when the run fails, the image panics, or an output cannot be
/// written.
pub fn run(
    options: &RunOptions,
    qemu: &QemuOptions,
) -> Result<(RunSummary, QemuReport), QemuError> {
    let (board, lines) = QemuBoard::start(qemu)?;
    let outcome = run_on(options, Some(lines));
    let measurements = board.fresh_measurements();
    let panic = board.panic();
    let log = board.debug_log();
    board.stop();
    if outcome.is_ok() {
        fs::write(options.out.join("qemu-debug.log"), log)?;
    }
    if let Some(panic) = panic {
        return Err(QemuError::Panicked(panic));
    }
    let summary = outcome?;
    let measurements = measurements.unwrap_or_default();
    let report = QemuReport {
        elf: qemu.elf.clone(),
        machine: MACHINE,
        ns_per_instruction: 1 << ICOUNT_SHIFT,
        measurements,
        latency_max_us: measurements.latency_max_us(),
        latency_max_instructions: measurements.latency_max_instructions(),
    };
    write_report(&options.out, &report)?;
    Ok((summary, report))
}

fn write_report(out: &Path, report: &QemuReport) -> io::Result<()> {
    let json = serde_json::to_string_pretty(report).map_err(io::Error::other)?;
    fs::write(out.join("qemu.json"), json + "\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measure_lines_are_parsed_and_converted() {
        let m = Measurements::parse(
            "measure stack_used_bytes=2048 stack_bytes=57948 latency_max_cycles=16800 \
             latency_samples=12 core_hz=168000000",
        )
        .unwrap();
        assert_eq!((m.stack_used_bytes, m.latency_samples), (2048, 12));
        assert!((m.latency_max_us() - 100.0).abs() < 1e-9);
        // 100 µs at 8 ns per instruction.
        assert_eq!(m.latency_max_instructions(), 12_500);
        assert_eq!(Measurements::parse("baud laser 500000"), None);
        assert_eq!(Measurements::parse("measure stack_used_bytes=x"), None);
    }

    #[test]
    fn debug_lines_set_the_reported_rates_and_flags() {
        let debug = DebugChannel::new(None);
        debug.on_line("baud laser 500000");
        debug.on_line("baud gps 115200");
        debug.on_line("boot stack_bytes=100");
        assert_eq!(debug.laser_baud.load(Ordering::SeqCst), 500_000);
        assert_eq!(debug.gps_baud.load(Ordering::SeqCst), 115_200);
        assert!(debug.lock().booted);
        assert!(debug.lock().panic.is_none());
        debug.on_line("panic index out of bounds at src/main.rs:3");
        assert!(debug.wait_for(Duration::ZERO, |log| log.panic.is_some()));
    }
}
