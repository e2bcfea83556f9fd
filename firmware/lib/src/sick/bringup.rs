//! The LMS2xx bring-up state machine (protocol notes §5, §6.5, §10): finds the sensor's baud
//! rate, stops its output, sets the range unit (read-modify-write of the configuration,
//! written only when it differs), sets the variant, switches to the streaming baud rate and
//! starts streaming; then watches the stream and starts over when the sensor resets.
//!
//! Sans-IO: [`BringUp::handle`] takes an [`Input`] (a receiver [`Event`], a timer expiry, a
//! host request) and returns the [`Action`]s the caller carries out. It never blocks, owns
//! no UART and reads no clock. A lidar task drives it like this:
//!
//! ```text
//! let mut bringup = BringUp::new(config);
//! let mut actions = bringup.handle(Input::Start);
//! loop {
//!     for action in actions {
//!         match action {
//!             Action::Send(request) => tx.write_all(request.as_bytes()).await,
//!             Action::SetBaud(baud) => { uart.set_baud(baud).await; receiver.clear() }
//!             Action::StartTimer { duration_ms } => deadline = now + duration_ms,
//!             Action::Streaming(setup) => scan_setup = Some(setup),
//!             Action::StreamingStopped | Action::Failed => scan_setup = None,
//!             Action::Rejected(cmd) => report(cmd),
//!         }
//!     }
//!     actions = select(uart byte, deadline, host command) {
//!         byte => match receiver.push(byte, now_us) {
//!             Some(event) => { forward B0 scans; bringup.handle(event.into()) }
//!             None => continue,
//!         },
//!         deadline => bringup.handle(Input::Timeout),   // one timer; StartTimer replaces it
//!         host command => bringup.handle(Input::Configure(cmd)),
//!     };
//! }
//! ```
//!
//! Sequence (each request waits for the sensor's ACK, then for the reply with the matching
//! code; `B0h` scans and stray replies arriving meanwhile are skipped):
//!
//! 1. Baud detection: for the preferred rate, then 9 600, 19 200, 38 400, 500 000: set the
//!    UART, send `20 25` (stops an old stream), then `31h`; a valid `B1h` settles the rate.
//!    Three rounds, then [`LaserState::Failed`].
//! 2. `20 25` again if the status still reports streaming.
//! 3. `74h`; if the unit (byte 6) differs: `20 00 SICK_LMS`, `77h` with the block changed
//!    only there, `20 25`. The EEPROM is written only when needed.
//! 4. `3Bh` with angle and resolution; the `BBh` echo must match.
//! 5. If the rate differs from the target: `20 48` (reply at the old rate), switch the UART,
//!    wait 250 ms, verify with `31h`.
//! 6. `20 24` to stream, then a watchdog: no `B0h` for a whole period restarts bring-up.
//!
//! Retries: three tries per request; the ACK must come within 150 ms, the reply within 1 s
//! (3 s for mode switches, 15 s for the configuration write); a NAK or a `92h` reply waits
//! 50 ms (at least the 30 ms the sensor needs) before the next try. A failed request outside
//! baud detection restarts bring-up; after three restarts it pauses for 5 s
//! ([`LaserState::Failed`]) and starts over. A power-on message `90h` at any time restarts
//! bring-up, trying first the rate it arrived at. A host reconfiguration while streaming
//! stops the stream and redoes steps 3, 4 and 6; during bring-up it is applied before
//! streaming starts.

use heapless::Vec;
use protocol::{AngularResolution, ConfigureLaserCmd, LaserState, RangeUnit, ScanAngle};

use super::command::{DEFAULT_PASSWORD, LmsBaud, OperatingMode, Request, RequestBytes};
use super::config::ConfigBlock;
use super::receiver::Event;
use super::reply::{MODE_SWITCHED, Reply, code};
use super::telegram::Telegram;
use protocol::MeasuringMode;

/// Time limits of the bring-up, in milliseconds.
pub mod timing {
    /// How long to wait for the ACK byte after sending a request (the sensor needs ≤ 60 ms).
    pub const ACK_TIMEOUT_MS: u32 = 150;
    /// Reply timeout of status, type, configuration read, variant and scan requests.
    pub const REPLY_TIMEOUT_MS: u32 = 1_000;
    /// Reply timeout of mode switches `20h` (up to 3 s).
    pub const MODE_SWITCH_TIMEOUT_MS: u32 = 3_000;
    /// Reply timeout of the configuration write `77h` (EEPROM, several seconds).
    pub const CONFIG_WRITE_TIMEOUT_MS: u32 = 15_000;
    /// Pause after a NAK or a `92h` reply before trying again (the sensor needs ≥ 30 ms).
    pub const NAK_BACKOFF_MS: u32 = 50;
    /// Pause after switching the UART to a new baud rate before talking again.
    pub const BAUD_SETTLE_MS: u32 = 250;
    /// Pause in [`protocol::LaserState::Failed`] before bring-up starts over.
    pub const FAILED_PAUSE_MS: u32 = 5_000;
    /// Default stream watchdog: a period without any scan restarts bring-up.
    pub const STREAM_WATCHDOG_MS: u32 = 2_000;
}

// The sensor needs at least 30 ms after a NAK.
const _: () = assert!(timing::NAK_BACKOFF_MS >= 30);

/// Tries per request.
const TRIES: u8 = 3;
/// Rounds over all baud rates before giving up.
const DETECT_ROUNDS: u8 = 3;
/// Bring-up restarts after failed requests before pausing.
const MAX_RESTARTS: u8 = 3;
/// Baud rates tried after the preferred one, in order.
const PROBE_ORDER: [LmsBaud; 4] = [
    LmsBaud::B9600,
    LmsBaud::B19200,
    LmsBaud::B38400,
    LmsBaud::B500000,
];

/// What the bring-up aims for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BringUpConfig {
    /// Variant and unit.
    pub laser: ConfigureLaserCmd,
    /// The baud rate to stream at (500 000 needs RS-422).
    pub target_baud: LmsBaud,
    /// Whether to stream once configured.
    pub streaming: bool,
    /// Stream watchdog period; a period without any scan restarts bring-up.
    pub stream_watchdog_ms: u32,
}

impl Default for BringUpConfig {
    /// 180° at 0.5°, millimetres, streaming at 500 kBd.
    fn default() -> Self {
        BringUpConfig {
            laser: ConfigureLaserCmd {
                angle: ScanAngle::Deg180,
                resolution: AngularResolution::Half,
                unit: RangeUnit::Mm,
            },
            target_baud: LmsBaud::B500000,
            streaming: true,
            stream_watchdog_ms: timing::STREAM_WATCHDOG_MS,
        }
    }
}

/// How to read the scans once streaming: what [`super::ScanRepr::to_msg`] and a
/// [`super::RangeDecoder`] need.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StreamingSetup {
    /// Angle of the first value, hundredths of a degree (0 for 180°, 4 000 for 100°).
    pub start_angle_cdeg: u16,
    /// Angle between values, hundredths of a degree.
    pub step_angle_cdeg: u16,
    /// Values per complete scan.
    pub values_per_scan: u16,
    /// Unit of the range words.
    pub unit: RangeUnit,
    /// Measuring mode (which bits of a range word are distance).
    pub measuring_mode: MeasuringMode,
    /// Whether scans carry the real-time indices.
    pub real_time_indices: bool,
}

/// What happened, as the bring-up sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input<'a> {
    /// Start (or restart) bring-up, e.g. at boot.
    Start,
    /// A valid telegram from the [`super::Receiver`] (scans included).
    Telegram(Telegram<&'a [u8]>),
    /// The ACK byte `06h`.
    Ack,
    /// The NAK byte `15h`.
    Nak,
    /// The timer of the last [`Action::StartTimer`] expired.
    Timeout,
    /// The host asks for another variant or unit.
    Configure(ConfigureLaserCmd),
    /// The host starts (`true`) or stops (`false`) streaming.
    SetStreaming(bool),
}

impl<'a> From<Event<'a>> for Input<'a> {
    fn from(event: Event<'a>) -> Self {
        match event {
            Event::Telegram { telegram, .. } => Input::Telegram(telegram),
            Event::Ack { .. } => Input::Ack,
            Event::Nak { .. } => Input::Nak,
        }
    }
}

/// What the caller must do, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Action {
    /// Send these bytes to the sensor (at 500 kBd, pace them ≥ 55 µs apart).
    Send(RequestBytes),
    /// Switch the UART to this baud rate once everything sent has left; drop received bytes
    /// ([`super::Receiver::clear`]).
    SetBaud(u32),
    /// (Re)start the one timer: deliver [`Input::Timeout`] after `duration_ms`. Replaces any
    /// running timer.
    StartTimer {
        /// Milliseconds from now.
        duration_ms: u32,
    },
    /// The sensor streams; scans are to be read with this setup.
    Streaming(StreamingSetup),
    /// The sensor stopped streaming (on request or to reconfigure).
    StreamingStopped,
    /// A host configuration was not applied: unsupported (0.25° needs the 100° field) or
    /// refused by the sensor, which keeps its previous variant.
    Rejected(ConfigureLaserCmd),
    /// Bring-up failed after all retries; it starts over when the timer expires.
    Failed,
}

/// The actions of one [`BringUp::handle`] call (at most four).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Actions(Vec<Action, 4>);

impl Actions {
    fn push(&mut self, action: Action) {
        // Every handler emits at most four actions.
        let pushed = self.0.push(action);
        debug_assert!(pushed.is_ok(), "too many actions");
    }

    /// The actions, in order.
    pub fn as_slice(&self) -> &[Action] {
        &self.0
    }
}

impl IntoIterator for Actions {
    type Item = Action;
    type IntoIter = <Vec<Action, 4> as IntoIterator>::IntoIter;

    fn into_iter(self) -> Self::IntoIter {
        self.0.into_iter()
    }
}

/// Where the bring-up stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    NotStarted,
    /// Baud detection at `PROBE[index]`; `status` once `31h` was sent.
    Probe {
        index: u8,
        round: u8,
        status: bool,
    },
    StopStreaming,
    ReadConfig,
    Installation,
    WriteConfig,
    LeaveInstallation,
    SetVariant,
    SwitchBaud,
    SettleBaud,
    VerifyBaud,
    StartStreaming,
    StopOnRequest,
    Streaming,
    Idle,
    FailedPause,
}

/// Where a request in flight stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    AwaitAck,
    AwaitReply,
    Backoff,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Pending {
    request: Request,
    tries_left: u8,
    reply_timeout_ms: u32,
    phase: Phase,
}

/// The bring-up state machine. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct BringUp {
    config: BringUpConfig,
    step: Step,
    pending: Option<Pending>,
    /// The UART's baud rate as last set.
    baud: LmsBaud,
    /// The rate baud detection tries first.
    probe_first: LmsBaud,
    block: Option<ConfigBlock>,
    /// Active variant as echoed by the sensor: (angle °, resolution 1/100°).
    variant: Option<(u16, u16)>,
    setup: Option<StreamingSetup>,
    restarts: u8,
    /// The host changed the configuration during bring-up.
    reconfigure: bool,
    /// A scan arrived during the current watchdog period.
    scan_seen: bool,
}

impl BringUp {
    /// A bring-up aiming for `config`; it starts with [`Input::Start`]. The UART is assumed
    /// at 9 600 Bd until the first [`Action::SetBaud`].
    pub fn new(config: BringUpConfig) -> BringUp {
        BringUp {
            config,
            step: Step::NotStarted,
            pending: None,
            baud: LmsBaud::B9600,
            probe_first: config.target_baud,
            block: None,
            variant: None,
            setup: None,
            restarts: 0,
            reconfigure: false,
            scan_seen: false,
        }
    }

    /// The bring-up state, for the board's status report.
    pub fn state(&self) -> LaserState {
        match self.step {
            Step::NotStarted | Step::Probe { .. } => LaserState::DetectingBaud,
            Step::SwitchBaud | Step::SettleBaud | Step::VerifyBaud => LaserState::SwitchingBaud,
            Step::Streaming => LaserState::Streaming,
            Step::Idle => LaserState::Idle,
            Step::FailedPause => LaserState::Failed,
            Step::StopStreaming
            | Step::ReadConfig
            | Step::Installation
            | Step::WriteConfig
            | Step::LeaveInstallation
            | Step::SetVariant
            | Step::StartStreaming
            | Step::StopOnRequest => LaserState::Configuring,
        }
    }

    /// The baud rate the UART runs at (as last requested with [`Action::SetBaud`]).
    pub fn baud(&self) -> u32 {
        self.baud.baud()
    }

    /// How to read scans, while streaming.
    pub fn setup(&self) -> Option<StreamingSetup> {
        match self.step {
            Step::Streaming => self.setup,
            _ => None,
        }
    }

    /// What the bring-up aims for.
    pub fn config(&self) -> &BringUpConfig {
        &self.config
    }

    /// Handles one input and returns what to do.
    pub fn handle(&mut self, input: Input<'_>) -> Actions {
        let mut out = Actions::default();
        match input {
            Input::Start => self.restart(self.config.target_baud, &mut out),
            Input::Configure(cmd) => self.configure(cmd, &mut out),
            Input::SetStreaming(on) => self.set_streaming(on, &mut out),
            Input::Ack => self.on_ack(&mut out),
            Input::Nak => self.on_nak(&mut out),
            Input::Timeout => self.on_timeout(&mut out),
            Input::Telegram(telegram) => self.on_telegram(&telegram, &mut out),
        }
        out
    }

    /// Starts baud detection, trying `first` before the others.
    fn restart(&mut self, first: LmsBaud, out: &mut Actions) {
        self.probe_first = first;
        self.pending = None;
        self.setup = None;
        self.block = None;
        self.variant = None;
        self.step = Step::Probe {
            index: 0,
            round: 0,
            status: false,
        };
        self.start_probe(0, out);
    }

    /// The baud rate probed at `index`: the preferred one, then the others in order.
    fn probe_baud(&self, index: u8) -> LmsBaud {
        let mut others = PROBE_ORDER
            .iter()
            .copied()
            .filter(|&b| b != self.probe_first);
        match index {
            0 => self.probe_first,
            i => others.nth(usize::from(i) - 1).unwrap_or(self.probe_first),
        }
    }

    fn start_probe(&mut self, index: u8, out: &mut Actions) {
        let baud = self.probe_baud(index);
        self.baud = baud;
        out.push(Action::SetBaud(baud.baud()));
        self.send(
            Request::SetMode(OperatingMode::OnRequest),
            1,
            timing::MODE_SWITCH_TIMEOUT_MS,
            out,
        );
    }

    /// Sends `request`, allowing `tries` tries.
    fn send(&mut self, request: Request, tries: u8, reply_timeout_ms: u32, out: &mut Actions) {
        self.pending = Some(Pending {
            request,
            tries_left: tries.saturating_sub(1),
            reply_timeout_ms,
            phase: Phase::AwaitAck,
        });
        out.push(Action::Send(request.to_bytes()));
        out.push(Action::StartTimer {
            duration_ms: timing::ACK_TIMEOUT_MS,
        });
    }

    /// Moves to `step` and sends its request.
    fn enter(&mut self, step: Step, out: &mut Actions) {
        self.step = step;
        let laser = self.config.laser;
        let (request, timeout_ms) = match step {
            Step::StopStreaming | Step::LeaveInstallation | Step::StopOnRequest => (
                Request::SetMode(OperatingMode::OnRequest),
                timing::MODE_SWITCH_TIMEOUT_MS,
            ),
            Step::ReadConfig => (Request::ReadConfig, timing::REPLY_TIMEOUT_MS),
            Step::Installation => (
                Request::SetMode(OperatingMode::Installation {
                    password: DEFAULT_PASSWORD,
                }),
                timing::MODE_SWITCH_TIMEOUT_MS,
            ),
            Step::WriteConfig => {
                let Some(mut block) = self.block else {
                    // Unreachable: WriteConfig follows a successful ReadConfig.
                    self.step_failed(out);
                    return;
                };
                block.set_unit(laser.unit);
                (Request::WriteConfig(block), timing::CONFIG_WRITE_TIMEOUT_MS)
            }
            Step::SetVariant => (
                Request::SetVariant {
                    angle_deg: laser.angle.degrees(),
                    resolution_cdeg: laser.resolution.centidegrees(),
                },
                timing::REPLY_TIMEOUT_MS,
            ),
            Step::SwitchBaud => (
                Request::SetMode(OperatingMode::Baud(self.config.target_baud)),
                timing::MODE_SWITCH_TIMEOUT_MS,
            ),
            Step::VerifyBaud => (Request::Status, timing::REPLY_TIMEOUT_MS),
            Step::StartStreaming => (
                Request::SetMode(OperatingMode::StreamAll),
                timing::MODE_SWITCH_TIMEOUT_MS,
            ),
            Step::Idle => {
                self.pending = None;
                return;
            }
            Step::NotStarted
            | Step::Probe { .. }
            | Step::SettleBaud
            | Step::Streaming
            | Step::FailedPause => return,
        };
        self.send(request, TRIES, timeout_ms, out);
    }

    fn on_ack(&mut self, out: &mut Actions) {
        if let Some(pending) = &mut self.pending {
            if pending.phase == Phase::AwaitAck {
                pending.phase = Phase::AwaitReply;
                out.push(Action::StartTimer {
                    duration_ms: pending.reply_timeout_ms,
                });
            }
        }
    }

    fn on_nak(&mut self, out: &mut Actions) {
        if let Some(pending) = &mut self.pending {
            if pending.phase != Phase::Backoff {
                pending.phase = Phase::Backoff;
                out.push(Action::StartTimer {
                    duration_ms: timing::NAK_BACKOFF_MS,
                });
            }
        }
    }

    fn on_timeout(&mut self, out: &mut Actions) {
        if self.pending.is_some() {
            self.retry(out);
            return;
        }
        match self.step {
            Step::SettleBaud => self.enter(Step::VerifyBaud, out),
            Step::Streaming => {
                if self.scan_seen {
                    self.scan_seen = false;
                    out.push(Action::StartTimer {
                        duration_ms: self.config.stream_watchdog_ms,
                    });
                } else {
                    out.push(Action::StreamingStopped);
                    self.restart(self.baud, out);
                }
            }
            Step::FailedPause => self.restart(self.config.target_baud, out),
            _ => {}
        }
    }

    /// Sends the pending request again, or gives up on the step.
    fn retry(&mut self, out: &mut Actions) {
        let Some(pending) = self.pending else { return };
        if pending.tries_left == 0 {
            self.pending = None;
            self.step_failed(out);
            return;
        }
        self.pending = Some(Pending {
            tries_left: pending.tries_left - 1,
            phase: Phase::AwaitAck,
            ..pending
        });
        out.push(Action::Send(pending.request.to_bytes()));
        out.push(Action::StartTimer {
            duration_ms: timing::ACK_TIMEOUT_MS,
        });
    }

    fn step_failed(&mut self, out: &mut Actions) {
        match self.step {
            Step::Probe {
                index,
                round,
                status: false,
            } => {
                // No reply to `20 25`: ask for the status anyway (the stop may have been lost).
                self.step = Step::Probe {
                    index,
                    round,
                    status: true,
                };
                self.send(Request::Status, 2, timing::REPLY_TIMEOUT_MS, out);
            }
            Step::Probe {
                index,
                round,
                status: true,
            } => {
                let (index, round) = if usize::from(index) + 1 < PROBE_ORDER.len() {
                    (index + 1, round)
                } else {
                    (0, round + 1)
                };
                if round >= DETECT_ROUNDS {
                    self.fail(out);
                } else {
                    self.step = Step::Probe {
                        index,
                        round,
                        status: false,
                    };
                    self.start_probe(index, out);
                }
            }
            _ => {
                self.restarts += 1;
                if self.restarts > MAX_RESTARTS {
                    self.fail(out);
                } else {
                    self.restart(self.baud, out);
                }
            }
        }
    }

    fn fail(&mut self, out: &mut Actions) {
        self.step = Step::FailedPause;
        self.pending = None;
        self.restarts = 0;
        out.push(Action::Failed);
        out.push(Action::StartTimer {
            duration_ms: timing::FAILED_PAUSE_MS,
        });
    }

    fn on_telegram(&mut self, telegram: &Telegram<&[u8]>, out: &mut Actions) {
        let code = telegram.command();
        if code == code::POWER_ON {
            if self.step == Step::Streaming {
                out.push(Action::StreamingStopped);
            }
            self.restarts = 0;
            self.restart(self.baud, out);
            return;
        }
        if code == code::SCAN {
            self.scan_seen = true;
        }
        let Some(pending) = &mut self.pending else {
            return;
        };
        if code == code::REJECTED {
            if pending.phase != Phase::Backoff {
                pending.phase = Phase::Backoff;
                out.push(Action::StartTimer {
                    duration_ms: timing::NAK_BACKOFF_MS,
                });
            }
            return;
        }
        if code != pending.request.reply_code() {
            return;
        }
        self.pending = None;
        match Reply::parse(telegram) {
            Ok(reply) => self.on_reply(reply, out),
            Err(_) => self.step_failed(out),
        }
    }

    fn on_reply(&mut self, reply: Reply, out: &mut Actions) {
        match (self.step, reply) {
            (
                Step::Probe {
                    index,
                    round,
                    status: false,
                },
                Reply::ModeSwitch { .. },
            ) => {
                self.step = Step::Probe {
                    index,
                    round,
                    status: true,
                };
                self.send(Request::Status, 2, timing::REPLY_TIMEOUT_MS, out);
            }
            (Step::Probe { .. }, Reply::Status(status)) => {
                if status.is_streaming() {
                    self.enter(Step::StopStreaming, out);
                } else {
                    self.enter(Step::ReadConfig, out);
                }
            }
            (Step::StopStreaming, Reply::ModeSwitch { .. }) => self.enter(Step::ReadConfig, out),
            (Step::ReadConfig, Reply::Config { block, .. }) => {
                self.block = Some(block);
                if block.unit() == Some(self.config.laser.unit) {
                    self.enter(Step::SetVariant, out);
                } else {
                    self.enter(Step::Installation, out);
                }
            }
            (
                Step::Installation,
                Reply::ModeSwitch {
                    result: MODE_SWITCHED,
                    ..
                },
            ) => {
                self.enter(Step::WriteConfig, out);
            }
            (
                Step::WriteConfig,
                Reply::ConfigWritten {
                    accepted: true,
                    block,
                    ..
                },
            ) => {
                self.block = Some(block);
                self.enter(Step::LeaveInstallation, out);
            }
            (Step::LeaveInstallation, Reply::ModeSwitch { .. }) => {
                self.enter(Step::SetVariant, out)
            }
            (
                Step::SetVariant,
                Reply::Variant {
                    accepted,
                    angle_deg,
                    resolution_cdeg,
                    ..
                },
            ) => {
                let laser = self.config.laser;
                let wanted = (laser.angle.degrees(), laser.resolution.centidegrees());
                self.variant = Some((angle_deg, resolution_cdeg));
                if !accepted || (angle_deg, resolution_cdeg) != wanted {
                    out.push(Action::Rejected(laser));
                }
                if self.baud != self.config.target_baud {
                    self.enter(Step::SwitchBaud, out);
                } else {
                    self.configured(out);
                }
            }
            (Step::SwitchBaud, Reply::ModeSwitch { result, .. }) => {
                if result == MODE_SWITCHED {
                    self.baud = self.config.target_baud;
                    self.step = Step::SettleBaud;
                    out.push(Action::SetBaud(self.baud.baud()));
                    out.push(Action::StartTimer {
                        duration_ms: timing::BAUD_SETTLE_MS,
                    });
                } else {
                    // Refused (e.g. RS-232 wiring cannot carry 500 kBd): stay at this rate.
                    self.configured(out);
                }
            }
            (Step::VerifyBaud, Reply::Status(status)) => {
                if status.baud().is_none_or(|baud| baud == self.baud) {
                    self.configured(out);
                } else {
                    self.step_failed(out);
                }
            }
            (
                Step::StartStreaming,
                Reply::ModeSwitch {
                    result: MODE_SWITCHED,
                    ..
                },
            ) => {
                self.step = Step::Streaming;
                self.restarts = 0;
                self.scan_seen = false;
                self.setup = self.compute_setup();
                if let Some(setup) = self.setup {
                    out.push(Action::Streaming(setup));
                }
                out.push(Action::StartTimer {
                    duration_ms: self.config.stream_watchdog_ms,
                });
            }
            (Step::StopOnRequest, Reply::ModeSwitch { .. }) => {
                self.step = Step::Idle;
                out.push(Action::StreamingStopped);
            }
            _ => self.step_failed(out),
        }
    }

    /// Variant and baud rate are set: apply a pending host change, or stream, or idle.
    fn configured(&mut self, out: &mut Actions) {
        self.restarts = 0;
        if self.reconfigure {
            self.reconfigure = false;
            self.enter(Step::ReadConfig, out);
        } else if self.config.streaming {
            self.enter(Step::StartStreaming, out);
        } else {
            self.enter(Step::Idle, out);
        }
    }

    fn compute_setup(&self) -> Option<StreamingSetup> {
        let block = self.block?;
        let (angle_deg, resolution_cdeg) = self.variant?;
        if resolution_cdeg == 0 {
            return None;
        }
        Some(StreamingSetup {
            start_angle_cdeg: (180 - angle_deg.min(180)) * 50,
            step_angle_cdeg: resolution_cdeg,
            values_per_scan: angle_deg * 100 / resolution_cdeg + 1,
            unit: block.unit().unwrap_or(self.config.laser.unit),
            measuring_mode: block.measuring_mode(),
            real_time_indices: block.real_time_indices(),
        })
    }

    fn configure(&mut self, cmd: ConfigureLaserCmd, out: &mut Actions) {
        if !cmd.is_supported() {
            out.push(Action::Rejected(cmd));
            return;
        }
        self.config.laser = cmd;
        match self.step {
            Step::Streaming => {
                out.push(Action::StreamingStopped);
                self.enter(Step::StopStreaming, out);
            }
            Step::Idle => self.enter(Step::ReadConfig, out),
            Step::NotStarted | Step::FailedPause | Step::Probe { .. } => {}
            _ => self.reconfigure = true,
        }
    }

    fn set_streaming(&mut self, on: bool, out: &mut Actions) {
        self.config.streaming = on;
        match (self.step, on) {
            (Step::Streaming, false) => self.enter(Step::StopOnRequest, out),
            (Step::Idle, true) => self.enter(Step::StartStreaming, out),
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sick::fake_lms::FakeLms;
    use crate::sick::receiver::Receiver;
    use std::collections::VecDeque;

    /// The board side: bring-up, receiver and UART, wired to a fake sensor, with a virtual
    /// clock.
    struct Bench {
        lms: FakeLms,
        bringup: BringUp,
        receiver: Receiver,
        uart_baud: u32,
        now_us: u64,
        timer_ms: Option<u32>,
        /// Bytes on their way from the sensor.
        wire: VecDeque<u8>,
        setups: std::vec::Vec<StreamingSetup>,
        stopped: u32,
        failed: u32,
        rejected: std::vec::Vec<ConfigureLaserCmd>,
        timers: std::vec::Vec<u32>,
        scans: u32,
    }

    impl Bench {
        fn new(lms: FakeLms, config: BringUpConfig) -> Bench {
            Bench {
                lms,
                bringup: BringUp::new(config),
                receiver: Receiver::new(),
                uart_baud: 9_600,
                now_us: 0,
                timer_ms: None,
                wire: VecDeque::new(),
                setups: vec![],
                stopped: 0,
                failed: 0,
                rejected: vec![],
                timers: vec![],
                scans: 0,
            }
        }

        fn input(&mut self, input: Input<'_>) {
            let actions = self.bringup.handle(input);
            self.apply(actions);
        }

        fn apply(&mut self, actions: Actions) {
            for action in actions {
                match action {
                    Action::Send(request) => {
                        let reply = self.lms.receive(request.as_bytes(), self.uart_baud);
                        self.wire.extend(reply);
                    }
                    Action::SetBaud(baud) => {
                        self.uart_baud = baud;
                        self.receiver.clear();
                    }
                    Action::StartTimer { duration_ms } => {
                        self.timer_ms = Some(duration_ms);
                        self.timers.push(duration_ms);
                    }
                    Action::Streaming(setup) => self.setups.push(setup),
                    Action::StreamingStopped => self.stopped += 1,
                    Action::Rejected(cmd) => self.rejected.push(cmd),
                    Action::Failed => self.failed += 1,
                }
            }
        }

        /// Handles one input: the next event from the wire, else the timer's expiry (after
        /// `scans_per_period` scans from a streaming sensor). `false` when nothing is left.
        fn step(&mut self, scans_per_period: usize) -> bool {
            while let Some(byte) = self.wire.pop_front() {
                self.now_us += 20;
                let Some(event) = self.receiver.push(byte, self.now_us) else {
                    continue;
                };
                if let Event::Telegram { telegram, .. } = &event {
                    if telegram.command() == code::SCAN {
                        self.scans += 1;
                    }
                }
                let actions = self.bringup.handle(event.into());
                self.apply(actions);
                return true;
            }
            let Some(ms) = self.timer_ms else {
                return false;
            };
            if scans_per_period > 0 && self.bringup.state() == LaserState::Streaming {
                let scans = self.lms.stream(scans_per_period, self.uart_baud);
                self.wire.extend(scans);
                let mut events = 0;
                while self.step(0) && !self.wire.is_empty() {
                    events += 1;
                }
                let _ = events;
            }
            self.timer_ms = None;
            self.now_us += u64::from(ms) * 1_000;
            self.input(Input::Timeout);
            true
        }

        /// Handles up to `steps` inputs.
        fn run(&mut self, steps: usize, scans_per_period: usize) {
            for _ in 0..steps {
                if !self.step(scans_per_period) {
                    return;
                }
            }
        }

        /// Handles inputs until the bring-up is in `state` (at most `limit` inputs).
        fn run_until(&mut self, state: LaserState, scans_per_period: usize, limit: usize) -> bool {
            for _ in 0..limit {
                if self.bringup.state() == state {
                    return true;
                }
                if !self.step(scans_per_period) {
                    break;
                }
            }
            self.bringup.state() == state
        }

        /// Runs until the bring-up streams (or idles when not asked to stream).
        fn settle(&mut self) {
            let target = if self.bringup.config().streaming {
                LaserState::Streaming
            } else {
                LaserState::Idle
            };
            assert!(
                self.run_until(target, 0, 10_000),
                "did not settle: {:?}",
                self.bringup.step
            );
        }
    }

    fn config_180_half_mm() -> BringUpConfig {
        BringUpConfig::default()
    }

    #[test]
    fn clean_bring_up_from_9600() {
        let lms = FakeLms::new();
        let mut bench = Bench::new(lms, config_180_half_mm());
        bench.input(Input::Start);
        assert_eq!(bench.bringup.state(), LaserState::DetectingBaud);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert_eq!(bench.bringup.baud(), 500_000);
        assert_eq!(bench.lms.baud, 500_000);
        assert!(bench.lms.streaming);
        assert_eq!(bench.lms.eeprom_writes, 1);
        assert_eq!(bench.lms.config.unit(), Some(RangeUnit::Mm));
        assert_eq!((bench.lms.angle_deg, bench.lms.resolution_cdeg), (180, 50));
        let setup = bench.setups.last().copied().unwrap();
        assert_eq!(
            setup,
            StreamingSetup {
                start_angle_cdeg: 0,
                step_angle_cdeg: 50,
                values_per_scan: 361,
                unit: RangeUnit::Mm,
                measuring_mode: MeasuringMode(0x00),
                real_time_indices: false,
            }
        );
        assert_eq!(bench.bringup.setup(), Some(setup));
        // The configuration write went through installation mode and back.
        let codes: std::vec::Vec<u8> = bench.lms.log.iter().map(|r| r.command()).collect();
        let write = codes.iter().position(|&c| c == 0x77).unwrap();
        assert_eq!(
            bench.lms.log[write - 1],
            Request::SetMode(OperatingMode::Installation {
                password: DEFAULT_PASSWORD
            })
        );
        assert_eq!(
            bench.lms.log[write + 1],
            Request::SetMode(OperatingMode::OnRequest)
        );
        // The baud switch was verified before streaming started.
        assert!(bench.timers.contains(&timing::BAUD_SETTLE_MS));
        assert_eq!(
            bench.lms.log.last(),
            Some(&Request::SetMode(OperatingMode::StreamAll))
        );
        // Scans keep the watchdog happy.
        bench.run(200, 2);
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert!(bench.scans > 10);
    }

    #[test]
    fn sensor_already_streaming_at_500k() {
        let mut lms = FakeLms::new();
        lms.baud = 500_000;
        lms.streaming = true;
        lms.angle_deg = 180;
        lms.resolution_cdeg = 50;
        lms.config.set_unit(RangeUnit::Mm);
        lms.config.set_measuring_mode(MeasuringMode(0x04));
        let mut bench = Bench::new(lms, config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert_eq!(
            bench.lms.eeprom_writes, 0,
            "no EEPROM write when the unit is right"
        );
        assert!(
            !bench
                .lms
                .log
                .iter()
                .any(|r| matches!(r, Request::SetMode(OperatingMode::Baud(_))))
        );
        // Scans that arrived while waiting for replies were skipped.
        assert!(bench.scans > 0);
        assert_eq!(
            bench.setups.last().unwrap().measuring_mode,
            MeasuringMode(0x04)
        );
        // Baud detection needed no other rate.
        assert_eq!(bench.lms.ignored, 0);
    }

    #[test]
    fn nak_then_success() {
        let mut lms = FakeLms::new();
        lms.baud = 500_000;
        lms.nak_next = 2;
        let mut bench = Bench::new(lms, config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert_eq!(bench.lms.naks_sent, 2);
        assert!(bench.timers.contains(&timing::NAK_BACKOFF_MS));
    }

    #[test]
    fn timeout_then_retry() {
        let mut lms = FakeLms::new();
        lms.baud = 500_000;
        lms.ignore_code = Some((0x74, 2));
        let mut bench = Bench::new(lms, config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        let reads = bench
            .lms
            .log
            .iter()
            .filter(|r| **r == Request::ReadConfig)
            .count();
        assert_eq!(reads, 3, "two lost requests, then the third try");
        assert_eq!(bench.failed, 0);
    }

    #[test]
    fn lost_requests_restart_then_fail_then_recover() {
        let mut lms = FakeLms::new();
        lms.baud = 500_000;
        lms.ignore_code = Some((0x74, 1_000));
        let mut bench = Bench::new(lms, config_180_half_mm());
        bench.input(Input::Start);
        assert!(bench.run_until(LaserState::Failed, 0, 100_000));
        assert!(bench.failed >= 1);
        bench.lms.ignore_code = None;
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
    }

    #[test]
    fn silent_sensor_fails_after_three_rounds() {
        let mut lms = FakeLms::new();
        lms.powered = false;
        let mut bench = Bench::new(lms, config_180_half_mm());
        bench.input(Input::Start);
        assert!(bench.run_until(LaserState::Failed, 0, 1_000));
        assert_eq!(bench.failed, 1);
        // 3 rounds × 4 rates × (20 25 once, 31h twice).
        assert_eq!(bench.lms.ignored, 3 * 4 * 3);
    }

    #[test]
    fn power_on_mid_stream_at_same_rate() {
        let mut bench = Bench::new(FakeLms::new(), config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        bench.run(100, 1);
        // A reset with the permanent-baud flag: the sensor keeps 500 kBd and says 90h.
        bench.lms.permanent_baud = true;
        let power_on = bench.lms.power_on();
        bench.wire.extend(power_on);
        assert!(bench.step(0));
        assert_eq!(bench.stopped, 1);
        assert_eq!(bench.bringup.state(), LaserState::DetectingBaud);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert_eq!(bench.setups.len(), 2);
        assert!(bench.lms.streaming);
    }

    #[test]
    fn power_on_mid_stream_back_at_9600() {
        let mut bench = Bench::new(FakeLms::new(), config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        bench.run(100, 1);
        // The sensor comes back at 9 600 Bd: its 90h is lost; the watchdog notices.
        let _lost = bench.lms.power_on();
        assert!(bench.run_until(LaserState::DetectingBaud, 1, 10));
        assert_eq!(bench.stopped, 1);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert_eq!(bench.lms.baud, 500_000);
        assert_eq!(bench.bringup.baud(), 500_000);
        // The unit survived in EEPROM: no second write.
        assert_eq!(bench.lms.eeprom_writes, 1);
    }

    #[test]
    fn host_reconfigure_while_streaming() {
        let mut bench = Bench::new(FakeLms::new(), config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        bench.run(50, 1);
        let log_len = bench.lms.log.len();
        let cmd = ConfigureLaserCmd {
            angle: ScanAngle::Deg100,
            resolution: AngularResolution::Quarter,
            unit: RangeUnit::Mm,
        };
        bench.input(Input::Configure(cmd));
        assert_eq!(bench.stopped, 1);
        assert_eq!(bench.bringup.state(), LaserState::Configuring);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        let setup = bench.setups.last().copied().unwrap();
        assert_eq!(
            (
                setup.start_angle_cdeg,
                setup.step_angle_cdeg,
                setup.values_per_scan
            ),
            (4_000, 25, 401)
        );
        assert_eq!(
            &bench.lms.log[log_len..],
            &[
                Request::SetMode(OperatingMode::OnRequest),
                Request::ReadConfig,
                Request::SetVariant {
                    angle_deg: 100,
                    resolution_cdeg: 25
                },
                Request::SetMode(OperatingMode::StreamAll),
            ]
        );
        assert_eq!(bench.lms.eeprom_writes, 1);
        // Unit change: the configuration is written once more.
        let cmd = ConfigureLaserCmd {
            unit: RangeUnit::Cm,
            ..cmd
        };
        bench.input(Input::Configure(cmd));
        bench.settle();
        assert_eq!(bench.lms.eeprom_writes, 2);
        assert_eq!(bench.setups.last().unwrap().unit, RangeUnit::Cm);
    }

    #[test]
    fn reconfigure_during_bring_up_is_applied_before_streaming() {
        let mut bench = Bench::new(FakeLms::new(), config_180_half_mm());
        bench.input(Input::Start);
        // Let detection finish and configuration begin.
        while bench.bringup.state() == LaserState::DetectingBaud {
            bench.run(1, 0);
        }
        let cmd = ConfigureLaserCmd {
            angle: ScanAngle::Deg100,
            resolution: AngularResolution::One,
            unit: RangeUnit::Mm,
        };
        bench.input(Input::Configure(cmd));
        bench.settle();
        assert_eq!(bench.setups.len(), 1);
        assert_eq!(bench.setups[0].values_per_scan, 101);
        assert_eq!((bench.lms.angle_deg, bench.lms.resolution_cdeg), (100, 100));
    }

    #[test]
    fn unsupported_variant_rejected() {
        let mut bench = Bench::new(FakeLms::new(), config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        let log_len = bench.lms.log.len();
        let cmd = ConfigureLaserCmd {
            angle: ScanAngle::Deg180,
            resolution: AngularResolution::Quarter,
            unit: RangeUnit::Mm,
        };
        bench.input(Input::Configure(cmd));
        assert_eq!(bench.rejected, vec![cmd]);
        assert_eq!(bench.lms.log.len(), log_len, "nothing sent");
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert_eq!(
            bench.bringup.config().laser.resolution,
            AngularResolution::Half
        );
    }

    #[test]
    fn variant_refused_by_sensor_keeps_its_echo() {
        let mut lms = FakeLms::new();
        lms.refuse_variant = true;
        let mut bench = Bench::new(lms, config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert_eq!(bench.rejected.len(), 1);
        let setup = bench.setups.last().unwrap();
        assert_eq!((setup.step_angle_cdeg, setup.values_per_scan), (100, 181));
    }

    #[test]
    fn stop_and_restart_streaming_on_request() {
        let mut bench = Bench::new(FakeLms::new(), config_180_half_mm());
        bench.input(Input::Start);
        bench.settle();
        bench.input(Input::SetStreaming(false));
        bench.run(2_000, 1);
        assert_eq!(bench.bringup.state(), LaserState::Idle);
        assert!(!bench.lms.streaming);
        assert_eq!(bench.bringup.setup(), None);
        bench.input(Input::SetStreaming(true));
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Streaming);
        assert!(bench.lms.streaming);
    }

    #[test]
    fn bring_up_without_streaming_ends_idle() {
        let config = BringUpConfig {
            streaming: false,
            ..BringUpConfig::default()
        };
        let mut bench = Bench::new(FakeLms::new(), config);
        bench.input(Input::Start);
        bench.settle();
        assert_eq!(bench.bringup.state(), LaserState::Idle);
        assert_eq!(bench.bringup.baud(), 500_000);
        assert!(!bench.lms.streaming);
    }

    #[test]
    fn stray_inputs_are_ignored() {
        let mut bringup = BringUp::new(BringUpConfig::default());
        assert_eq!(bringup.state(), LaserState::DetectingBaud);
        assert!(bringup.handle(Input::Ack).as_slice().is_empty());
        assert!(bringup.handle(Input::Nak).as_slice().is_empty());
        assert!(bringup.handle(Input::Timeout).as_slice().is_empty());
        let a0 = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
        let telegram = Telegram::new_checked(&a0[..]).unwrap();
        assert!(
            bringup
                .handle(Input::Telegram(telegram))
                .as_slice()
                .is_empty()
        );
        let start = bringup.handle(Input::Start);
        assert_eq!(start.as_slice()[0], Action::SetBaud(500_000));
        assert!(
            matches!(start.as_slice()[1], Action::Send(r) if r.as_bytes() == [0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08])
        );
        assert_eq!(
            start.as_slice()[2],
            Action::StartTimer {
                duration_ms: timing::ACK_TIMEOUT_MS
            }
        );
    }
}
