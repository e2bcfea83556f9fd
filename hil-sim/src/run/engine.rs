//! The lock-step loop that runs emulated sensors, the firmware and the host together on one
//! virtual clock.
//!
//! Each step at virtual time `t`:
//!
//! 1. **Settle**: move every byte the board wrote to its reader (commands to the laser
//!    emulator, frames to the host) and wait until the firmware has read every byte written
//!    to it and its executor is idle, with no timer due. Nothing else can then happen at `t`.
//! 2. **Emit**: carry out the fault events due (GPS outage, unplugged link; a power cycle at
//!    its own time, after what the laser sent before it), and write what the emulators sent
//!    by `t` — told apart into telegrams by a [`TelegramTap`] as the bytes leave the sensor,
//!    garbled when sent at another baud rate than the board listens at (a telegram sent so
//!    is held and garbled whole), then damaged by the byte faults. The emulators follow the
//!    robot's true motion by themselves: each scan and each GPS epoch takes the pose at its
//!    own time, however late it is polled. If anything was written, settle again.
//! 3. **Advance** to the next event: an emulator's next output (at most every
//!    [`QUANTUM_US`], so bytes arrive in chunks, as from a UART FIFO), a firmware timer, a
//!    host ping, a fault, the end.
//!
//! The firmware sees the same bytes at the same virtual times whatever the host's speed, so a
//! run is reproducible to the byte; `realtime` only waits for the wall clock before each step.
//!
//! The end: the emulators stop at the run's duration (no scan or epoch from then on), the
//! telegrams and bursts on the lines leave whole, the board and the host drain, and the host
//! asks for the final status.
//!
//! # Wall-clock wiring (a real board)
//!
//! With [`Wiring::Wall`] the same loop drives serial lines to a board the engine cannot see
//! inside: a flashed board on real ports (hardware in the loop), or firmware running in wall
//! mode elsewhere. There is no settling (the engine cannot know when the board has reacted),
//! time is the wall clock, and each line runs at the baud rate of the emulator that drives
//! it: the laser line follows the emulated sensor through its baud switches, so a board
//! listening at another rate hears what a real UART would. Everything the summary counts on
//! the board comes from its own status report. What the emulators send does not depend on
//! when the engine looks: the laser's scans lie on a fixed grid of its clock (a bring-up that
//! ends a few milliseconds later still meets the same first scan) and each is measured at its
//! own time, power cycles happen at their set time, and the output ends at a set time, so a
//! board reacting a little later than the lock-step firmware receives the same scans and fixes.

use std::collections::VecDeque;
use std::io::{self, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use firmware::sick::{ScanRepr, Telegram};
use serialport::{SerialPort, TTYPort};

use super::host_side::{HostSide, SentScan};
use super::tap::{Piece, TelegramTap};
use crate::board::Board;
use crate::emulators::{GpsEmulator, GpsTruth, Lms2xx, garble};
use crate::faults::{ByteFaults, FaultSpec};
use crate::pty::{PortCounters, PtyLink};
use crate::replay::{GpsReplay, GpsReplayOptions, LocalGpsFix};
use crate::sim_time::VirtualClock;
use crate::world::{RobotState, Trajectory, World};

/// Emulator output is delivered in chunks at least this far apart, µs.
pub const QUANTUM_US: u64 = 1_000;
/// The longest step when nothing is scheduled, µs.
const MAX_STEP_US: u64 = 10_000;
/// The longest step on the wall clock, µs: the engine cannot know when a board it does not see
/// inside writes, so it looks at the lines this often (a command waits at most this long
/// before the emulated sensor hears it).
const WALL_POLL_US: u64 = QUANTUM_US;
/// Time-sync pings, one every this many µs.
const PING_PERIOD_US: u64 = 1_000_000;
/// After the sensors stop: how long the firmware and host drain, µs. On the wall clock a board
/// that runs late is still sending then, so the drain goes on while the host hears scans or
/// fixes, each time for this long again, up to [`MAX_WALL_DRAIN_US`].
const DRAIN_US: u64 = 200_000;
/// The longest drain on the wall clock, µs.
const MAX_WALL_DRAIN_US: u64 = 10 * DRAIN_US;
/// How long to wait for the final status report, µs.
const STATUS_WAIT_US: u64 = 500_000;
/// How long an unplugged host link stays unplugged, µs.
pub const UNPLUGGED_US: u64 = 300_000;
/// Checks of a settle that only yield the CPU before it sleeps between checks.
const SETTLE_YIELDS: u32 = 20;
/// A settle that makes no progress for this long means the firmware hangs.
const SETTLE_TIMEOUT: Duration = Duration::from_secs(10);

/// The serial line under an [`Endpoint`].
pub enum Line {
    /// The device end of a pseudo-terminal whose other end a board opened.
    Pty(PtyLink),
    /// A serial port (a real UART adapter, or any tty).
    Port(TTYPort),
    /// A pseudo-terminal whose board end an emulated UART (QEMU's) opened, which passes every
    /// byte whatever the rates: the rate the board's UART listens at is what the board
    /// reports ([`ReportedBaud`]), and bytes sent at another rate are garbled as a real UART
    /// would hear them.
    Emulated {
        /// The pty.
        link: PtyLink,
        /// The board's rate, as it reports it.
        board_baud: Arc<dyn ReportedBaud>,
    },
}

/// The rate an emulated board's UART listens at, as the board reports it on another line.
pub trait ReportedBaud: Send + Sync {
    /// The rate, after taking in every report the board made before the bytes read from its
    /// UART so far: the engine asks right after reading them, so that a request sent just
    /// after a rate change is heard at the new rate.
    ///
    /// # Errors
    /// When the line with the reports fails.
    fn baud(&self) -> io::Result<u32>;
}

impl ReportedBaud for AtomicU32 {
    fn baud(&self) -> io::Result<u32> {
        Ok(self.load(Ordering::SeqCst))
    }
}

impl Line {
    fn device(&mut self) -> &mut TTYPort {
        match self {
            Line::Pty(link) | Line::Emulated { link, .. } => &mut link.device,
            Line::Port(port) => port,
        }
    }
}

/// One end of a serial line that the simulation drives, with what it moved.
pub struct Endpoint {
    line: Line,
    /// The board's counters for its end, when the board runs in this process.
    board: Option<Arc<PortCounters>>,
    written: u64,
    read: u64,
}

impl Endpoint {
    /// A lock-step endpoint on `link` whose other end the board counts in `board`.
    pub fn new(link: PtyLink, board: Arc<PortCounters>) -> Endpoint {
        Endpoint {
            line: Line::Pty(link),
            board: Some(board),
            written: 0,
            read: 0,
        }
    }

    /// A wall-clock endpoint on `line`, whose other end the engine cannot observe. The line's
    /// baud rate follows the emulator that writes to it.
    pub fn wall(line: Line) -> Endpoint {
        Endpoint {
            line,
            board: None,
            written: 0,
            read: 0,
        }
    }

    /// Bytes written to the board.
    pub fn written(&self) -> u64 {
        self.written
    }

    /// Bytes read from the board.
    pub fn read(&self) -> u64 {
        self.read
    }

    /// Reads what is there without waiting.
    fn read_available(&mut self) -> io::Result<Vec<u8>> {
        let mut out = Vec::new();
        crate::pty::read_available(self.line.device(), &mut out)?;
        self.read += out.len() as u64;
        Ok(out)
    }

    fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        let device = self.line.device();
        device
            .set_timeout(SETTLE_TIMEOUT)
            .map_err(io::Error::other)?;
        device.write_all(bytes)?;
        self.written += bytes.len() as u64;
        Ok(())
    }

    /// Whether the board has read everything written to it and everything it wrote was read
    /// (always true when the board cannot be observed).
    fn balanced(&self) -> bool {
        self.board.as_ref().is_none_or(|board| {
            board.read() == self.written && board.written() == self.read && !board.writing()
        })
    }

    /// The rate the board's end listens at: read back from the pty when the board is in
    /// this process, as reported by an emulated board, otherwise the line's own rate (a real
    /// UART pair garbles by itself).
    fn board_baud(&mut self) -> io::Result<u32> {
        match (&self.board, &mut self.line) {
            (Some(_), Line::Pty(link)) => link.board_baud(),
            (_, Line::Emulated { board_baud, .. }) => board_baud.baud(),
            (_, line) => line.device().baud_rate().map_err(io::Error::other),
        }
    }

    /// On a wall-clock line, sets the line to `baud` once everything written so far has left
    /// at the old rate; a lock-step line keeps the board's rate.
    fn follow_baud(&mut self, baud: u32) -> io::Result<()> {
        if self.board.is_some() {
            return Ok(());
        }
        let device = self.line.device();
        if device.baud_rate().map_err(io::Error::other)? != baud {
            device.flush()?;
            device.set_baud_rate(baud).map_err(io::Error::other)?;
        }
        Ok(())
    }
}

/// How the engine is wired to the firmware and what clock it runs on.
pub enum Wiring<'c> {
    /// The firmware runs in this process on `clock`, which the engine advances; steps settle.
    LockStep {
        /// The virtual clock of the session.
        clock: &'c VirtualClock,
        /// The firmware instance.
        board: Board,
    },
    /// A board the engine cannot observe, on the wall clock.
    Wall,
}

/// What the fault events did.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct EventsInjected {
    /// Laser power cycles.
    pub laser_restarts: u32,
    /// GPS outages begun.
    pub gps_outages: u32,
    /// Host link unplugs.
    pub link_replugs: u32,
}

/// The sensors' side of a run.
pub struct Sensors<W: World> {
    /// The laser.
    pub lms: Lms2xx<W>,
    /// The GPS receiver, `None` when the world has no sky (indoors it has no fix).
    pub gps: GpsEmulator,
    /// The robot's true motion.
    pub trajectory: Trajectory,
    /// Whether the GPS can see satellites at all.
    pub gps_has_sky: bool,
    /// The truth of each scan in the order the laser sends them, when the laser replays a
    /// log (`trajectory` is then unused for the laser).
    pub scan_truth: Option<Vec<RobotState>>,
    /// Recorded GPS fixes to replay instead of following `trajectory`, with the log time of
    /// the laser's first recorded scan: the fixes start when that scan goes out, keeping
    /// the log's timing between the two sensors (at the recorded laser pace).
    pub gps_log: Option<(Vec<LocalGpsFix>, f64)>,
    /// The robot computer's camera (the camera method), following `trajectory`.
    pub camera: Option<super::camera_feed::CameraFeed>,
}

/// Counts of what the sensors sent.
#[derive(Debug, Clone, Copy, Default)]
pub struct SentCounts {
    /// Scan telegrams that left the laser (whole, or cut short by a power cycle or a
    /// request).
    pub scan_telegrams: u64,
    /// Of those, cut by a power cycle.
    pub scan_telegrams_cut: u64,
    /// Of those, cut short by a request from the board (§5: a request interrupts a scan).
    pub scan_telegrams_interrupted: u64,
    /// Scan telegrams sent whole.
    pub scan_telegrams_whole: u64,
}

/// Why the laser stopped mid-telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CutBy {
    /// A power cycle.
    Restart,
    /// A request from the board.
    Request,
}

/// How the telegram under way on the laser line goes to the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Passing {
    /// Byte by byte as it leaves the sensor, damaged by the byte faults (a scan may be cut
    /// short).
    Streamed,
    /// Held until its end and garbled whole: sent at another rate than the board listens at.
    Held,
}

/// Everything a lock-step run holds.
pub struct Engine<'c, W: World> {
    wiring: Wiring<'c>,
    laser: Endpoint,
    gps_end: Endpoint,
    host_end: Endpoint,
    sensors: Sensors<W>,
    tap: TelegramTap,
    /// How the telegram under way goes on.
    passing: Passing,
    /// When the scans whose telegrams have started and not been accounted were measured, µs.
    scan_times_us: VecDeque<u64>,
    /// The rate of the laser's last bytes.
    laser_sent_baud: u32,
    /// When the laser was polled last, µs.
    laser_polled_us: u64,
    /// Why the telegram being cut off stopped.
    cut_by: CutBy,
    laser_faults: ByteFaults,
    gps_faults: ByteFaults,
    faults: FaultSpec,
    /// The host.
    pub host: HostSide,
    /// What the sensors sent.
    pub sent: SentCounts,
    /// What the fault events did.
    pub events: EventsInjected,
    next_restart: usize,
    next_replug: usize,
    unplugged_until_us: Option<u64>,
    in_outage: bool,
    next_ping_us: u64,
    realtime: Option<Instant>,
    gps_replay: Option<GpsReplay>,
    relay: Option<Endpoint>,
    /// Where the camera's frames go instead of the host side ([`Engine::relay_camera`]).
    camera_relay: Option<std::sync::mpsc::SyncSender<super::camera_feed::CameraFrame>>,
}

/// Where a run stands.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Running,
    Draining {
        /// When the drain ends, unless the host still hears from the board.
        until_us: u64,
        /// When it started.
        from_us: u64,
        /// Scans and fixes the host had decoded at the last look.
        heard: usize,
    },
    AwaitingStatus {
        asked_us: u64,
    },
}

impl<'c, W: World> Engine<'c, W> {
    /// Assembles a run; nothing happens until [`Self::run`].
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        wiring: Wiring<'c>,
        (laser, gps_end, host_end): (Endpoint, Endpoint, Endpoint),
        sensors: Sensors<W>,
        faults: FaultSpec,
        seed: u64,
        host: HostSide,
        realtime: bool,
    ) -> Self {
        // On the wall clock there is nothing to wait for but the wall.
        let realtime = realtime || matches!(wiring, Wiring::Wall);
        let mut sensors = sensors;
        // Each scan and each epoch at the true pose of its own time.
        if sensors.scan_truth.is_none() {
            let trajectory = sensors.trajectory.clone();
            sensors
                .lms
                .set_motion(move |t_us| trajectory.pose_at(t_us as f64 * 1e-6).sensor_pose());
        }
        if sensors.gps_log.is_none() {
            let trajectory = sensors.trajectory.clone();
            sensors
                .gps
                .set_trajectory(move |t_us| gps_truth(&trajectory.pose_at(t_us as f64 * 1e-6)));
        }
        let laser_sent_baud = sensors.lms.baud();
        Engine {
            wiring,
            laser,
            gps_end,
            host_end,
            sensors,
            tap: TelegramTap::new(),
            passing: Passing::Streamed,
            scan_times_us: VecDeque::new(),
            laser_sent_baud,
            laser_polled_us: 0,
            cut_by: CutBy::Restart,
            laser_faults: ByteFaults::new(&faults, seed ^ 0x1A5E_0001),
            gps_faults: ByteFaults::new(
                &FaultSpec {
                    truncate: 0.0,
                    ..faults.clone()
                },
                seed ^ 0x0695_0002,
            ),
            faults,
            host,
            sent: SentCounts::default(),
            events: EventsInjected::default(),
            next_restart: 0,
            next_replug: 0,
            unplugged_until_us: None,
            in_outage: false,
            next_ping_us: PING_PERIOD_US / 2,
            realtime: realtime.then(Instant::now),
            gps_replay: None,
            relay: None,
            camera_relay: None,
        }
    }

    /// Hands the camera's frames to another program (the daemon's camera) through `frames`
    /// instead of the in-process host side, as a camera plugged into the robot computer does.
    pub fn relay_camera(
        &mut self,
        frames: std::sync::mpsc::SyncSender<super::camera_feed::CameraFrame>,
    ) {
        self.camera_relay = Some(frames);
    }

    /// Passes the host link on to another program through `link` (a pty whose other end it
    /// opened as its serial port): the frames the board sends go on to it as they are read,
    /// and what it writes goes to the board. It then keeps the board's clock in sync, so this
    /// side stops pinging and only counts.
    pub fn relay_host_link(&mut self, link: PtyLink) {
        self.relay = Some(Endpoint::wall(Line::Pty(link)));
    }

    /// What the byte faults did to the laser and GPS streams.
    pub fn injected(&self) -> (crate::faults::InjectedFaults, crate::faults::InjectedFaults) {
        (*self.laser_faults.injected(), *self.gps_faults.injected())
    }

    /// The emulators, for their counters.
    pub fn sensors(&self) -> &Sensors<W> {
        &self.sensors
    }

    /// Panics in the firmware, when it runs in this process (a board on real ports reports
    /// none: a reset shows as a missing final status or as scan-counter gaps).
    pub fn panics(&self) -> u32 {
        match &self.wiring {
            Wiring::LockStep { board, .. } => board.executor.panics(),
            Wiring::Wall => 0,
        }
    }

    /// Bytes written to and read from the laser, GPS and host lines.
    pub fn endpoints(&self) -> [&Endpoint; 3] {
        [&self.laser, &self.gps_end, &self.host_end]
    }

    /// Runs the sensors for `duration_us` of virtual time, lets what is on the lines leave,
    /// then drains and asks the board for its final status.
    ///
    /// # Errors
    /// When a port fails or the firmware stops reacting.
    pub fn run(&mut self, duration_us: u64) -> io::Result<()> {
        self.sensors.lms.stop_scans_at(duration_us);
        self.sensors.gps.stop_epochs_at(duration_us);
        let mut t_us = 0;
        let mut phase = Phase::Running;
        loop {
            self.settle(t_us)?;
            let wrote = match phase {
                Phase::Running => self.emit(t_us)?,
                _ => false,
            };
            if wrote {
                continue;
            }
            if self.host_actions(t_us, phase)? {
                continue;
            }
            match phase {
                Phase::Running if t_us >= duration_us && self.lines_quiet() => {
                    phase = Phase::Draining {
                        until_us: t_us + DRAIN_US,
                        from_us: t_us,
                        heard: self.heard(),
                    };
                }
                Phase::Draining { from_us, heard, .. }
                    if matches!(self.wiring, Wiring::Wall)
                        && self.heard() != heard
                        && t_us < from_us + MAX_WALL_DRAIN_US =>
                {
                    phase = Phase::Draining {
                        until_us: (t_us + DRAIN_US).min(from_us + MAX_WALL_DRAIN_US),
                        from_us,
                        heard: self.heard(),
                    };
                }
                Phase::Draining { until_us, .. } if t_us >= until_us => {
                    let request = self.host.status_request();
                    self.host_end.write(&request)?;
                    phase = Phase::AwaitingStatus { asked_us: t_us };
                    continue;
                }
                Phase::AwaitingStatus { asked_us } => {
                    let answered = self.host.status.is_some_and(|s| s.uptime_us >= asked_us);
                    if answered || t_us >= asked_us + STATUS_WAIT_US {
                        return Ok(());
                    }
                }
                _ => {}
            }
            let next_us = self.next_event_us(t_us, phase, duration_us);
            if let Some(start) = self.realtime {
                let due = start + Duration::from_micros(next_us);
                if let Some(wait) = due.checked_duration_since(Instant::now()) {
                    std::thread::sleep(wait);
                }
            }
            t_us = match &self.wiring {
                Wiring::LockStep { clock, .. } => {
                    clock.advance_to(next_us);
                    next_us
                }
                Wiring::Wall => self
                    .realtime
                    .map_or(next_us, |start| start.elapsed().as_micros() as u64)
                    .max(next_us),
            };
        }
    }

    /// Moves bytes until the firmware has reacted to everything at `t_us` (on the wall clock:
    /// moves what is there).
    fn settle(&mut self, t_us: u64) -> io::Result<()> {
        let (clock, board) = match &self.wiring {
            Wiring::LockStep { clock, board } => (*clock, board.clone()),
            Wiring::Wall => {
                self.pump(t_us)?;
                return Ok(());
            }
        };
        let mut last_progress = Instant::now();
        let mut idle_checks = 0u32;
        loop {
            let moved = self.pump(t_us)?;
            let timer_due = clock.next_timer_us().is_some_and(|at| at <= t_us);
            if moved || timer_due {
                last_progress = Instant::now();
                continue;
            }
            if board.executor.panics() > 0 {
                return Err(io::Error::other("the firmware panicked"));
            }
            if let Some(epoch) = board.executor.idle_epoch()
                && self.laser.balanced()
                && self.gps_end.balanced()
                && self.host_end.balanced()
                && board.executor.idle_epoch() == Some(epoch)
            {
                return Ok(());
            }
            if last_progress.elapsed() > SETTLE_TIMEOUT {
                return Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    format!(
                        "the firmware did not settle at t = {t_us} µs (executor idle: {}, \
                         laser {}/{} read, host {}/{} read)",
                        board.executor.idle_epoch().is_some(),
                        self.laser.board.as_ref().map_or(0, |b| b.read()),
                        self.laser.written,
                        self.host_end.read,
                        self.host_end.board.as_ref().map_or(0, |b| b.written()),
                    ),
                ));
            }
            // The firmware thread usually reacts at once: give it the CPU, then wait longer.
            idle_checks += 1;
            if idle_checks < SETTLE_YIELDS {
                std::thread::yield_now();
            } else {
                std::thread::sleep(Duration::from_micros(20));
            }
        }
    }

    /// Reads what the board wrote: commands to the laser, frames to the host. Returns whether
    /// any byte moved.
    fn pump(&mut self, t_us: u64) -> io::Result<bool> {
        let commands = self.laser.read_available()?;
        let mut cut_off = false;
        if !commands.is_empty() {
            let baud = self.laser.board_baud()?;
            let interrupted = self.sensors.lms.counters().scans_interrupted;
            self.sensors.lms.receive(&commands, baud, t_us);
            // A request cut a scan short: it ends where it stopped, not where its length says.
            if self.sensors.lms.counters().scans_interrupted != interrupted {
                cut_off = self.laser_cut_off(t_us, CutBy::Request)?;
            }
        }
        // The GPS receiver is not configured by the board.
        let to_gps = self.gps_end.read_available()?;
        let frames = self.host_end.read_available()?;
        if self.unplugged_until_us.is_some() {
            self.host.bytes_while_unplugged += frames.len() as u64;
        } else if !frames.is_empty() {
            self.host.feed(&frames, t_us as f64 * 1e-6);
            if let Some(relay) = self.relay.as_mut() {
                relay.write(&frames)?;
            }
        }
        let mut relayed = false;
        if let Some(relay) = self.relay.as_mut() {
            let to_board = relay.read_available()?;
            if !to_board.is_empty() && self.unplugged_until_us.is_none() {
                self.host_end.write(&to_board)?;
                relayed = true;
            }
        }
        Ok(!commands.is_empty() || !to_gps.is_empty() || !frames.is_empty() || relayed || cut_off)
    }

    /// The fault events and the emulators' output at `t_us`. Returns whether anything was
    /// written.
    fn emit(&mut self, t_us: u64) -> io::Result<bool> {
        let t_s = t_us as f64 * 1e-6;
        self.start_gps_replay(t_us);
        let outage = !self.sensors.gps_has_sky || self.faults.gps_outage_at(t_s);
        if outage != self.in_outage {
            self.in_outage = outage;
            self.sensors.gps.set_fix(!outage);
            if outage && self.sensors.gps_has_sky {
                self.events.gps_outages += 1;
            }
        }
        match &mut self.gps_replay {
            Some(replay) => {
                // The recording says whether there is a fix; an injected outage overrides it.
                replay.apply(&mut self.sensors.gps, t_us);
                if outage {
                    self.sensors.gps.set_fix(false);
                }
            }
            None if self.sensors.gps_log.is_some() => self.sensors.gps.set_fix(false),
            // The trajectory function gives each epoch its truth.
            None => {}
        }
        if let Some(until_us) = self.unplugged_until_us
            && t_us >= until_us
        {
            self.unplugged_until_us = None;
            self.host.reconnected();
        }
        if let Some(&at_s) = self.faults.link_replugs_s.get(self.next_replug)
            && t_s >= at_s
        {
            self.next_replug += 1;
            self.events.link_replugs += 1;
            self.unplugged_until_us = Some(t_us + UNPLUGGED_US);
        }

        let mut wrote = false;
        if let Some(&at_s) = self.faults.laser_restarts_s.get(self.next_restart)
            && t_s >= at_s
        {
            // At its own time, whenever the engine looks.
            let at_us = s_to_us(at_s).min(t_us);
            self.next_restart += 1;
            self.events.laser_restarts += 1;
            self.sensors.lms.power_cycle(at_us);
            wrote |= self.laser_cut_off(at_us, CutBy::Restart)?;
        }
        wrote |= self.emit_laser(t_us)?;
        // The camera is the robot computer's: its frames go to the host, not the board.
        if let Some(camera) = self.sensors.camera.as_mut() {
            while let Some(frame) = camera.due(t_us) {
                match &self.camera_relay {
                    // A daemon that has stopped taking frames has stopped: nothing to hand on.
                    Some(frames) => {
                        let _ = frames.send(frame);
                    }
                    None => self.host.camera_frame(frame),
                }
            }
        }
        let runs = self.sensors.gps.poll_output_runs(t_us);
        for run in runs {
            self.gps_end.follow_baud(run.baud)?;
            let board_baud = self.gps_end.board_baud()?;
            let heard = garble(&run.bytes, run.baud, board_baud);
            let damaged = self.gps_faults.apply(&heard);
            self.gps_end.write(&damaged)?;
            wrote |= !damaged.is_empty();
        }
        // Listen at the rate the laser now listens at.
        self.laser.follow_baud(self.sensors.lms.baud())?;
        Ok(wrote)
    }

    /// Starts the recorded GPS fixes once the laser has sent its first recorded scan.
    fn start_gps_replay(&mut self, t_us: u64) {
        if self.gps_replay.is_some()
            || self
                .sensors
                .lms
                .replay_progress()
                .is_none_or(|p| p.scans_sent == 0)
        {
            return;
        }
        let Some((fixes, first_scan_s)) = self.sensors.gps_log.take() else {
            return;
        };
        // Fixes before the first scan are left out; the rest keep their offsets to it.
        let fixes: Vec<LocalGpsFix> = fixes
            .into_iter()
            .filter(|f| f.t_s >= first_scan_s)
            .collect();
        let lead_s = fixes.first().map_or(0.0, |f| f.t_s - first_scan_s);
        self.gps_replay = Some(GpsReplay::new(
            fixes,
            GpsReplayOptions {
                start_us: t_us + (lead_s * 1e6).round() as u64,
                ..GpsReplayOptions::default()
            },
        ));
    }

    /// The laser stopped sending mid-telegram at `at_us` (a power cycle, a request that cut
    /// its scan short): hands on what left before, then ends the telegram under way. Returns
    /// whether anything was written.
    fn laser_cut_off(&mut self, at_us: u64, by: CutBy) -> io::Result<bool> {
        let mut wrote = self.emit_laser(at_us)?;
        if let Some(piece) = self.tap.cut() {
            self.cut_by = by;
            wrote |= self.write_laser_piece(piece, self.laser_sent_baud)?;
        }
        // Every scan begun has been accounted for.
        self.scan_times_us.clear();
        Ok(wrote)
    }

    fn emit_laser(&mut self, t_us: u64) -> io::Result<bool> {
        let mut wrote = false;
        let runs = self.sensors.lms.poll_output_runs(t_us);
        self.laser_polled_us = t_us;
        self.scan_times_us
            .extend(self.sensors.lms.take_scans_started());
        for run in runs {
            self.laser_sent_baud = run.baud;
            for piece in self.tap.push(&run.bytes) {
                wrote |= self.write_laser_piece(piece, run.baud)?;
            }
        }
        Ok(wrote)
    }

    /// Writes a piece of the laser's output to the board as it hears it, damaged by the byte
    /// faults, and accounts for the scans. Returns whether anything was written.
    fn write_laser_piece(&mut self, piece: Piece, sent_baud: u32) -> io::Result<bool> {
        self.laser.follow_baud(sent_baud)?;
        let board_baud = self.laser.board_baud()?;
        let bytes = match piece {
            Piece::Other(bytes) => self
                .laser_faults
                .apply(&garble(&bytes, sent_baud, board_baud)),
            Piece::Start { len, is_scan } => {
                self.passing = if sent_baud != board_baud {
                    Passing::Held
                } else {
                    if is_scan {
                        self.laser_faults.begin_telegram(len);
                    }
                    Passing::Streamed
                };
                return Ok(false);
            }
            Piece::Part(bytes) => match self.passing {
                Passing::Held => return Ok(false),
                Passing::Streamed => self
                    .laser_faults
                    .telegram_part(&garble(&bytes, sent_baud, board_baud)),
            },
            Piece::End {
                bytes,
                is_scan,
                cut,
            } => {
                let out = match self.passing {
                    Passing::Held => {
                        let heard = garble(&bytes, sent_baud, board_baud);
                        if is_scan {
                            self.laser_faults.apply_telegram(&heard)
                        } else {
                            self.laser_faults.apply(&heard)
                        }
                    }
                    Passing::Streamed => {
                        self.laser_faults.end_telegram();
                        Vec::new()
                    }
                };
                self.passing = Passing::Streamed;
                if is_scan {
                    self.scan_sent(&bytes, cut);
                }
                out
            }
            Piece::Fragment(bytes) => {
                // Cut before its command byte: a scan if one had started and is unaccounted.
                if !self.scan_times_us.is_empty() {
                    self.scan_sent(&bytes, true);
                }
                self.laser_faults
                    .apply(&garble(&bytes, sent_baud, board_baud))
            }
        };
        self.laser.write(&bytes)?;
        Ok(!bytes.is_empty())
    }

    /// Accounts for a scan telegram that left the laser, whole or `cut` by a power cycle.
    fn scan_sent(&mut self, bytes: &[u8], cut: bool) {
        let measured_us = self
            .scan_times_us
            .pop_front()
            .unwrap_or(self.laser_polled_us);
        self.sent.scan_telegrams += 1;
        if cut {
            match self.cut_by {
                CutBy::Restart => self.sent.scan_telegrams_cut += 1,
                CutBy::Request => self.sent.scan_telegrams_interrupted += 1,
            }
        } else if let Some(values) = scan_values(bytes) {
            let index = self.sent.scan_telegrams_whole as usize;
            self.sent.scan_telegrams_whole += 1;
            let truth = match &self.sensors.scan_truth {
                Some(table) => table.get(index).copied().unwrap_or_default(),
                None => self.sensors.trajectory.pose_at(measured_us as f64 * 1e-6),
            };
            self.host.scan_sent(SentScan { values, truth });
        }
    }

    /// Scans and fixes the host has decoded so far.
    fn heard(&self) -> usize {
        self.host.records.len() + self.host.fixes.len()
    }

    /// Whether the sensors have nothing more on their lines.
    fn lines_quiet(&self) -> bool {
        !self.sensors.lms.is_transmitting() && self.sensors.gps.next_output_us().is_none()
    }

    /// Pings. Returns whether anything was written.
    fn host_actions(&mut self, t_us: u64, phase: Phase) -> io::Result<bool> {
        if t_us < self.next_ping_us || phase != Phase::Running {
            return Ok(false);
        }
        self.next_ping_us += PING_PERIOD_US;
        if self.unplugged_until_us.is_some() || self.relay.is_some() {
            return Ok(false);
        }
        let ping = self.host.ping(t_us as f64 * 1e-6);
        self.host_end.write(&ping)?;
        Ok(true)
    }

    fn next_event_us(&mut self, t_us: u64, phase: Phase, duration_us: u64) -> u64 {
        let max_step_us = match self.wiring {
            Wiring::LockStep { .. } => MAX_STEP_US,
            Wiring::Wall => WALL_POLL_US,
        };
        let mut next = t_us + max_step_us;
        if phase == Phase::Running {
            let emulators = [
                self.sensors.lms.next_output_us(),
                self.sensors.gps.next_output_us(),
            ];
            for at in emulators.into_iter().flatten() {
                next = next.min(at.max(t_us + QUANTUM_US));
            }
            let scheduled = [
                Some(self.next_ping_us),
                self.faults
                    .laser_restarts_s
                    .get(self.next_restart)
                    .map(|&s| s_to_us(s)),
                self.faults
                    .link_replugs_s
                    .get(self.next_replug)
                    .map(|&s| s_to_us(s)),
                self.unplugged_until_us,
                self.gps_replay.as_ref().and_then(GpsReplay::next_change_us),
                Some(duration_us),
            ];
            for at in scheduled.into_iter().flatten() {
                if at > t_us {
                    next = next.min(at);
                }
            }
        }
        if let Wiring::LockStep { clock, .. } = &self.wiring
            && let Some(at) = clock.next_timer_us()
        {
            next = next.min(at);
        }
        next.max(t_us + 1)
    }
}

/// Seconds to µs, rounded up: an event set for `s` happens at the first µs at or after it.
fn s_to_us(s: f64) -> u64 {
    (s * 1e6).ceil() as u64
}

/// The GPS antenna at the robot's origin.
fn gps_truth(truth: &RobotState) -> GpsTruth {
    GpsTruth {
        east_m: truth.x_m,
        north_m: truth.y_m,
        up_m: 0.0,
        speed_mps: truth.speed_mps.abs(),
        course_deg: (90.0 - truth.theta_rad.to_degrees()).rem_euclid(360.0),
    }
}

/// The range words of a scan telegram, as the firmware forwards them.
fn scan_values(bytes: &[u8]) -> Option<Vec<u16>> {
    let telegram = Telegram::new_checked(bytes).ok()?;
    let scan = ScanRepr::parse(&telegram).ok()?;
    Some(scan.to_msg(0, 0, 0, 0).values.to_vec())
}
