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
use super::range_model::{
    DEFAULT_MAX_RANGE_M, DEFAULT_RANGE_SIGMA_M, RangeModel, beam_bearing_rad, encode_range,
};
use super::tx_line::{BITS_PER_BYTE, TxLine, TxRun, byte_offset_us};
use crate::world::{Room, SensorPose, World};

/// The status byte of every telegram: no error, LMS type 6 (§8).
pub const STATUS_OK: u8 = 0x10;
/// The baud rate after power-on.
pub const POWER_ON_BAUD: u32 = 9_600;
/// The longest pause inside a request before the sensor drops it (§5).
pub const MAX_REQUEST_GAP_US: u64 = 6_000;
/// The operating mode `B1h` reports in installation mode (the `20h` sub-command).
const OPERATING_MODE_INSTALLATION: u8 = 0x00;
/// Measuring modes the sensor accepts in a configuration write.
const KNOWN_MEASURING_MODES: [u8; 9] = [0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F, 0x3F];

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
        self.replay = Some(Replay {
            source: Box::new(source),
            pace,
            mapping,
            pending: None,
            last: None,
            anchor: None,
            exhausted: false,
            sent: 0,
        });
    }

    /// Drops the replay source: scans measure the world again.
    pub fn stop_replay(&mut self) {
        self.replay = None;
    }

    /// Where the replay stands, if a source is set.
    pub fn replay_progress(&self) -> Option<ReplayProgress> {
        self.replay.as_ref().map(|r| ReplayProgress {
            scans_sent: r.sent,
            finished: r.is_finished(),
        })
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
                    Some(replay) => match replay.take_due(at_us).or_else(|| replay.last.clone()) {
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
            .map_or(BeamMapping::Exact, |r| r.mapping);
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

/// One recorded scan to stream instead of a measured one ([`Lms2xx::replay`]).
///
/// Beam `i` points at bearing `first_beam_rad + i · resolution_rad` from the sensor's
/// forward axis, counter-clockwise positive (the laser-frame angle of the LMS is that
/// bearing plus 90°).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedScan {
    /// When it was recorded, seconds on the log's clock (only differences matter).
    pub timestamp_s: f64,
    /// Bearing of beam 0, radians.
    pub first_beam_rad: f64,
    /// Bearing step from one beam to the next, radians.
    pub resolution_rad: f64,
    /// One range per beam, metres. A negative or non-finite range means no echo.
    pub ranges_m: Vec<f64>,
    /// Ranges at or above this are the recorder's "no return" marker, metres (e.g. the
    /// maximum range of a `ROBOTLASER1` message).
    pub no_return_from_m: Option<f64>,
    /// The exact bytes of a captured telegram, sent verbatim in place of one built from
    /// the ranges, whatever its variant, unit or CRC (a raw capture's scans).
    pub telegram: Option<Vec<u8>>,
}

/// Where recorded scans come from, in the order they were recorded.
pub trait ScanSource {
    /// The next recorded scan, or `None` when the log is exhausted.
    fn next_scan(&mut self) -> Option<RecordedScan>;
}

impl<I: Iterator<Item = RecordedScan>> ScanSource for I {
    fn next_scan(&mut self) -> Option<RecordedScan> {
        self.next()
    }
}

/// When recorded scans go out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReplayPace {
    /// At the first scan end at or after each scan's log time, relative to the first scan.
    #[default]
    Recorded,
    /// One per scan end, as fast as the mirror (and the line) allows.
    AsFastAsPossible,
}

/// How the beams of a recorded scan are placed on the values of the active variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BeamMapping {
    /// A value takes the recorded beam at its exact angle (within 0.01°); a value without
    /// one is "no echo". 180 recorded beams at 1° (−90° … +89°) fill values 0–179 of the
    /// 181-value 180°/1° variant, and value 180 (the sensor's far left) is no echo; in the
    /// 361-value 180°/0.5° variant they fill the even values 0–358, and the odd values and
    /// value 360 are no echo. 361 beams at 0.5° into 181 values take every other beam.
    #[default]
    Exact,
    /// A value takes the recorded beam nearest to its angle if that beam is at most one
    /// recorded step away, else no echo: 180 beams at 1° fill the 181-value variant with
    /// value 180 repeating beam 179, and the 361-value variant with each half-degree value
    /// repeating the beam half a degree counter-clockwise of it (ties go that way), and
    /// values 359 and 360 repeating beam 179.
    Nearest,
}

/// How far a replay has come ([`Lms2xx::replay_progress`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplayProgress {
    /// Recorded scans sent so far.
    pub scans_sent: u32,
    /// Whether the source is exhausted and every scan of it sent.
    pub finished: bool,
}

/// The range words of one complete scan of `variant` carrying the recorded `scan`.
///
/// Each value takes a recorded range as [`BeamMapping`] says. A range is coded exactly as a
/// measured one ([`encode_range`]): no echo (all distance bits set) for values without a
/// recorded beam, negative or non-finite ranges, ranges at or above the recording's
/// `no_return_from_m`, and ranges beyond `max_range_m` (the sensor's maximum range); a
/// range the unit and measuring mode cannot express gives "measured value > maximum" (…F7h).
/// A receiver decodes both codes as "no return".
pub fn recorded_words(
    scan: &RecordedScan,
    variant: Variant,
    unit: RangeUnit,
    mode: MeasuringMode,
    max_range_m: f64,
    mapping: BeamMapping,
) -> Vec<u16> {
    /// Angular tolerance of [`BeamMapping::Exact`]: 0.01°.
    const EXACT_TOLERANCE_RAD: f64 = 0.01 * std::f64::consts::PI / 180.0;
    /// Fraction of a beam step that settles ties of [`BeamMapping::Nearest`].
    const TIE_BIAS: f64 = 1e-6;
    let count = scan.ranges_m.len();
    let beam_of = |index: u16| -> Option<usize> {
        let step = scan.resolution_rad;
        if count == 0 || !step.is_finite() || step == 0.0 {
            // Without a step only beam 0 has an angle.
            let offset = beam_bearing_rad(variant.beam_angle_cdeg(index)) - scan.first_beam_rad;
            return (count > 0 && offset.abs() <= EXACT_TOLERANCE_RAD).then_some(0);
        }
        let position =
            (beam_bearing_rad(variant.beam_angle_cdeg(index)) - scan.first_beam_rad) / step;
        let last = (count - 1) as f64;
        let nearest = match mapping {
            BeamMapping::Exact => position.round(),
            // Ties (a value halfway between two beams) go to the higher index, whatever
            // the rounding of `position`.
            BeamMapping::Nearest => (position + TIE_BIAS).round().clamp(0.0, last),
        };
        let off_rad = (position - nearest).abs() * step.abs();
        let close = match mapping {
            BeamMapping::Exact => off_rad <= EXACT_TOLERANCE_RAD,
            BeamMapping::Nearest => off_rad <= step.abs() + EXACT_TOLERANCE_RAD,
        };
        (close && (0.0..=last).contains(&nearest)).then_some(nearest as usize)
    };
    (0..variant.values_per_scan())
        .map(|index| {
            let range_m = beam_of(index)
                .and_then(|beam| scan.ranges_m.get(beam).copied())
                .filter(|r| r.is_finite() && *r >= 0.0 && *r <= max_range_m)
                .filter(|r| scan.no_return_from_m.is_none_or(|limit| *r < limit));
            encode_range(range_m, unit, mode)
        })
        .collect()
}

/// A [`ScanSource`] the emulator can clone with itself.
trait BoxedScanSource: ScanSource + Send {
    fn clone_boxed(&self) -> Box<dyn BoxedScanSource>;
}

impl<S: ScanSource + Clone + Send + 'static> BoxedScanSource for S {
    fn clone_boxed(&self) -> Box<dyn BoxedScanSource> {
        Box::new(self.clone())
    }
}

/// The replay state: the source, the scan waiting to go out, and the log clock's anchor.
struct Replay {
    source: Box<dyn BoxedScanSource>,
    pace: ReplayPace,
    mapping: BeamMapping,
    /// The next scan, taken from the source but not sent yet.
    pending: Option<RecordedScan>,
    /// The last scan sent.
    last: Option<RecordedScan>,
    /// (emulator time, log time) of the first scan sent.
    anchor: Option<(u64, f64)>,
    /// The source returned `None`.
    exhausted: bool,
    sent: u32,
}

impl Clone for Replay {
    fn clone(&self) -> Self {
        Replay {
            source: self.source.clone_boxed(),
            pace: self.pace,
            mapping: self.mapping,
            pending: self.pending.clone(),
            last: self.last.clone(),
            anchor: self.anchor,
            exhausted: self.exhausted,
            sent: self.sent,
        }
    }
}

impl std::fmt::Debug for Replay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Replay")
            .field("pace", &self.pace)
            .field("mapping", &self.mapping)
            .field("anchor", &self.anchor)
            .field("exhausted", &self.exhausted)
            .field("sent", &self.sent)
            .finish_non_exhaustive()
    }
}

impl Replay {
    /// Whether every scan of the source has been sent.
    fn is_finished(&self) -> bool {
        self.exhausted && self.pending.is_none()
    }

    /// The recorded scan to send at the scan end `at_us`, if one is due.
    fn take_due(&mut self, at_us: u64) -> Option<RecordedScan> {
        if self.pending.is_none() && !self.exhausted {
            self.pending = self.source.next_scan();
            self.exhausted = self.pending.is_none();
        }
        let scan = self.pending.as_ref()?;
        let due = match (self.pace, self.anchor) {
            (ReplayPace::Recorded, Some((anchor_us, anchor_s))) => {
                let after_s = scan.timestamp_s - anchor_s;
                // A stamp before the anchor (or not a number) is due at once.
                let after_us = if after_s > 0.0 {
                    (after_s * 1e6).round() as u64
                } else {
                    0
                };
                at_us >= anchor_us.saturating_add(after_us)
            }
            _ => true,
        };
        if !due {
            return None;
        }
        let scan = self.pending.take()?;
        if self.anchor.is_none() {
            self.anchor = Some((at_us, scan.timestamp_s));
        }
        self.sent += 1;
        self.last = Some(scan.clone());
        Some(scan)
    }
}

/// The configuration block of an LMS200 as delivered: no blanking, stop threshold `46h`,
/// default measuring mode, cm.
fn default_config() -> ConfigBlock {
    let mut block = [0u8; firmware::sick::config::CONFIG_LEN];
    block[2] = 0x46;
    // A 34-byte block is always valid.
    ConfigBlock::from_bytes(&block).unwrap_or_else(|_| unreachable!())
}

/// Whether a written block holds a unit and measuring mode the sensor knows.
fn is_valid_config(block: &ConfigBlock) -> bool {
    block.unit().is_some() && KNOWN_MEASURING_MODES.contains(&block.measuring_mode().0)
}

/// `current` with its first bytes replaced by `written` (an old-firmware block has 32).
fn merge_config(current: ConfigBlock, written: &ConfigBlock) -> ConfigBlock {
    let mut bytes = [0u8; firmware::sick::config::CONFIG_LEN];
    let current = current.as_bytes();
    bytes[..current.len()].copy_from_slice(current);
    let written = written.as_bytes();
    bytes[..written.len()].copy_from_slice(written);
    ConfigBlock::from_bytes(&bytes).unwrap_or_else(|_| unreachable!())
}

/// The 7-byte firmware version of `B1h`: the type string after its last `;`, padded with
/// spaces.
fn version_of(type_text: &str) -> [u8; 7] {
    let version = type_text.rsplit(';').next().unwrap_or("");
    let mut out = [b' '; 7];
    for (slot, byte) in out.iter_mut().zip(version.bytes()) {
        *slot = byte;
    }
    out
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

/// The largest index `<= max` that is a character boundary of `text`.
fn floor_char_boundary(text: &str, max: usize) -> usize {
    (0..=max.min(text.len()))
        .rev()
        .find(|&i| text.is_char_boundary(i))
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::garble;
    use firmware::sick::bringup::Action;
    use firmware::sick::{BringUp, BringUpConfig, Event, Input, RangeDecoder, Receiver, crc16};
    use protocol::LaserState;

    fn hex(text: &str) -> Vec<u8> {
        text.split_whitespace()
            .map(|b| u8::from_str_radix(b, 16).unwrap())
            .collect()
    }

    /// A request telegram with its CRC appended.
    fn with_crc(mut bytes: Vec<u8>) -> Vec<u8> {
        let crc = crc16(&bytes);
        bytes.extend_from_slice(&crc.to_le_bytes());
        bytes
    }

    /// A sensor that has been on for a while: no `90h`, ready at time 0.
    fn running(options: Lms2xxOptions) -> Lms2xx {
        Lms2xx::new(Lms2xxOptions {
            send_power_on: false,
            seed: 1,
            ..options
        })
    }

    /// Sends `request` at `baud` at `at_us`, returns every run sent until `until_us`.
    fn exchange(
        lms: &mut Lms2xx,
        request: &[u8],
        baud: u32,
        at_us: u64,
        until_us: u64,
    ) -> Vec<TxRun> {
        lms.receive(request, baud, at_us);
        lms.poll_output_runs(until_us)
    }

    fn bytes_of(runs: &[TxRun]) -> Vec<u8> {
        runs.iter().flat_map(|r| r.bytes.clone()).collect()
    }

    #[test]
    fn answers_the_example_requests() {
        let mut lms = running(Lms2xxOptions::default());
        let cases = [
            // Stop streaming → ACK, A0 00 (§4, §11).
            ("02 00 02 00 20 25 35 08", "06 02 80 03 00 A0 00 10 16 0A"),
            // Installation mode with the default password.
            (
                "02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 53 BE C5",
                "06 02 80 03 00 A0 00 10 16 0A",
            ),
            ("02 00 02 00 20 25 35 08", "06 02 80 03 00 A0 00 10 16 0A"),
            // Variant 180°/0.5°.
            (
                "02 00 05 00 3B B4 00 32 00 3B 1F",
                "06 02 80 07 00 BB 01 B4 00 32 00 10 03 9D",
            ),
            // Bad CRC → NAK only.
            ("02 00 01 00 31 15 13", "15"),
            // Wrong address → silence.
            ("02 05 01 00 31 15 12", ""),
        ];
        let mut now_us = 0;
        for (request, reply) in cases {
            let runs = exchange(&mut lms, &hex(request), 9_600, now_us, now_us + 500_000);
            assert_eq!(bytes_of(&runs), hex(reply), "{request}");
            now_us += 500_000;
        }
        // Sub-command 26h (mean values) is not emulated: ACK, 92h.
        let request = with_crc(hex("02 00 03 00 20 26 05"));
        let runs = exchange(&mut lms, &request, 9_600, now_us, now_us + 500_000);
        assert_eq!(bytes_of(&runs), hex("06 02 80 02 00 92 10 7F 33"));
        now_us += 500_000;
        // Wrong password → A0 01.
        let request = with_crc(hex("02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 00"));
        let runs = exchange(&mut lms, &request, 9_600, now_us, now_us + 500_000);
        let expected = emit_reply(&Reply::ModeSwitch {
            result: 1,
            status: STATUS_OK,
        });
        assert_eq!(bytes_of(&runs), [&[ACK][..], &expected].concat());
        now_us += 500_000;
        // 0.25° at 180° is refused; the active variant (180°/0.5°) is echoed.
        let request = with_crc(hex("02 00 05 00 3B B4 00 19 00"));
        let runs = exchange(&mut lms, &request, 9_600, now_us, now_us + 500_000);
        let reply = with_crc(hex("02 80 07 00 BB 00 B4 00 32 00 10"));
        assert_eq!(bytes_of(&runs), [&[ACK][..], &reply].concat());
        now_us += 500_000;
        // Type.
        let runs = exchange(
            &mut lms,
            &hex("02 00 01 00 3A 1E 12"),
            9_600,
            now_us,
            now_us + 500_000,
        );
        let bytes = bytes_of(&runs);
        assert_eq!(bytes[0], ACK);
        let telegram = Telegram::new_checked(&bytes[1..]).unwrap();
        assert_eq!(telegram.check_crc(), Ok(()));
        assert_eq!(
            Reply::parse(&telegram).unwrap(),
            Reply::Type {
                text: heapless::Vec::from_slice(b"LMS200;S18063;V02.19 ").unwrap(),
                status: STATUS_OK
            }
        );
        now_us += 500_000;
        // Status: exactly what the firmware's emitter makes of the sensor's state.
        let runs = exchange(
            &mut lms,
            &hex("02 00 01 00 31 15 12"),
            9_600,
            now_us,
            now_us + 500_000,
        );
        let expected = StatusReply {
            version: *b"V02.19 ",
            operating_mode: OPERATING_MODE_ON_REQUEST,
            device_status: 0,
            measuring_mode: MeasuringMode(0),
            angle_deg: 180,
            resolution_cdeg: 50,
            baud_code: 0x8067,
            permanent_baud: false,
            address: 0,
            unit_byte: 0,
            status: STATUS_OK,
        };
        let expected = [&[ACK][..], &emit_reply(&Reply::Status(expected))].concat();
        assert_eq!(bytes_of(&runs), expected);
        assert_eq!(bytes_of(&runs).len(), 1 + 160);
        now_us += 500_000;
        // One scan: a 361-value B0 in cm.
        let runs = exchange(
            &mut lms,
            &hex("02 00 02 00 30 01 31 18"),
            9_600,
            now_us,
            now_us + 1_500_000,
        );
        let bytes = bytes_of(&runs);
        assert_eq!(bytes[0], ACK);
        assert_eq!(&bytes[1..8], &hex("02 80 D6 02 B0 69 01")[..]);
        let scan = ScanRepr::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap();
        assert_eq!((scan.values.len(), scan.unit), (361, RangeUnit::Cm));
        // 5 m straight ahead.
        assert!(
            (i32::from(scan.values[180]) - 500).abs() <= 6,
            "{}",
            scan.values[180]
        );
        now_us += 1_500_000;
        // Reset → ACK, 91h; then 90h.
        let runs = exchange(
            &mut lms,
            &hex("02 00 01 00 10 34 12"),
            9_600,
            now_us,
            now_us + 2_000_000,
        );
        let bytes = bytes_of(&runs);
        assert_eq!(&bytes[..9], &hex("06 02 80 02 00 91 10 79 30")[..]);
        let telegram = Telegram::new_checked(&bytes[9..]).unwrap();
        assert_eq!(telegram.command(), 0x90);
        assert_eq!(telegram.data(), b"LMS200;S18063;V02.19 \x10");
        assert_eq!(lms.variant(), Variant::DEFAULT);
        let c = lms.counters();
        assert_eq!(
            (c.requests, c.acks, c.naks, c.wrong_address),
            (11, 11, 1, 1)
        );
        assert_eq!((c.rejected, c.power_on_messages, c.scans_sent), (1, 1, 1));
        assert_eq!(c.replies, 11);
    }

    #[test]
    fn reply_timing() {
        let mut lms = running(Lms2xxOptions::default());
        lms.receive(&hex("02 00 02 00 20 24 34 08"), 9_600, 1_000);
        // The ACK leaves within a few ms, the A0 after the mode switch delay.
        assert_eq!(lms.next_output_us(), Some(1_000 + 2_000));
        assert!(lms.poll_output(3_000).is_empty());
        assert_eq!(lms.next_output_us(), Some(1_000 + 2_000 + 1_042));
        assert!(lms.poll_output(4_041).is_empty());
        assert_eq!(lms.poll_output(4_042), [ACK]);
        assert!(lms.poll_output(100_000).is_empty());
        assert!(!lms.is_streaming());
        let a0 = lms.poll_output(120_000);
        assert_eq!(a0, hex("02 80 03 00 A0 00 10 16 0A"));
        assert!(lms.is_streaming());
    }

    #[test]
    fn configuration_write_needs_installation_mode() {
        let mut lms = running(Lms2xxOptions::default());
        let mut block = lms.config();
        block.set_unit(RangeUnit::Mm);
        block.set_measuring_mode(MeasuringMode(0x04));
        let write = Request::WriteConfig(block).to_bytes();
        let runs = exchange(&mut lms, write.as_bytes(), 9_600, 0, 2_000_000);
        let bytes = bytes_of(&runs);
        let reply = Reply::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap();
        assert!(matches!(
            reply,
            Reply::ConfigWritten {
                accepted: false,
                ..
            }
        ));
        assert_eq!(lms.config().unit(), Some(RangeUnit::Cm));
        let install = Request::SetMode(OperatingMode::Installation {
            password: DEFAULT_PASSWORD,
        });
        exchange(
            &mut lms,
            install.to_bytes().as_bytes(),
            9_600,
            2_000_000,
            2_500_000,
        );
        assert!(lms.is_installation_mode());
        lms.receive(write.as_bytes(), 9_600, 2_500_000);
        // The EEPROM write takes about a second.
        assert_eq!(lms.poll_output(3_000_000), [ACK]);
        let bytes = lms.poll_output(4_000_000);
        let reply = Reply::parse(&Telegram::new_checked(&bytes[..]).unwrap()).unwrap();
        assert_eq!(
            reply,
            Reply::ConfigWritten {
                accepted: true,
                block,
                status: STATUS_OK
            }
        );
        assert_eq!(lms.counters().eeprom_writes, 1);
        // Scans now come in mm, measuring mode 4 (16 m, 3FFFh for no echo).
        let runs = exchange(
            &mut lms,
            &hex("02 00 02 00 30 01 31 18"),
            9_600,
            4_000_000,
            5_000_000,
        );
        let bytes = bytes_of(&runs);
        let scan = ScanRepr::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap();
        assert_eq!((scan.unit, scan.values.len()), (RangeUnit::Mm, 181));
        assert!((i32::from(scan.values[90]) - 5_000).abs() < 60);
        // The status reports the new mode and unit.
        let runs = exchange(
            &mut lms,
            &hex("02 00 01 00 31 15 12"),
            9_600,
            5_000_000,
            6_000_000,
        );
        let bytes = bytes_of(&runs);
        let Reply::Status(status) =
            Reply::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap()
        else {
            panic!()
        };
        assert_eq!(status.operating_mode, OPERATING_MODE_INSTALLATION);
        assert_eq!(
            (status.measuring_mode, status.unit()),
            (MeasuringMode(4), Some(RangeUnit::Mm))
        );
    }

    #[test]
    fn baud_switch_takes_effect_after_the_reply() {
        let mut lms = running(Lms2xxOptions::default());
        let status = hex("02 00 01 00 31 15 12");
        lms.receive(&hex("02 00 02 00 20 48 58 08"), 9_600, 0);
        // Before the A0 has left, the sensor still listens at 9 600 Bd only.
        lms.receive(&status, 500_000, 50_000);
        assert_eq!(lms.baud(), 9_600);
        let runs = lms.poll_output_runs(500_000);
        assert_eq!(runs.len(), 1);
        assert_eq!(runs[0].baud, 9_600);
        assert_eq!(runs[0].bytes, hex("06 02 80 03 00 A0 00 10 16 0A"));
        assert_eq!(lms.baud(), 500_000);
        // At the old rate the host is not understood any more.
        let garbage = lms.counters().garbage_bytes;
        let runs = exchange(&mut lms, &status, 9_600, 600_000, 1_000_000);
        assert!(runs.is_empty());
        assert_eq!(lms.counters().garbage_bytes, garbage + 7);
        // At the new rate it is; the status reports 500 kBd.
        let runs = exchange(&mut lms, &status, 500_000, 1_000_000, 1_100_000);
        assert_eq!(runs.len(), 1);
        assert_eq!(runs[0].baud, 500_000);
        let telegram = Telegram::new_checked(&runs[0].bytes[1..]).unwrap();
        let Reply::Status(status) = Reply::parse(&telegram).unwrap() else {
            panic!()
        };
        assert_eq!(status.baud(), Some(LmsBaud::B500000));
        assert_eq!(lms.counters().requests, 2);
    }

    #[test]
    fn request_at_the_wrong_baud_is_ignored() {
        let mut lms = running(Lms2xxOptions::default());
        let runs = exchange(&mut lms, &hex("02 00 01 00 31 15 12"), 38_400, 0, 1_000_000);
        assert!(runs.is_empty());
        let c = lms.counters();
        assert_eq!((c.requests, c.garbage_bytes, c.acks, c.naks), (0, 7, 0, 0));
        // A request split by a pause over 6 ms is dropped too.
        lms.receive(&hex("02 00 01"), 9_600, 1_000_000);
        lms.receive(&hex("00 31 15 12"), 9_600, 1_007_000);
        assert!(lms.poll_output(2_000_000).is_empty());
        // Without the pause it is answered.
        lms.receive(&hex("02 00 01"), 9_600, 2_000_000);
        lms.receive(&hex("00 31 15 12"), 9_600, 2_001_000);
        assert_eq!(lms.poll_output(3_000_000)[0], ACK);
    }

    /// Streams at `baud` with `variant` for `duration_us` after the stream has started;
    /// returns the arrival times of the decoded scans and the sensor.
    fn stream(baud: u32, variant: Variant, duration_us: u64) -> (Vec<u64>, Vec<ScanRepr>, Lms2xx) {
        let mut lms = running(Lms2xxOptions {
            baud,
            variant,
            unit: RangeUnit::Mm,
            ..Lms2xxOptions::default()
        });
        lms.receive(&hex("02 00 02 00 20 24 34 08"), baud, 0);
        let mut receiver = Receiver::new();
        let (mut stamps, mut scans) = (Vec::new(), Vec::new());
        let mut now_us = 0;
        while now_us < 500_000 + duration_us {
            now_us += 1_000;
            for byte in lms.poll_output(now_us) {
                if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                    if telegram.command() == 0xB0 && now_us >= 500_000 {
                        stamps.push(now_us);
                        scans.push(ScanRepr::parse(&telegram).unwrap());
                    }
                }
            }
        }
        (stamps, scans, lms)
    }

    #[test]
    fn streams_every_scan_at_500k() {
        let (stamps, scans, lms) = stream(500_000, Variant::new(180, 50), 2_000_000);
        // 37.5 complete scans per second.
        assert!((74..=76).contains(&stamps.len()), "{}", stamps.len());
        assert_eq!(lms.counters().scans_skipped, 0);
        for pair in stamps.windows(2) {
            assert!((26_000..=28_000).contains(&(pair[1] - pair[0])), "{pair:?}");
        }
        assert!(
            scans
                .iter()
                .all(|s| s.values.len() == 361 && s.unit == RangeUnit::Mm)
        );
        // 75 Hz at 1°, 18.75 Hz at 100°/0.25°.
        let (stamps, _, _) = stream(500_000, Variant::new(180, 100), 2_000_000);
        assert!((149..=151).contains(&stamps.len()), "{}", stamps.len());
        let (stamps, scans, _) = stream(500_000, Variant::new(100, 25), 2_000_000);
        assert!((37..=38).contains(&stamps.len()), "{}", stamps.len());
        assert_eq!(scans[0].values.len(), 401);
    }

    #[test]
    fn skips_scans_at_38400() {
        let (stamps, _, lms) = stream(38_400, Variant::new(180, 50), 2_000_000);
        // 732 bytes take 191 ms: one scan in eight goes out (the line carries ≤ 5.2/s).
        assert!((9..=10).contains(&stamps.len()), "{}", stamps.len());
        for pair in stamps.windows(2) {
            assert!((pair[1] - pair[0]).abs_diff(213_333) < 1_500, "{pair:?}");
        }
        // Seven skipped scans between two sent ones, up to seven before the first and after
        // the last.
        let c = lms.counters();
        let between = 7 * (c.scans_sent - 1);
        assert!((between..=between + 14).contains(&c.scans_skipped), "{c:?}");
    }

    /// A moving sensor at 38 400 Bd whose stream is asked for at `request_us`, polled every
    /// `poll_us`: the scans' measurement times, every byte it sent, and its stream starts.
    fn slow_stream(request_us: u64, poll_us: u64) -> (Vec<u64>, Vec<u8>, Vec<StreamStart>) {
        let mut lms = running(Lms2xxOptions {
            baud: 38_400,
            variant: Variant::new(180, 50),
            ..Lms2xxOptions::default()
        });
        lms.set_motion(|t_us| SensorPose::new(t_us as f64 * 1e-6, 0.0, 0.0));
        lms.stop_scans_at(1_500_000);
        let mut now_us = 0;
        let mut bytes = Vec::new();
        let mut measured = Vec::new();
        while now_us < 2_000_000 {
            if (now_us..now_us + poll_us).contains(&request_us) {
                lms.receive(&hex("02 00 02 00 20 24 34 08"), 38_400, request_us);
            }
            now_us += poll_us;
            bytes.extend(lms.poll_output(now_us));
            measured.extend(lms.take_scans_started());
        }
        (measured, bytes, lms.stream_starts().to_vec())
    }

    #[test]
    fn slow_streams_keep_the_mirror_grid_whenever_they_are_asked_for() {
        // The sensor streams 105 ms after the request (ACK, mode switch, A0h); it sends every
        // eighth scan, those ending at multiples of 213.3 ms since it came up. Asked for
        // anywhere before the grid point at 213.3 ms less that, the stream begins there and
        // sends the same scans, measured at the same poses, however often it is polled.
        let (measured, bytes, starts) = slow_stream(0, 1_000);
        assert_eq!(
            measured,
            [
                213_333, 426_666, 640_000, 853_333, 1_066_666, 1_280_000, 1_493_333
            ]
        );
        assert_eq!(starts.len(), 1);
        assert_eq!(starts[0].first_scan_us, 213_333);
        assert!(
            (104_000..106_000).contains(&starts[0].streaming_us),
            "{starts:?}"
        );
        for (request_us, poll_us) in [(0, 7_000), (50_000, 1_000), (100_000, 3_000)] {
            let (m, b, _) = slow_stream(request_us, poll_us);
            assert_eq!(
                m, measured,
                "asked at {request_us} µs, polled every {poll_us} µs"
            );
            assert!(
                b == bytes,
                "asked at {request_us} µs, polled every {poll_us} µs"
            );
        }
        // Asked for too late for the first grid point: it starts at the next one.
        let (m, _, starts) = slow_stream(120_000, 1_000);
        assert_eq!(m, measured[1..]);
        assert_eq!(starts[0].first_scan_us, 426_666);
        // The scans were measured where the sensor was: different poses, different ranges.
        let scan_of = |k: usize| {
            let start = 10 + k * 732;
            ScanRepr::parse(&Telegram::new_checked(&bytes[start..start + 732]).unwrap()).unwrap()
        };
        assert_ne!(scan_of(0).values, scan_of(5).values);
    }

    #[test]
    fn power_cycle_sends_power_on_at_9600() {
        let mut lms = running(Lms2xxOptions {
            baud: 500_000,
            variant: Variant::new(180, 50),
            ..Lms2xxOptions::default()
        });
        lms.receive(&hex("02 00 02 00 20 24 34 08"), 500_000, 0);
        let _ = lms.poll_output(1_000_000);
        assert!(lms.is_streaming());
        lms.power_cycle(1_000_000);
        assert_eq!(lms.baud(), 9_600);
        assert!(!lms.is_streaming());
        // Silent while starting, then 90h at 9 600 Bd.
        let runs = lms.poll_output_runs(1_000_000 + 690_000);
        assert!(runs.is_empty());
        lms.receive(&hex("02 00 01 00 31 15 12"), 9_600, 1_500_000);
        let runs = lms.poll_output_runs(3_000_000);
        assert_eq!(runs.len(), 1);
        assert_eq!(runs[0].baud, 9_600);
        let telegram = Telegram::new_checked(&runs[0].bytes[..]).unwrap();
        assert_eq!(telegram.check_crc(), Ok(()));
        assert!(matches!(
            Reply::parse(&telegram),
            Ok(Reply::PowerOn {
                status: STATUS_OK,
                ..
            })
        ));
        assert_eq!(telegram.total_len(), runs[0].bytes.len());
        // Then it answers at 9 600 Bd, not streaming, in its power-on variant.
        let runs = exchange(
            &mut lms,
            &hex("02 00 01 00 31 15 12"),
            9_600,
            3_000_000,
            4_000_000,
        );
        let telegram = Telegram::new_checked(&runs[0].bytes[1..]).unwrap();
        let Reply::Status(status) = Reply::parse(&telegram).unwrap() else {
            panic!()
        };
        assert_eq!(status.baud(), Some(LmsBaud::B9600));
        assert!(!status.is_streaming());
        assert_eq!((status.angle_deg, status.resolution_cdeg), (180, 50));
    }

    #[test]
    fn a_request_interrupts_a_scan() {
        let mut lms = running(Lms2xxOptions::default());
        lms.receive(&hex("02 00 02 00 20 24 34 08"), 9_600, 0);
        // At 9 600 Bd a 181-value scan takes 387 ms; ask for the status in the middle.
        let before = lms.poll_output(400_000);
        lms.receive(&hex("02 00 01 00 31 15 12"), 9_600, 400_000);
        let after = lms.poll_output(404_000);
        assert_eq!(after, [ACK]);
        assert_eq!(lms.counters().scans_interrupted, 1);
        assert!(before.len() < 10 + 372);
    }

    #[test]
    fn same_seed_same_bytes() {
        let run = |seed| {
            let mut lms = Lms2xx::new(Lms2xxOptions {
                seed,
                ..Lms2xxOptions::default()
            });
            lms.receive(&hex("02 00 02 00 20 24 34 08"), 9_600, 800_000);
            lms.poll_output(3_000_000)
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
    }

    /// The board side of the bring-up test: the firmware's bring-up and receiver with a UART
    /// and a timer on a simulated clock.
    struct Board {
        bringup: BringUp,
        receiver: Receiver,
        uart_baud: u32,
        deadline_us: Option<u64>,
        /// (arrival time, scan) of every B0 while streaming.
        scans: Vec<(u64, ScanRepr)>,
    }

    impl Board {
        fn apply(&mut self, actions: firmware::sick::Actions, lms: &mut Lms2xx, now_us: u64) {
            for action in actions {
                match action {
                    Action::Send(request) => {
                        lms.receive(request.as_bytes(), self.uart_baud, now_us)
                    }
                    Action::SetBaud(baud) => {
                        self.uart_baud = baud;
                        self.receiver.clear();
                    }
                    Action::StartTimer { duration_ms } => {
                        self.deadline_us = Some(now_us + u64::from(duration_ms) * 1_000);
                    }
                    _ => {}
                }
            }
        }

        fn on_byte(&mut self, byte: Option<u8>, lms: &mut Lms2xx, now_us: u64) {
            let event = match byte {
                Some(byte) => self.receiver.push(byte, now_us),
                None => self.receiver.poll(now_us),
            };
            let Some(event) = event else {
                return;
            };
            if let Event::Telegram { telegram, .. } = &event {
                if telegram.command() == 0xB0 && self.bringup.state() == LaserState::Streaming {
                    self.scans
                        .push((now_us, ScanRepr::parse(telegram).unwrap()));
                }
            }
            let actions = self.bringup.handle(event.into());
            self.apply(actions, lms, now_us);
        }
    }

    #[test]
    fn firmware_bring_up_from_power_on_to_streaming() {
        let mut lms = Lms2xx::new(Lms2xxOptions {
            seed: 42,
            ..Lms2xxOptions::default()
        });
        let mut board = Board {
            bringup: BringUp::new(BringUpConfig::default()),
            receiver: Receiver::new(),
            uart_baud: 9_600,
            deadline_us: None,
            scans: Vec::new(),
        };
        let actions = board.bringup.handle(Input::Start);
        board.apply(actions, &mut lms, 0);
        let mut streaming_since_us = None;
        let mut now_us = 0;
        while now_us < 8_000_000 {
            now_us += 100;
            for run in lms.poll_output_runs(now_us) {
                for byte in garble(&run.bytes, run.baud, board.uart_baud) {
                    board.on_byte(Some(byte), &mut lms, now_us);
                }
            }
            board.on_byte(None, &mut lms, now_us);
            if board.deadline_us.is_some_and(|d| now_us >= d) {
                board.deadline_us = None;
                let actions = board.bringup.handle(Input::Timeout);
                board.apply(actions, &mut lms, now_us);
            }
            if streaming_since_us.is_none() && board.bringup.state() == LaserState::Streaming {
                streaming_since_us = Some(now_us);
            }
        }
        let since_us = streaming_since_us.expect("never streamed");
        assert!(since_us < 6_000_000, "{since_us}");
        assert_eq!(board.bringup.state(), LaserState::Streaming);
        assert_eq!((lms.baud(), board.uart_baud), (500_000, 500_000));
        assert_eq!(lms.variant(), Variant::new(180, 50));
        assert_eq!(lms.config().unit(), Some(RangeUnit::Mm));
        assert_eq!(lms.counters().eeprom_writes, 1);
        assert!(lms.counters().power_on_messages >= 1);
        // 37.5 scans per second since streaming started.
        let seconds = (now_us - since_us) as f64 / 1e6;
        let rate = board.scans.len() as f64 / seconds;
        assert!((rate - 37.5).abs() < 1.5, "{rate} scans/s");
        // Each scan: 361 values in mm matching the room within the noise.
        let setup = board.bringup.setup().unwrap();
        let decoder = RangeDecoder::new(setup.measuring_mode, setup.unit).unwrap();
        let model = lms.range_model();
        let variant = lms.variant();
        for (_, scan) in &board.scans {
            assert_eq!(scan.values.len(), 361);
            for (i, &word) in scan.values.iter().enumerate() {
                let expected = model.true_range_m(variant.beam_angle_cdeg(i as u16));
                let measured = decoder.range_mm(word);
                match (expected, measured) {
                    (Some(range_m), Some(range_mm)) => {
                        let error_mm = (f64::from(range_mm) - range_m * 1_000.0).abs();
                        assert!(error_mm <= 60.0, "beam {i}: {range_mm} mm vs {range_m} m");
                    }
                    (expected, measured) => panic!("beam {i}: {expected:?} vs {measured:?}"),
                }
            }
        }
    }

    /// A recorded scan of `count` beams at 1° from −90°, beam `i` at `1 + i / 100` m.
    fn recorded(timestamp_s: f64, count: usize) -> RecordedScan {
        RecordedScan {
            timestamp_s,
            first_beam_rad: -std::f64::consts::FRAC_PI_2,
            resolution_rad: 1f64.to_radians(),
            ranges_m: (0..count).map(|i| 1.0 + i as f64 / 100.0).collect(),
            no_return_from_m: None,
            telegram: None,
        }
    }

    #[test]
    fn recorded_words_map_beams_explicitly() {
        let mm = RangeUnit::Mm;
        let words = |scan: &RecordedScan, variant, mode, mapping| {
            recorded_words(scan, variant, mm, MeasuringMode(mode), 80.0, mapping)
        };
        // 180 beams into 180°/1°: value 180 has no beam.
        let scan = recorded(0.0, 180);
        let w = words(&scan, Variant::new(180, 100), 0, BeamMapping::Exact);
        assert_eq!((w.len(), w[0], w[179], w[180]), (181, 1_000, 2_790, 0x1FFF));
        let w = words(&scan, Variant::new(180, 100), 0, BeamMapping::Nearest);
        assert_eq!(w[180], 2_790);
        // Into 180°/0.5°: even values only; Nearest fills the odd ones counter-clockwise.
        let w = words(&scan, Variant::new(180, 50), 0, BeamMapping::Exact);
        assert_eq!((w[2], w[3], w[360]), (1_010, 0x1FFF, 0x1FFF));
        let w = words(&scan, Variant::new(180, 50), 0, BeamMapping::Nearest);
        assert_eq!((w[2], w[3], w[359], w[360]), (1_010, 1_020, 2_790, 2_790));
        // 100° at 1° takes beams 40–140.
        let w = words(&scan, Variant::new(100, 100), 0, BeamMapping::Exact);
        assert_eq!((w.len(), w[0], w[100]), (101, 1_400, 2_400));
        // 361 beams at 0.5° into 181 values: every other beam.
        let fine = RecordedScan {
            resolution_rad: 0.5f64.to_radians(),
            ranges_m: (0..361).map(|i| 1.0 + i as f64 / 1_000.0).collect(),
            ..recorded(0.0, 0)
        };
        let w = words(&fine, Variant::new(180, 100), 0, BeamMapping::Exact);
        assert_eq!((w[1], w[180]), (1_002, 1_360));
        // No return: the log's marker, beyond the sensor's maximum, negative, not a number;
        // too far for mode 0 in mm is "> maximum" (1FF7h), fine in mode 0Fh.
        let mut odd = recorded(0.0, 6);
        odd.ranges_m = vec![81.83, 80.5, -1.0, f64::NAN, 9.0, 0.0];
        odd.no_return_from_m = Some(81.83);
        let w = words(&odd, Variant::new(180, 100), 0, BeamMapping::Exact);
        assert_eq!(&w[..6], [0x1FFF, 0x1FFF, 0x1FFF, 0x1FFF, 0x1FF7, 0]);
        let w = words(&odd, Variant::new(180, 100), 0x0F, BeamMapping::Exact);
        assert_eq!(&w[..6], [0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF, 9_000, 0]);
        // An empty or degenerate scan is all no echo.
        let w = words(&recorded(0.0, 0), Variant::DEFAULT, 0, BeamMapping::Nearest);
        assert!(w.iter().all(|&v| v == 0x1FFF));
    }

    /// A sensor at 500 kBd in mm, streaming from time 0 (the `A0h` has left by 110 ms).
    fn streaming_replay(scans: Vec<RecordedScan>, pace: ReplayPace) -> Lms2xx {
        let mut lms = running(Lms2xxOptions {
            baud: 500_000,
            variant: Variant::new(180, 50),
            unit: RangeUnit::Mm,
            ..Lms2xxOptions::default()
        });
        lms.replay(scans.into_iter(), pace, BeamMapping::Exact);
        lms.receive(&hex("02 00 02 00 20 24 34 08"), 500_000, 0);
        lms
    }

    /// Arrival times and scans of every `B0h` until `until_us`, polled every 100 µs.
    fn collect_scans(lms: &mut Lms2xx, until_us: u64) -> Vec<(u64, ScanRepr)> {
        let mut receiver = Receiver::new();
        let mut out = Vec::new();
        let mut now_us = 0;
        while now_us < until_us {
            now_us += 100;
            for byte in lms.poll_output(now_us) {
                if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                    if telegram.command() == 0xB0 {
                        out.push((now_us, ScanRepr::parse(&telegram).unwrap()));
                    }
                }
            }
        }
        out
    }

    #[test]
    fn replay_as_fast_as_possible_then_silence() {
        let scans: Vec<_> = (0..4).map(|i| recorded(100.0 * i as f64, 180)).collect();
        let mut lms = streaming_replay(scans, ReplayPace::AsFastAsPossible);
        let got = collect_scans(&mut lms, 1_000_000);
        // One per scan end (26.7 ms at 0.5°) regardless of the log's 100 s spacing.
        assert_eq!(got.len(), 4);
        for pair in got.windows(2) {
            assert!(
                (26_000..=27_500).contains(&(pair[1].0 - pair[0].0)),
                "{}",
                pair[1].0
            );
        }
        assert_eq!(got[0].1.values[0], 1_000);
        assert_eq!(got[3].1.values[358], 2_790);
        assert_eq!(
            lms.replay_progress(),
            Some(ReplayProgress {
                scans_sent: 4,
                finished: true
            })
        );
        assert!(lms.is_streaming());
        assert_eq!(lms.next_output_us(), None);
        assert_eq!(lms.counters().scans_sent, 4);
        // A clone carries on from the same place; a requested scan repeats the last one.
        let mut clone = lms.clone();
        let runs = exchange(
            &mut clone,
            &hex("02 00 02 00 30 01 31 18"),
            500_000,
            1_000_000,
            1_100_000,
        );
        let bytes = bytes_of(&runs);
        let scan = ScanRepr::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap();
        assert_eq!(scan.values, got[3].1.values);
        // Without the replay the world is measured again.
        lms.stop_replay();
        assert_eq!(collect_scans(&mut lms, 1_100_000).len(), 3);
    }

    #[test]
    fn replay_at_the_recorded_pace() {
        // 0.1 s, 0.1 s, then two scans at the same time, then 0.5 s.
        let stamps = [50.0, 50.1, 50.2, 50.2, 50.7];
        let scans = stamps.iter().map(|&t| recorded(t, 180)).collect();
        let mut lms = streaming_replay(scans, ReplayPace::Recorded);
        let got = collect_scans(&mut lms, 2_000_000);
        assert_eq!(got.len(), 5);
        let first_us = got[0].0;
        let offsets: Vec<u64> = got.iter().map(|(t, _)| t - first_us).collect();
        // First scan end at or after each log-relative time; a second scan due at the same
        // time goes out one scan later.
        for (offset, expected) in offsets.iter().zip([0, 100_000, 200_000, 226_667, 700_000]) {
            assert!(
                (expected..expected + 26_667 + 100).contains(offset),
                "{offsets:?}"
            );
        }
        assert!(lms.replay_progress().unwrap().finished);
    }
}
