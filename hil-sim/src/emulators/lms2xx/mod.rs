//! An emulated SICK LMS200: a pure state machine that answers host requests byte-exactly and
//! streams scans of a [`World`], with the sensor's timing (protocol notes
//! `shared/protocols/sick-lms2xx.md`).
//!
//! Time and bytes in, bytes out: [`Lms2xx::receive`] takes the host's bytes with the baud rate
//! the host sent them at and the time they arrived; [`Lms2xx::poll_output`] returns the bytes
//! that have left the sensor's transmitter by a given time, paced at its baud rate (10 bit
//! times per byte); [`Lms2xx::next_output_us`] says when to poll next. The emulator reads no
//! clock: `now_us` is any monotonic microsecond count, with the sensor powered at 0. Every
//! telegram is built with the firmware's own [`Reply::emit`] and [`ScanRepr::emit`] and every
//! request decoded with [`Request::parse`].
//!
//! Behaviour:
//!
//! * Reception (§2, §4, §5): bytes sent at another baud rate than the sensor's are not
//!   understood (counted as garbage, and any partial request is lost), as are bytes sent while
//!   it starts up. A request is framed by STX, length and CRC; a pause of more than 6 ms
//!   inside it drops it. Wrong address: silence. Bad CRC: NAK `15h`. Otherwise ACK `06h`
//!   ([`Lms2xxTiming::ack_delay_us`] after the request), then the reply telegram. A request
//!   cuts short a scan being sent ([`Lms2xxOptions::requests_interrupt_output`], §5, §10.3).
//! * Replies: `A0h` after [`Lms2xxTiming::mode_switch_delay_us`], `F7h` after
//!   [`Lms2xxTiming::config_write_delay_us`], the others after
//!   [`Lms2xxTiming::reply_delay_us`]; the `B0h` answering `30 01` is the next scan the mirror
//!   completes. The sensor handles requests in order: a reply still pending delays the ACK
//!   of the next request.
//! * `20h`: `24h` streams, `25h` stops, `00h` + password enters installation mode (`A0 01`
//!   for a wrong password), `40h`/`41h`/`42h`/`48h` switch the baud rate once the `A0h` reply
//!   has left at the old rate. Mode and baud changes take effect when their reply has been
//!   sent, so scans can still precede the `A0h` of a stop (§6.5 step 8).
//! * `3Bh` (§6.2): the five LMS200 variants are accepted (`BB 01`), others refused (`BB 00`
//!   with the active variant); a change stops streaming.
//! * `31h` `B1h` reports operating mode (`24h`/`25h`/`00h`), variant, measuring mode, unit and
//!   baud code; `3Ah` the type string; `74h` the configuration block.
//! * `77h` (§6.3): only in installation mode and with a known unit and measuring mode
//!   (`F7 01`, counted in [`Lms2xxCounters::eeprom_writes`]), else `F7 00` with the block
//!   unchanged. Unit (byte 6), measuring mode (byte 5) and the real-time indices (byte 4,
//!   bit 1) change the scans.
//! * `10h`: `91h`, then the sensor restarts: not streaming, 9 600 Bd (unless
//!   [`Lms2xxOptions::permanent_baud`]), default variant, and `90h` after
//!   [`Lms2xxTiming::reset_delay_us`]. [`Lms2xx::power_cycle`] does the same without the
//!   `91h`, after [`Lms2xxTiming::power_on_delay_us`]. The configuration block is kept (it
//!   lives in EEPROM); the variant is not.
//! * Requests that parse but are not emulated (sub-range streaming, mean values, …) get ACK
//!   and `92h`.
//! * Streaming (§7, §9): the mirror turns at 75 Hz from the moment the sensor came up; a
//!   complete scan ends every 1, 2 or 4 rotations (75, 37.5, 18.75 scans/s), numbered from
//!   that moment. When a scan telegram takes longer on the line than a scan (`m` scan
//!   periods, rounded up), only every `m`-th scan is sent, those whose number is a multiple
//!   of `m`: the scans sent lie on a fixed grid of the sensor's clock, whenever streaming
//!   was asked for, as the mirror spins on regardless. At 500 kBd every scan is sent; at
//!   38 400 Bd a 0.5° scan (732 bytes, 191 ms) goes out every 213 ms, with 7 skipped ones in
//!   between. (The manual's table says 8 at 38 400 Bd, §9: the real sensor apparently also
//!   lets the first scan ending after the line is free go; this emulator skips exactly what
//!   the line cannot carry.) A scan is measured from the pose the sensor has when it ends
//!   ([`Lms2xx::set_motion`]). [`Lms2xx::stream_starts`] records when each stream began and
//!   when its first scan went out; [`Lms2xx::stop_scans_at`] ends the output at a fixed
//!   time, letting what is on the line leave whole.
//! * Replay ([`Lms2xx::replay`]): instead of measuring the world, streamed scans carry the
//!   ranges of recorded scans taken from a [`ScanSource`], in order, each exactly once. At
//!   [`ReplayPace::Recorded`] the log's clock is anchored at the first recorded scan, which
//!   goes out at the first scan end once streaming; every later one goes out at the first
//!   scan end at or after its log-relative time. At [`ReplayPace::AsFastAsPossible`] one
//!   recorded scan goes out per scan end. A scan end whose line is busy is skipped as
//!   usual, but the recorded scan waits for the next free one instead of being lost, so a
//!   log denser than the line carries goes out late, never thinned. When the source is
//!   exhausted the sensor keeps reporting that it streams but sends no more scans. A `30 01`
//!   request gets the recorded scan due then, else the last one sent again, else no `B0h`.
//!   Conversion to range words: see [`recorded_words`]; a recorded scan that carries a
//!   captured telegram ([`RecordedScan::telegram`]) goes out as those bytes, verbatim.
//!
//! Files: this module holds the emulator itself; `replay_source.rs` the recorded scans it
//! can stream instead of measured ones, `config_block.rs` the configuration block it keeps in
//! EEPROM, `type_text.rs` what it derives from its type string, and `tests.rs` its tests.

mod config_block;
mod replay_source;
#[cfg(test)]
mod tests;
mod type_text;

pub use replay_source::{
    BeamMapping, RecordedScan, ReplayPace, ReplayProgress, ScanSource, recorded_words,
};

use std::collections::VecDeque;

use firmware::sick::command::DEFAULT_PASSWORD;
use firmware::sick::reply::MAX_TEXT_LEN;
use firmware::sick::status_reply::{OPERATING_MODE_ON_REQUEST, OPERATING_MODE_STREAMING};
use firmware::sick::telegram::{ACK, HOST_ADDRESS, MAX_LEN_FIELD, NAK, STX, telegram_len};
use firmware::sick::{
    ConfigBlock, LmsBaud, MeasuringMode, OperatingMode, Reply, Request, ScanRepr, StatusReply,
    Telegram,
};
use protocol::RangeUnit;

use super::lms_variant::{ROTATION_US_DENOMINATOR, ROTATION_US_NUMERATOR, Variant};
use super::range_model::{DEFAULT_MAX_RANGE_M, DEFAULT_RANGE_SIGMA_M, RangeModel};
use super::tx_line::{BITS_PER_BYTE, TxLine, TxRun, byte_offset_us};
use crate::world::{Room, SensorPose, World};
use config_block::{default_config, is_valid_config, merge_config};
use replay_source::Replay;
use type_text::{floor_char_boundary, version_of};

/// The status byte of every telegram: no error, LMS type 6 (§8).
pub const STATUS_OK: u8 = 0x10;
/// The baud rate after power-on.
pub const POWER_ON_BAUD: u32 = 9_600;
/// The longest pause inside a request before the sensor drops it (§5).
pub const MAX_REQUEST_GAP_US: u64 = 6_000;
/// The operating mode `B1h` reports in installation mode (the `20h` sub-command).
const OPERATING_MODE_INSTALLATION: u8 = 0x00;

/// How long the sensor takes, in µs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lms2xxTiming {
    /// From the last byte of a request to the ACK or NAK (the sensor allows itself 60 ms).
    pub ack_delay_us: u64,
    /// From the ACK to replies other than mode switches and configuration writes.
    pub reply_delay_us: u64,
    /// From the ACK to the `A0h` reply of a mode switch (the sensor allows itself 3 s).
    pub mode_switch_delay_us: u64,
    /// From the ACK to the `F7h` reply of a configuration write (EEPROM).
    pub config_write_delay_us: u64,
    /// From the `91h` of a software reset to the `90h` power-on message.
    pub reset_delay_us: u64,
    /// From power-on to the `90h` power-on message (up to 60 s on a real LMS200; short here
    /// so that tests run quickly).
    pub power_on_delay_us: u64,
}

impl Default for Lms2xxTiming {
    fn default() -> Self {
        Lms2xxTiming {
            ack_delay_us: 2_000,
            reply_delay_us: 10_000,
            mode_switch_delay_us: 100_000,
            config_write_delay_us: 1_000_000,
            reset_delay_us: 500_000,
            power_on_delay_us: 700_000,
        }
    }
}

/// The sensor's settings at power-on and the emulation's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Lms2xxOptions {
    /// Baud rate at power-on: 9 600 on delivery; another supported rate models a sensor whose
    /// rate was made permanent. Unsupported rates fall back to 9 600.
    pub baud: u32,
    /// Whether the sensor keeps its last rate over a reset or power cycle (command `66h`).
    pub permanent_baud: bool,
    /// Type and firmware string of `BAh` and `90h` (at most 48 bytes; the version shown in
    /// `B1h` is the part after the last `;`).
    pub type_text: String,
    /// Variant at power-on.
    pub variant: Variant,
    /// Unit of the range words (configuration byte 6).
    pub unit: RangeUnit,
    /// Measuring mode (configuration byte 5).
    pub measuring_mode: MeasuringMode,
    /// Whether the sensor has just been switched on: silent until it sends `90h` after
    /// [`Lms2xxTiming::power_on_delay_us`]. Otherwise it is ready at time 0 and sends nothing.
    pub send_power_on: bool,
    /// Delays.
    pub timing: Lms2xxTiming,
    /// Range noise, 1 σ, metres.
    pub range_sigma_m: f64,
    /// Surfaces farther away give no echo, metres.
    pub max_range_m: f64,
    /// Seed of the range noise.
    pub seed: u64,
    /// The sensor's pose in the world.
    pub pose: SensorPose,
    /// Whether a request cuts short a scan being sent (§5, §10.3).
    pub requests_interrupt_output: bool,
}

impl Default for Lms2xxOptions {
    /// An LMS200 as delivered, just switched on: 9 600 Bd, 180° at 1°, cm, mode 0.
    fn default() -> Self {
        Lms2xxOptions {
            baud: POWER_ON_BAUD,
            permanent_baud: false,
            type_text: "LMS200;S18063;V02.19 ".to_owned(),
            variant: Variant::DEFAULT,
            unit: RangeUnit::Cm,
            measuring_mode: MeasuringMode::DEFAULT,
            send_power_on: true,
            timing: Lms2xxTiming::default(),
            range_sigma_m: DEFAULT_RANGE_SIGMA_M,
            max_range_m: DEFAULT_MAX_RANGE_M,
            seed: 0,
            pose: SensorPose::default(),
            requests_interrupt_output: true,
        }
    }
}

/// What the emulator did. Telegrams and bytes are counted when they start to be sent,
/// except [`Self::bytes_sent`], counted as they leave the line.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Lms2xxCounters {
    /// Requests with a valid address and CRC.
    pub requests: u32,
    /// ACK bytes sent.
    pub acks: u32,
    /// NAK bytes sent (bad CRC).
    pub naks: u32,
    /// Reply telegrams sent in answer to requests (`92h` and the `B0h` of `30 01` included).
    pub replies: u32,
    /// `92h` replies sent.
    pub rejected: u32,
    /// `90h` power-on messages sent.
    pub power_on_messages: u32,
    /// Streamed and requested `B0h` telegrams sent.
    pub scans_sent: u32,
    /// Streamed scans not sent because the line was busy or they were not on the grid of
    /// the scans the line can carry.
    pub scans_skipped: u32,
    /// Scans cut short by a request.
    pub scans_interrupted: u32,
    /// Bytes that have left the line.
    pub bytes_sent: u64,
    /// Received bytes not understood: wrong baud rate, sensor starting up, outside a
    /// telegram, or part of a request dropped for a pause.
    pub garbage_bytes: u64,
    /// Requests ignored for their address.
    pub wrong_address: u32,
    /// Accepted configuration writes.
    pub eeprom_writes: u32,
}

/// The operating mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    OnRequest,
    Streaming,
    Installation,
}

/// What a telegram put on the line is, for the counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outgoing {
    Ack,
    Nak,
    Reply,
    Rejected,
    PowerOn,
}

/// A state change made when the line reaches it (after the reply before it has left).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Change {
    Mode(Mode),
    Baud(u32),
    Reset,
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum Item {
    Send {
        bytes: Vec<u8>,
        what: Outgoing,
    },
    /// The `B0h` answering `30 01`, measured when it is sent.
    OneScan,
    Apply(Change),
}

#[derive(Debug, Clone, PartialEq, Eq)]
struct Queued {
    not_before_us: u64,
    item: Item,
}

/// The emulated LMS200. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct Lms2xx<W = Room> {
    options: Lms2xxOptions,
    ranges: RangeModel<W>,
    baud: u32,
    mode: Mode,
    variant: Variant,
    config: ConfigBlock,
    /// Input is not understood before this time (starting up).
    online_at_us: u64,
    /// The mirror's rotations are counted from here.
    mirror_epoch_us: u64,
    /// Rotation at whose end the next streamed scan is complete.
    next_scan_rotation: u64,
    telegram_index: u8,
    rx: Vec<u8>,
    rx_last_us: u64,
    queue: VecDeque<Queued>,
    line: TxLine,
    out: Vec<TxRun>,
    last_now_us: u64,
    counters: Lms2xxCounters,
    /// Recorded scans streamed instead of measured ones.
    replay: Option<Replay>,
    /// Where the sensor is at each moment, when it moves.
    motion: Option<Motion>,
    /// Scan telegrams on the line whose first byte has not left: (when it leaves, when the
    /// scan was measured), µs.
    scans_queued: VecDeque<(u64, u64)>,
    /// When the scans whose first byte has left were measured, µs, until taken.
    scans_started: Vec<u64>,
    /// Every stream so far.
    stream_starts: Vec<StreamStart>,
    /// No streamed scan goes out from this time on.
    scans_end_us: Option<u64>,
}

/// The sensor's pose as a function of time (µs), shared by the emulator's clones.
#[derive(Clone)]
struct Motion(std::sync::Arc<dyn Fn(u64) -> SensorPose + Send + Sync>);

impl std::fmt::Debug for Motion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Motion")
    }
}

/// A stream of scans as the sensor began it ([`Lms2xx::stream_starts`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct StreamStart {
    /// When the sensor switched to streaming (its `A0h` reply had left), µs.
    pub streaming_us: u64,
    /// When the first scan it sends ends (its telegram starts then), µs: a request for the
    /// stream may come up to `first_scan_us - streaming_us` later and the same scans go out.
    pub first_scan_us: u64,
}

impl Lms2xx<Room> {
    /// A sensor in the default [`Room`].
    pub fn new(options: Lms2xxOptions) -> Self {
        Lms2xx::with_world(options, Room::default())
    }
}

impl<W: World> Lms2xx<W> {
    /// A sensor measuring `world`.
    pub fn with_world(mut options: Lms2xxOptions, world: W) -> Self {
        if LmsBaud::from_baud(options.baud).is_none() {
            options.baud = POWER_ON_BAUD;
        }
        if !options.variant.is_supported() {
            options.variant = Variant::DEFAULT;
        }
        options
            .type_text
            .truncate(floor_char_boundary(&options.type_text, MAX_TEXT_LEN));
        let mut config = default_config();
        config.set_unit(options.unit);
        config.set_measuring_mode(options.measuring_mode);
        let ranges = RangeModel::new(
            world,
            options.pose,
            options.range_sigma_m,
            options.max_range_m,
            options.seed,
        );
        let mut lms = Lms2xx {
            baud: options.baud,
            mode: Mode::OnRequest,
            variant: options.variant,
            config,
            online_at_us: 0,
            mirror_epoch_us: 0,
            next_scan_rotation: 0,
            telegram_index: 0,
            rx: Vec::new(),
            rx_last_us: 0,
            queue: VecDeque::new(),
            line: TxLine::new(),
            out: Vec::new(),
            last_now_us: 0,
            counters: Lms2xxCounters::default(),
            replay: None,
            motion: None,
            scans_queued: VecDeque::new(),
            scans_started: Vec::new(),
            stream_starts: Vec::new(),
            scans_end_us: None,
            ranges,
            options,
        };
        if lms.options.send_power_on {
            lms.restart(0, lms.options.timing.power_on_delay_us);
        }
        lms
    }

    /// Takes `bytes` the host sent at `host_baud`, the last of them arriving at `now_us`.
    pub fn receive(&mut self, bytes: &[u8], host_baud: u32, now_us: u64) {
        let now_us = self.advance(now_us);
        if bytes.is_empty() {
            return;
        }
        if now_us < self.online_at_us || host_baud != self.baud {
            self.drop_rx();
            self.counters.garbage_bytes += bytes.len() as u64;
            return;
        }
        if !self.rx.is_empty() && now_us.saturating_sub(self.rx_last_us) > MAX_REQUEST_GAP_US {
            self.drop_rx();
        }
        self.rx.extend_from_slice(bytes);
        self.rx_last_us = now_us;
        self.parse_requests(now_us);
    }

    /// The bytes that have left the sensor by `now_us`, in order.
    pub fn poll_output(&mut self, now_us: u64) -> Vec<u8> {
        self.poll_output_runs(now_us)
            .into_iter()
            .flat_map(|run| run.bytes)
            .collect()
    }

    /// The bytes that have left the sensor by `now_us`, grouped by the baud rate they were
    /// sent at (a receiver at another rate does not understand them; see
    /// [`super::baud_mismatch::garble`]).
    pub fn poll_output_runs(&mut self, now_us: u64) -> Vec<TxRun> {
        self.advance(now_us);
        std::mem::take(&mut self.out)
    }

    /// When the output or the state changes next, if anything is scheduled: poll then.
    pub fn next_output_us(&self) -> Option<u64> {
        let byte = self.line.next_byte_end_us();
        let item = self
            .queue
            .front()
            .map(|q| q.not_before_us.max(self.line.free_at_us()));
        let replay_done = self.replay.as_ref().is_some_and(Replay::is_finished);
        let scan = (self.mode == Mode::Streaming && !replay_done)
            .then(|| self.rotation_end_us(self.next_scan_rotation))
            .filter(|&at| self.scans_end_us.is_none_or(|end| at < end));
        [byte, item, scan].into_iter().flatten().min()
    }

    /// Switches the sensor off and on at `now_us`: output stops mid-byte, streaming stops,
    /// the rate returns to 9 600 Bd (unless permanent), and `90h` follows after
    /// [`Lms2xxTiming::power_on_delay_us`].
    pub fn power_cycle(&mut self, now_us: u64) {
        let now_us = self.advance(now_us);
        self.line.cut(now_us);
        self.scans_queued.clear();
        self.queue.clear();
        self.restart(now_us, self.options.timing.power_on_delay_us);
    }

    /// Whether bytes put on the line have not all left yet.
    pub fn is_transmitting(&self) -> bool {
        self.line.next_byte_end_us().is_some()
    }

    /// The current baud rate.
    pub fn baud(&self) -> u32 {
        self.baud
    }

    /// Whether the sensor streams scans.
    pub fn is_streaming(&self) -> bool {
        self.mode == Mode::Streaming
    }

    /// Whether the sensor is in installation mode.
    pub fn is_installation_mode(&self) -> bool {
        self.mode == Mode::Installation
    }

    /// The active variant.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// The configuration block.
    pub fn config(&self) -> ConfigBlock {
        self.config
    }

    /// The counters.
    pub fn counters(&self) -> Lms2xxCounters {
        self.counters
    }

    /// The options the sensor was made with.
    pub fn options(&self) -> &Lms2xxOptions {
        &self.options
    }

    /// The sensor's pose.
    pub fn pose(&self) -> SensorPose {
        self.ranges.pose
    }

    /// Moves the sensor; scans measured from now on see the world from `pose` (and a motion
    /// set with [`Self::set_motion`] is dropped).
    pub fn set_pose(&mut self, pose: SensorPose) {
        self.motion = None;
        self.ranges.pose = pose;
    }

    /// Moves the sensor along `pose_at` (µs to pose): each scan sees the world from the pose
    /// at the moment it ends, however late the emulator is polled.
    pub fn set_motion(&mut self, pose_at: impl Fn(u64) -> SensorPose + Send + Sync + 'static) {
        self.motion = Some(Motion(std::sync::Arc::new(pose_at)));
    }

    /// When each scan telegram whose first byte has left the line since the last call was
    /// measured (the end of its scan), µs, in the order they went out.
    pub fn take_scans_started(&mut self) -> Vec<u64> {
        std::mem::take(&mut self.scans_started)
    }

    /// Every stream of scans begun so far, in order.
    pub fn stream_starts(&self) -> &[StreamStart] {
        &self.stream_starts
    }

    /// From `end_us` on, no streamed scan goes out; what is on the line then leaves whole.
    pub fn stop_scans_at(&mut self, end_us: u64) {
        self.scans_end_us = Some(end_us);
    }

    /// The range model (world, pose, noise), e.g. to compute the expected ranges.
    pub fn range_model(&self) -> &RangeModel<W> {
        &self.ranges
    }

    /// From now on, streamed and requested scans carry the recorded scans of `source`
    /// instead of measuring the world, paced by `pace`, their beams placed on the active
    /// variant's by `mapping` (see the [module documentation](self) and [`recorded_words`]).
    /// Replaces any earlier source.
    pub fn replay<S>(&mut self, source: S, pace: ReplayPace, mapping: BeamMapping)
    where
        S: ScanSource + Clone + Send + 'static,
    {
        self.replay = Some(Replay::new(source, pace, mapping));
    }

    /// Drops the replay source: scans measure the world again.
    pub fn stop_replay(&mut self) {
        self.replay = None;
    }

    /// Where the replay stands, if a source is set.
    pub fn replay_progress(&self) -> Option<ReplayProgress> {
        self.replay.as_ref().map(Replay::progress)
    }

    /// Runs every event due by `now_us` in time order; returns `now_us`, never earlier than
    /// the previous call's.
    fn advance(&mut self, now_us: u64) -> u64 {
        let now_us = now_us.max(self.last_now_us);
        self.last_now_us = now_us;
        loop {
            let free_us = self.line.free_at_us();
            let item_us = self.queue.front().map(|q| q.not_before_us.max(free_us));
            let scan_us = (self.mode == Mode::Streaming)
                .then(|| self.rotation_end_us(self.next_scan_rotation))
                .filter(|&at| self.scans_end_us.is_none_or(|end| at < end));
            match (item_us, scan_us) {
                (Some(t), scan) if t <= now_us && scan.is_none_or(|s| t <= s) => {
                    if let Some(queued) = self.queue.pop_front() {
                        self.run(queued.item, t);
                    }
                }
                (_, Some(t)) if t <= now_us => self.complete_scan(t),
                _ => break,
            }
        }
        let first_new = self.out.len();
        let merge_from = first_new.saturating_sub(1);
        let before: usize = self.out[merge_from..].iter().map(|r| r.bytes.len()).sum();
        self.line.transmit_until(now_us, &mut self.out);
        let after: usize = self.out[merge_from..].iter().map(|r| r.bytes.len()).sum();
        self.counters.bytes_sent += (after - before) as u64;
        while let Some(&(first_byte_us, measured_us)) = self.scans_queued.front()
            && first_byte_us <= now_us
        {
            self.scans_started.push(measured_us);
            self.scans_queued.pop_front();
        }
        now_us
    }

    /// Carries out a queued item at `at_us`.
    fn run(&mut self, item: Item, at_us: u64) {
        match item {
            Item::Send { bytes, what } => {
                let counter = match what {
                    Outgoing::Ack => &mut self.counters.acks,
                    Outgoing::Nak => &mut self.counters.naks,
                    Outgoing::Reply => &mut self.counters.replies,
                    Outgoing::Rejected => {
                        self.counters.replies += 1;
                        &mut self.counters.rejected
                    }
                    Outgoing::PowerOn => &mut self.counters.power_on_messages,
                };
                *counter += 1;
                self.line.push(at_us, self.baud, bytes, false);
            }
            Item::OneScan => {
                let rotation = self.rotations_before(at_us);
                let bytes = match self.replay.as_mut() {
                    None => self.measure_scan(rotation),
                    Some(replay) => match replay.take_due(at_us).or_else(|| replay.last().cloned())
                    {
                        Some(scan) => self.recorded_scan(&scan, rotation),
                        // Nothing recorded yet and the source is empty: no `B0h`.
                        None => return,
                    },
                };
                self.counters.replies += 1;
                self.counters.scans_sent += 1;
                self.push_scan(at_us, self.rotation_end_us(rotation), bytes, false);
            }
            Item::Apply(Change::Mode(mode)) => {
                if mode == Mode::Streaming && self.mode != Mode::Streaming {
                    self.next_scan_rotation = self.next_scan_rotation_after(at_us);
                    let per_scan = self.variant.rotations_per_scan();
                    let grid = self.scans_per_telegram() * per_scan;
                    let first_rotation = self.next_scan_rotation.div_ceil(grid) * grid;
                    self.stream_starts.push(StreamStart {
                        streaming_us: at_us,
                        first_scan_us: self.rotation_end_us(first_rotation),
                    });
                }
                self.mode = mode;
            }
            Item::Apply(Change::Baud(baud)) => {
                self.baud = baud;
                self.drop_rx();
            }
            Item::Apply(Change::Reset) => self.restart(at_us, self.options.timing.reset_delay_us),
        }
    }

    /// A streamed scan ends at `at_us`: sent if it lies on the grid of the scans the line
    /// can carry and the line is free, else skipped.
    fn complete_scan(&mut self, at_us: u64) {
        let rotation = self.next_scan_rotation;
        let per_scan = self.variant.rotations_per_scan();
        self.next_scan_rotation += per_scan;
        let on_grid = (rotation / per_scan) % self.scans_per_telegram() == 0;
        if on_grid && self.line.free_at_us() <= at_us {
            let bytes = match self.replay.as_mut() {
                None => self.measure_scan(rotation),
                Some(replay) => match replay.take_due(at_us) {
                    Some(scan) => self.recorded_scan(&scan, rotation),
                    // Nothing recorded is due (or the log is exhausted): no telegram.
                    None => return,
                },
            };
            self.counters.scans_sent += 1;
            self.push_scan(at_us, at_us, bytes, self.options.requests_interrupt_output);
        } else {
            self.counters.scans_skipped += 1;
        }
    }

    /// Puts the telegram of a scan measured at `measured_us` on the line at `at_us`.
    fn push_scan(&mut self, at_us: u64, measured_us: u64, bytes: Vec<u8>, interruptible: bool) {
        if bytes.is_empty() {
            return;
        }
        let first_byte_us = at_us.max(self.line.free_at_us()) + byte_offset_us(1, self.baud);
        self.line.push(at_us, self.baud, bytes, interruptible);
        self.scans_queued.push_back((first_byte_us, measured_us));
    }

    /// How many scan periods a scan telegram takes on the line at the current rate, rounded
    /// up: only every so many scans is sent.
    fn scans_per_telegram(&self) -> u64 {
        let bits_us = self.scan_telegram_len() as u64 * BITS_PER_BYTE * 1_000_000;
        let scan_us_times_baud =
            self.variant.rotations_per_scan() * ROTATION_US_NUMERATOR * u64::from(self.baud);
        (bits_us * ROTATION_US_DENOMINATOR)
            .div_ceil(scan_us_times_baud.max(1))
            .max(1)
    }

    /// The length of a scan telegram of the active variant and configuration.
    fn scan_telegram_len(&self) -> usize {
        let mut values = heapless::Vec::new();
        // Every variant fits (at most 401 values).
        let _ = values.resize(usize::from(self.variant.values_per_scan()), 0);
        ScanRepr {
            unit: RangeUnit::Cm,
            partial_raster: None,
            values,
            indices: self.config.real_time_indices().then_some((0, 0)),
            status: STATUS_OK,
        }
        .buffer_len()
    }

    /// Back to the power-on state at `at_us`; `90h` after `delay_us`.
    fn restart(&mut self, at_us: u64, delay_us: u64) {
        if !self.options.permanent_baud {
            self.baud = POWER_ON_BAUD;
        }
        self.mode = Mode::OnRequest;
        self.variant = self.options.variant;
        self.drop_rx();
        self.online_at_us = at_us + delay_us;
        self.mirror_epoch_us = self.online_at_us;
        let power_on = Reply::PowerOn {
            text: heapless::Vec::from_slice(self.options.type_text.as_bytes()).unwrap_or_default(),
            status: STATUS_OK,
        };
        self.enqueue(
            self.online_at_us,
            Item::Send {
                bytes: emit_reply(&power_on),
                what: Outgoing::PowerOn,
            },
        );
    }

    fn enqueue(&mut self, not_before_us: u64, item: Item) {
        self.queue.push_back(Queued {
            not_before_us,
            item,
        });
    }

    fn drop_rx(&mut self) {
        self.counters.garbage_bytes += self.rx.len() as u64;
        self.rx.clear();
    }

    /// Takes every complete telegram from the receive buffer.
    fn parse_requests(&mut self, now_us: u64) {
        loop {
            let Some(start) = self.rx.iter().position(|&b| b == STX) else {
                self.drop_rx();
                return;
            };
            self.counters.garbage_bytes += start as u64;
            self.rx.drain(..start);
            let [_, _, lo, hi, ..] = self.rx[..] else {
                return;
            };
            let len_field = u16::from_le_bytes([lo, hi]);
            if len_field == 0 || len_field > MAX_LEN_FIELD {
                self.counters.garbage_bytes += 1;
                self.rx.remove(0);
                continue;
            }
            let total = telegram_len(len_field);
            if self.rx.len() < total {
                return;
            }
            let bytes: Vec<u8> = self.rx.drain(..total).collect();
            self.handle_telegram(&bytes, now_us);
        }
    }

    /// Answers one framed request received at `now_us`.
    fn handle_telegram(&mut self, bytes: &[u8], now_us: u64) {
        let Ok(telegram) = Telegram::new_checked(bytes) else {
            self.counters.garbage_bytes += bytes.len() as u64;
            return;
        };
        if telegram.address() != HOST_ADDRESS {
            self.counters.wrong_address += 1;
            return;
        }
        if self.options.requests_interrupt_output && self.line.interrupt(now_us) {
            self.counters.scans_interrupted += 1;
            // A scan cut before its first byte left never went out.
            self.scans_queued.clear();
        }
        let ack_us = now_us + self.options.timing.ack_delay_us;
        if telegram.check_crc().is_err() {
            let what = Outgoing::Nak;
            self.enqueue(
                ack_us,
                Item::Send {
                    bytes: vec![NAK],
                    what,
                },
            );
            return;
        }
        self.counters.requests += 1;
        let what = Outgoing::Ack;
        self.enqueue(
            ack_us,
            Item::Send {
                bytes: vec![ACK],
                what,
            },
        );
        match Request::parse(&telegram) {
            Ok(request) => self.answer(request, ack_us),
            Err(_) => {
                let bytes = emit_reply(&Reply::Rejected { status: STATUS_OK });
                let what = Outgoing::Rejected;
                self.enqueue(
                    ack_us + self.options.timing.reply_delay_us,
                    Item::Send { bytes, what },
                );
            }
        }
    }

    /// Queues the reply to `request`, acknowledged at `ack_us`.
    fn answer(&mut self, request: Request, ack_us: u64) {
        let timing = self.options.timing;
        let reply_us = ack_us + timing.reply_delay_us;
        let (reply, at_us, change) = match request {
            Request::SetMode(mode) => {
                let (result, change) = match mode {
                    OperatingMode::Installation { password } if password == DEFAULT_PASSWORD => {
                        (0, Some(Change::Mode(Mode::Installation)))
                    }
                    OperatingMode::Installation { .. } => (1, None),
                    OperatingMode::StreamAll => (0, Some(Change::Mode(Mode::Streaming))),
                    OperatingMode::OnRequest => (0, Some(Change::Mode(Mode::OnRequest))),
                    OperatingMode::Baud(baud) => (0, Some(Change::Baud(baud.baud()))),
                };
                let reply = Reply::ModeSwitch {
                    result,
                    status: STATUS_OK,
                };
                (reply, ack_us + timing.mode_switch_delay_us, change)
            }
            Request::SetVariant {
                angle_deg,
                resolution_cdeg,
            } => {
                let wanted = Variant::new(angle_deg, resolution_cdeg);
                let accepted = wanted.is_supported();
                if accepted {
                    self.variant = wanted;
                    if self.mode == Mode::Streaming {
                        self.mode = Mode::OnRequest;
                    }
                }
                let reply = Reply::Variant {
                    accepted,
                    angle_deg: self.variant.angle_deg,
                    resolution_cdeg: self.variant.resolution_cdeg,
                    status: STATUS_OK,
                };
                (reply, reply_us, None)
            }
            Request::Status => (Reply::Status(self.status()), reply_us, None),
            Request::Type => {
                let reply = Reply::Type {
                    text: heapless::Vec::from_slice(self.options.type_text.as_bytes())
                        .unwrap_or_default(),
                    status: STATUS_OK,
                };
                (reply, reply_us, None)
            }
            Request::ReadConfig => {
                let reply = Reply::Config {
                    block: self.config,
                    status: STATUS_OK,
                };
                (reply, reply_us, None)
            }
            Request::WriteConfig(block) => {
                let accepted = self.mode == Mode::Installation && is_valid_config(&block);
                if accepted {
                    self.config = merge_config(self.config, &block);
                    self.counters.eeprom_writes += 1;
                }
                let reply = Reply::ConfigWritten {
                    accepted,
                    block: self.config,
                    status: STATUS_OK,
                };
                (reply, ack_us + timing.config_write_delay_us, None)
            }
            Request::OneScan => {
                let rotation = self.next_scan_rotation_after(ack_us);
                self.enqueue(self.rotation_end_us(rotation), Item::OneScan);
                return;
            }
            Request::Reset => (
                Reply::ResetAck { status: STATUS_OK },
                reply_us,
                Some(Change::Reset),
            ),
        };
        let bytes = emit_reply(&reply);
        self.enqueue(
            at_us,
            Item::Send {
                bytes,
                what: Outgoing::Reply,
            },
        );
        if let Some(change) = change {
            self.enqueue(0, Item::Apply(change));
        }
    }

    /// The status block as the sensor stands now.
    fn status(&self) -> StatusReply {
        let operating_mode = match self.mode {
            Mode::OnRequest => OPERATING_MODE_ON_REQUEST,
            Mode::Streaming => OPERATING_MODE_STREAMING,
            Mode::Installation => OPERATING_MODE_INSTALLATION,
        };
        StatusReply {
            version: version_of(&self.options.type_text),
            operating_mode,
            device_status: 0,
            measuring_mode: self.config.measuring_mode(),
            angle_deg: self.variant.angle_deg,
            resolution_cdeg: self.variant.resolution_cdeg,
            baud_code: LmsBaud::from_baud(self.baud).map_or(0, LmsBaud::status_code),
            permanent_baud: self.options.permanent_baud,
            address: HOST_ADDRESS,
            unit_byte: self.config.as_bytes().get(6).copied().unwrap_or(0),
            status: STATUS_OK,
        }
    }

    /// Measures a complete scan ending with mirror rotation `rotation` and builds its
    /// `B0h` telegram.
    fn measure_scan(&mut self, rotation: u64) -> Vec<u8> {
        if let Some(Motion(pose_at)) = &self.motion {
            self.ranges.pose = pose_at(self.rotation_end_us(rotation));
        }
        let unit = self.config.unit().unwrap_or(RangeUnit::Cm);
        let words = self
            .ranges
            .scan_words(self.variant, unit, self.config.measuring_mode());
        self.scan_telegram(unit, &words, rotation)
    }

    /// The `B0h` telegram of the recorded `scan`, completed with mirror rotation `rotation`.
    fn recorded_scan(&mut self, scan: &RecordedScan, rotation: u64) -> Vec<u8> {
        if let Some(telegram) = &scan.telegram {
            return telegram.clone();
        }
        let unit = self.config.unit().unwrap_or(RangeUnit::Cm);
        let mapping = self
            .replay
            .as_ref()
            .map_or(BeamMapping::Exact, Replay::mapping);
        let words = recorded_words(
            scan,
            self.variant,
            unit,
            self.config.measuring_mode(),
            self.options.max_range_m,
            mapping,
        );
        self.scan_telegram(unit, &words, rotation)
    }

    /// The `B0h` telegram of `words`, completed with mirror rotation `rotation`.
    fn scan_telegram(&mut self, unit: RangeUnit, words: &[u16], rotation: u64) -> Vec<u8> {
        let indices = self
            .config
            .real_time_indices()
            .then_some((rotation as u8, self.telegram_index));
        self.telegram_index = self.telegram_index.wrapping_add(1);
        let scan = ScanRepr {
            unit,
            partial_raster: None,
            // At most 401 words: every supported variant fits.
            values: heapless::Vec::from_slice(words).unwrap_or_default(),
            indices,
            status: STATUS_OK,
        };
        let mut bytes = vec![0u8; scan.buffer_len()];
        match scan.emit(&mut Telegram::new_unchecked(&mut bytes[..])) {
            Ok(()) => bytes,
            // The buffer has exactly `buffer_len` bytes, so emit cannot fail.
            Err(_) => Vec::new(),
        }
    }

    /// When mirror rotation `rotation` (counted from 0 at start-up) ends.
    fn rotation_end_us(&self, rotation: u64) -> u64 {
        self.mirror_epoch_us + rotation * ROTATION_US_NUMERATOR / ROTATION_US_DENOMINATOR
    }

    /// Rotations completed by `at_us`.
    fn rotations_before(&self, at_us: u64) -> u64 {
        at_us.saturating_sub(self.mirror_epoch_us) * ROTATION_US_DENOMINATOR / ROTATION_US_NUMERATOR
    }

    /// The first rotation ending a complete scan strictly after `at_us`.
    fn next_scan_rotation_after(&self, at_us: u64) -> u64 {
        let per_scan = self.variant.rotations_per_scan();
        let mut rotation = (self.rotations_before(at_us) / per_scan + 1) * per_scan;
        while self.rotation_end_us(rotation) <= at_us {
            rotation += per_scan;
        }
        rotation
    }
}

/// The telegram bytes of `reply`.
fn emit_reply(reply: &Reply) -> Vec<u8> {
    let mut bytes = vec![0u8; reply.buffer_len()];
    match reply.emit(&mut Telegram::new_unchecked(&mut bytes[..])) {
        Ok(()) => bytes,
        // The buffer has exactly `buffer_len` bytes, so emit cannot fail.
        Err(_) => Vec::new(),
    }
}
