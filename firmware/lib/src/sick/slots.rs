//! Counting the scans a streaming LMS sent that did not arrive intact.
//!
//! While streaming, the sensor sends one `B0h` telegram per scan period `P` (13.3 ms at 1°,
//! 26.7 ms at 0.5°, 53.3 ms at 0.25°; every `m`-th period when a telegram takes longer than
//! `m − 1` periods on the line). A telegram occupies its *slot*: it starts at a multiple of
//! the period and lasts its air time `A < P`. So the receiver can count what it missed
//! without any help from the sensor:
//!
//! * **Between two accepted telegrams** the sensor sent one telegram per period: the scans
//!   missed are the whole periods between their starts, less one. This counts telegrams
//!   damaged on the way (bit errors, lost or cut bytes) and telegrams lost whole alike.
//! * **After the last accepted telegram** (and before the first one of a session) only the
//!   bytes tell: every slot in which bytes arrived held a telegram, which was not accepted.
//!   These slots count as missed until a telegram is accepted and its distance counts them
//!   exactly, or the session ends.
//!
//! Times come from the receiver's stamps. A byte's stamp is never earlier than its arrival,
//! but it can be later: bytes read in one burst well after they arrived (a reader that fell
//! behind, a whole telegram delivered at once) are stamped back from the read by one
//! character time each, which reaches back only over that read; the first byte of a 732-byte
//! telegram read in 256-byte reads is stamped up to two thirds of its air time late. A
//! telegram's start is therefore taken from its last byte, less the air time of the bytes
//! before it: the line is quiet after a telegram, so its last byte is read as it arrives.
//! (The first byte's stamp is no better when read on time, and after a resynchronisation the
//! receiver interpolates it, possibly too early.) Starts are placed on a grid of period `P`
//! at the nearest grid point: a start read up to `P/2` late lands in its own slot (107 ms at
//! 38 400 Bd, 13 ms at 500 kBd), one read later in a later slot. The grid is anchored at the
//! first accepted telegram's start and moves along with starts read at most `(P − A)/4` after
//! their grid point, following the sensor's clock, which drifts from the board's; a start
//! before its grid point shows the grid was anchored late, and moves it back. Its slots keep
//! their numbers.
//!
//! A start read more than `P/2` late looks like the next slot's read early, and moving the
//! grid back to it would shift every later slot by one. So a telegram moves the grid only
//! once the next one is accepted, which bounds its start: the sensor sent the next one at
//! least a period later, and it was not read early either. The grid follows the earlier of
//! the two bounds, the start read and the next one's less a period; it moves back by more
//! than `(P − A)/4` only on the next one's bound, since a run of telegrams read equally late
//! looks the same as a grid anchored late. (A run read more than `P/2` late and then on time
//! is counted right; a run that stays that late holds the count high while it lasts.)
//!
//! The scans missed among accepted telegrams are the slots they span less their number. As a
//! start is never read early, each one's slot is its true slot or a later one; so the
//! telegram `i` places at slot `s_i` began the grid's run no later than `s_i − i`, and the
//! least of those bounds is taken as its start. The last one's slot less the telegrams
//! before it, less that least bound, is the count: exact when the last telegram was read in
//! time, however many before it were read late (a reader that fell behind for a while, a
//! burst of several telegrams), and a telegram read late by whole periods is no exception.
//! While the last one was read late the count is high, until the next one is read in time.
//!
//! Bytes are placed in slots whose boundaries fall `(P − A)/2` before the grid points, in the
//! middle of the quiet gap between telegrams. Before the first accepted telegram of a session
//! the grid is anchored at the first byte heard, in slot 0, which bounds the run's start too:
//! the first accepted telegram's slot counts the ones before it, exactly while the two are
//! read late by amounts less than `P/2` apart.
//!
//! After a silence of [`BREAK_US`] the stream is broken: a power-cycled sensor says hello at
//! another baud rate (`90h` at 9 600 Bd reads as noise at 500 kBd). The grid is anchored anew
//! at the first byte after the break, and slots counted after it become certain only when
//! another telegram is accepted, counting as missed only then; when the session ends first
//! ([`ScanSlots::end`], the stream watchdog), they are discarded.
//!
//! The limits of this count: a telegram lost whole after the last accepted one (or before
//! the first) cannot be told from silence, and the last bytes of a damaged telegram there
//! read more than `(P − A)/2` late count the slot after it too.

/// A silence after which bytes are not taken for the stream's telegrams until one is
/// accepted, µs.
pub const BREAK_US: u64 = 500_000;

/// The LMS mirror turns at 75 Hz; one rotation, ns.
const ROTATION_NS: u64 = 1_000_000_000 / 75;

/// Bytes of a `B0h` telegram around its range words: STX, address, length (2), command,
/// value count (2), status, CRC (2).
const SCAN_FRAMING_BYTES: u64 = 10;

/// Bit times per byte on the line (8N1).
const BITS_PER_BYTE: u64 = 10;

/// The slot counter of one laser stream. See the [module documentation](self).
#[derive(Debug, Clone, Default)]
pub struct ScanSlots {
    /// The current session's timing, `None` when not streaming.
    timing: Option<Timing>,
    /// A time on the grid, ns: the first byte heard, then the first accepted telegram's
    /// start, then the starts the grid follows ([`Self::follow`]). `None` before the first
    /// byte of a session or after a break.
    anchor_ns: Option<u64>,
    /// The slot `anchor_ns` lies in; the grid's first byte lies in slot 0.
    anchor_slot: i64,
    /// Telegrams accepted on this grid.
    accepted: i64,
    /// The last accepted telegram's start as read, ns, which moves the grid once the next
    /// one bounds it.
    held_start_ns: Option<u64>,
    /// The slot of the last accepted telegram, less the telegrams accepted before it.
    lead_last: i64,
    /// The least of those over the grid's accepted telegrams, and 0 for its first byte.
    lead_min: i64,
    /// The highest slot with bytes.
    last_slot: i64,
    /// The last byte's stamp, ns.
    last_byte_ns: u64,
    /// Slots with bytes past the last accepted telegram's (or since the grid was anchored).
    pending: u32,
    /// Of those, heard after a break.
    after_break: u32,
    /// Whether a break happened since the last accepted telegram.
    broken: bool,
    /// Scans counted as missed on grids that ended, since boot.
    missed: u32,
}

/// A time or a duration in ns as a signed number (`u64` ns reach 584 years; half of that
/// fits).
fn signed(ns: u64) -> i64 {
    i64::try_from(ns).unwrap_or(i64::MAX)
}

#[derive(Debug, Clone, Copy)]
struct Timing {
    period_ns: u64,
    airtime_ns: u64,
    /// One character on the line, ns.
    char_ns: u64,
}

impl Timing {
    /// Where the slot boundary lies before a telegram's start, ns.
    fn lead_ns(&self) -> u64 {
        self.period_ns.saturating_sub(self.airtime_ns) / 2
    }

    /// Whole periods from `anchor_ns` to `t_ns` after shifting `t_ns` by `shift_ns`, rounded
    /// down; negative before the anchor.
    fn periods(&self, anchor_ns: u64, t_ns: u64, shift_ns: u64) -> i64 {
        let offset = signed(t_ns)
            .saturating_sub(signed(anchor_ns))
            .saturating_add(signed(shift_ns));
        offset.div_euclid(signed(self.period_ns).max(1))
    }

    /// The slot a byte at `t_ns` lies in, counted from the anchor's.
    fn slot(&self, anchor_ns: u64, t_ns: u64) -> i64 {
        self.periods(anchor_ns, t_ns, self.lead_ns())
    }

    /// The grid point nearest to `t_ns`, counted from the anchor.
    fn nearest(&self, anchor_ns: u64, t_ns: u64) -> i64 {
        self.periods(anchor_ns, t_ns, self.period_ns / 2)
    }
}

impl ScanSlots {
    /// A counter that is not counting (no stream).
    pub const fn new() -> ScanSlots {
        ScanSlots {
            timing: None,
            anchor_ns: None,
            anchor_slot: 0,
            accepted: 0,
            held_start_ns: None,
            lead_last: 0,
            lead_min: 0,
            last_slot: 0,
            last_byte_ns: 0,
            pending: 0,
            after_break: 0,
            broken: false,
            missed: 0,
        }
    }

    /// A streaming session starts: scans of `values_per_scan` range words, `step_angle_cdeg`
    /// apart (100 = 1°, 50 = 0.5°, 25 = 0.25°), at `baud`.
    pub fn start(&mut self, values_per_scan: u16, step_angle_cdeg: u16, baud: u32) {
        let rotations = match step_angle_cdeg {
            0..=25 => 4,
            26..=50 => 2,
            _ => 1,
        };
        let scan_ns = ROTATION_NS * rotations;
        let bytes = SCAN_FRAMING_BYTES + 2 * u64::from(values_per_scan);
        let char_ns = BITS_PER_BYTE * 1_000_000_000 / u64::from(baud.max(1));
        let airtime_ns = bytes * char_ns;
        // The sensor skips the scans that end while the line is still busy.
        let period_ns = scan_ns * airtime_ns.div_ceil(scan_ns).max(1);
        self.end();
        self.timing = Some(Timing {
            period_ns,
            airtime_ns,
            char_ns,
        });
    }

    /// The session ends (streaming stopped, or the watchdog gave up on the stream). Slots
    /// with bytes after the last accepted telegram count as missed, but those heard after a
    /// break, which are discarded.
    pub fn end(&mut self) {
        self.close_grid();
        self.timing = None;
        self.broken = false;
    }

    /// A byte arrived at `stamp_us`. Feed every byte, before the receiver sees it.
    pub fn on_byte(&mut self, stamp_us: u64) {
        let Some(timing) = self.timing else { return };
        let t_ns = stamp_us.saturating_mul(1_000);
        let silence_ns = t_ns.saturating_sub(self.last_byte_ns);
        self.last_byte_ns = t_ns;
        if self.anchor_ns.is_some() && silence_ns > BREAK_US * 1_000 {
            // What follows may be noise from a restarting sensor: counted apart, on a grid of
            // its own.
            self.close_grid();
            self.broken = true;
        }
        let Some(anchor_ns) = self.anchor_ns else {
            self.anchor_ns = Some(t_ns);
            self.count_slot();
            return;
        };
        let slot = self
            .anchor_slot
            .saturating_add(timing.slot(anchor_ns, t_ns));
        if slot > self.last_slot {
            self.last_slot = slot;
            self.count_slot();
        }
    }

    /// A scan telegram whose last byte arrived at `last_byte_us` was accepted. Call it once
    /// that byte has been fed to [`Self::on_byte`].
    ///
    /// Counts the scans missed on the grid from the slots its accepted telegrams span; see
    /// the [module documentation](self).
    pub fn on_scan(&mut self, last_byte_us: u64) {
        let Some(timing) = self.timing else { return };
        let start_ns = last_byte_us
            .saturating_mul(1_000)
            .saturating_sub(timing.airtime_ns.saturating_sub(timing.char_ns));
        // The bytes heard since the last accepted telegram are counted by the slots instead
        // (and are certain now, after a break too).
        self.pending = 0;
        self.after_break = 0;
        self.broken = false;
        if let Some(held_ns) = self.held_start_ns.take() {
            // The previous telegram began at least a period before this one, which was not
            // read early either.
            let next_bound_ns = start_ns.saturating_sub(timing.period_ns);
            self.follow(timing, held_ns.min(next_bound_ns), next_bound_ns < held_ns);
        }
        let anchor_ns = *self.anchor_ns.get_or_insert(start_ns);
        let nearest = timing.nearest(anchor_ns, start_ns);
        let slot = self.anchor_slot.saturating_add(nearest);
        self.lead_last = slot.saturating_sub(self.accepted);
        self.lead_min = self.lead_min.min(self.lead_last);
        self.accepted += 1;
        self.last_slot = self.last_slot.max(slot);
        // The grid's first telegram anchors it (a start is read better than a first byte).
        if self.accepted == 1 {
            self.anchor_ns = Some(start_ns);
            self.anchor_slot = slot;
        }
        self.held_start_ns = Some(start_ns);
    }

    /// Moves the grid to a telegram's start, `start_ns` (read, or bounded by the next
    /// telegram: `bounded`), when it lies at most `(P − A)/4` after its grid point, following
    /// the sensor's clock. A start before its grid point shows the grid was anchored late
    /// (starts are never read early) and moves it back: by up to `(P − A)/4` as read, by
    /// more only when the next telegram bounded it, as two telegrams read equally late look
    /// alike.
    fn follow(&mut self, timing: Timing, start_ns: u64, bounded: bool) {
        let Some(anchor_ns) = self.anchor_ns else {
            return;
        };
        let nearest = timing.nearest(anchor_ns, start_ns);
        let on_grid_ns =
            signed(anchor_ns).saturating_add(nearest.saturating_mul(signed(timing.period_ns)));
        let late_ns = signed(start_ns).saturating_sub(on_grid_ns);
        let tolerance_ns = signed(timing.lead_ns() / 2);
        if late_ns <= tolerance_ns && (bounded || late_ns >= -tolerance_ns) {
            self.anchor_ns = Some(start_ns);
            self.anchor_slot = self.anchor_slot.saturating_add(nearest);
        }
    }

    /// Scans known to have been sent but not accepted, since boot (wraps at 2³²): on the
    /// current grid, the slots its accepted telegrams span less those telegrams (which a
    /// telegram read on time after late ones corrects), plus the slots with bytes after the
    /// last one, but those heard after a break until a telegram accepted after them confirms
    /// them.
    pub fn missed(&self) -> u32 {
        self.missed
            .wrapping_add(self.grid_missed())
            .wrapping_add(self.pending.wrapping_sub(self.after_break))
    }

    /// Scans missed on the current grid by its accepted telegrams: the slots from the first
    /// byte's to the last accepted telegram's, less the telegrams. Each start is read on time
    /// or late, never early: the lowest slot less the telegrams before it bounds where the
    /// grid's telegrams began.
    fn grid_missed(&self) -> u32 {
        u32::try_from(self.lead_last.saturating_sub(self.lead_min)).unwrap_or(u32::MAX)
    }

    /// Counts what the current grid holds as missed (but the slots heard after a break) and
    /// forgets it: a break, or the session's end.
    fn close_grid(&mut self) {
        self.missed = self
            .missed
            .wrapping_add(self.grid_missed())
            .wrapping_add(self.pending.wrapping_sub(self.after_break));
        self.anchor_ns = None;
        self.anchor_slot = 0;
        self.accepted = 0;
        self.held_start_ns = None;
        self.lead_last = 0;
        self.lead_min = 0;
        self.last_slot = 0;
        self.pending = 0;
        self.after_break = 0;
    }

    fn count_slot(&mut self) {
        self.pending = self.pending.wrapping_add(1);
        if self.broken {
            self.after_break += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 0.5° scans of 361 values at 500 kBd: period 26 667 µs, 14 640 µs on the line.
    fn streaming() -> ScanSlots {
        let mut slots = ScanSlots::new();
        slots.start(361, 50, 500_000);
        slots
    }

    const PERIOD_US: u64 = 26_667;
    const AIRTIME_US: u64 = 14_640;
    /// 38 400 Bd: a 0.5° telegram takes 190.6 ms on the line, one goes out every 213.3 ms.
    const SLOW_PERIOD_US: u64 = 213_333;
    const SLOW_AIRTIME_US: u64 = 190_625;
    /// One character at 38 400 Bd and at 500 kBd, as the laser task rounds it, µs.
    const SLOW_CHAR_US: u64 = 260;
    const CHAR_US: u64 = 20;

    /// The bytes of a 500 kBd telegram starting at `start_us`, `fraction` of it arriving on
    /// time; returns the last one's stamp.
    fn bytes(slots: &mut ScanSlots, start_us: u64, fraction: f64) -> u64 {
        let n = (732.0 * fraction) as u64;
        let mut last_us = start_us;
        for i in 0..n {
            last_us = start_us + i * AIRTIME_US / 732;
            slots.on_byte(last_us);
        }
        last_us
    }

    /// An intact 500 kBd telegram starting at `start_us`, on time.
    fn telegram(slots: &mut ScanSlots, start_us: u64) {
        let last_us = bytes(slots, start_us, 1.0);
        slots.on_scan(last_us);
    }

    /// Feeds the first `count` of the 732 bytes of a telegram, read in one burst at
    /// `read_us`, 256 bytes per read and stamped as the laser task stamps them: back from the
    /// read by one character time per byte, never before the previous stamp. Returns the
    /// last one's stamp, `read_us`.
    fn read_in_one_burst(slots: &mut ScanSlots, read_us: u64, count: u64, char_us: u64) -> u64 {
        let mut last_us = 0;
        let mut left = count;
        while left > 0 {
            let chunk = left.min(256);
            for i in 0..chunk {
                last_us = (read_us - (chunk - 1 - i) * char_us).max(last_us);
                slots.on_byte(last_us);
            }
            left -= chunk;
        }
        last_us
    }

    /// Feeds a 38 400 Bd telegram starting at `start_us` whose last `late` bytes are read
    /// `late_us` late, all at once; returns the last one's stamp.
    fn held_up_telegram(slots: &mut ScanSlots, start_us: u64, late: u64, late_us: u64) -> u64 {
        let mut last_us = 0;
        for i in 0..732 {
            let on_time_us = start_us + (i + 1) * SLOW_AIRTIME_US / 732;
            let late_read_us = start_us + SLOW_AIRTIME_US + late_us;
            last_us = if i + late >= 732 {
                late_read_us - (731 - i) * SLOW_CHAR_US
            } else {
                on_time_us
            }
            .max(last_us);
            slots.on_byte(last_us);
        }
        last_us
    }

    #[test]
    fn an_intact_stream_misses_nothing() {
        let mut slots = streaming();
        for k in 0..100 {
            telegram(&mut slots, 5_000 + k * PERIOD_US);
        }
        assert_eq!(slots.missed(), 0);
    }

    #[test]
    fn damaged_telegrams_are_counted_once_each() {
        let mut slots = streaming();
        telegram(&mut slots, 5_000);
        // Two damaged (one cut short, one with its start lost), then an intact one.
        bytes(&mut slots, 5_000 + PERIOD_US, 0.3);
        for i in 100..732 {
            slots.on_byte(5_000 + 2 * PERIOD_US + i * AIRTIME_US / 732);
        }
        assert_eq!(slots.missed(), 2);
        telegram(&mut slots, 5_000 + 3 * PERIOD_US);
        assert_eq!(slots.missed(), 2);
        // A damaged first telegram of a session counts too.
        let mut slots = streaming();
        bytes(&mut slots, 1_000, 0.9);
        telegram(&mut slots, 1_000 + PERIOD_US);
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn telegrams_lost_whole_between_accepted_ones_count() {
        let mut slots = streaming();
        telegram(&mut slots, 0);
        // Nothing of the next two arrives.
        telegram(&mut slots, 3 * PERIOD_US);
        assert_eq!(slots.missed(), 2);
    }

    #[test]
    fn a_damaged_last_telegram_counts_while_the_stream_lasts() {
        let mut slots = streaming();
        telegram(&mut slots, 0);
        bytes(&mut slots, PERIOD_US, 0.5);
        assert_eq!(slots.missed(), 1);
        slots.end();
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn noise_after_a_break_is_dropped_when_the_session_ends() {
        let mut slots = streaming();
        telegram(&mut slots, 0);
        // The sensor restarts: 0.7 s of silence, then its hello at the wrong rate: two
        // slots with bytes, not counted while uncertain.
        for i in 0..29 {
            slots.on_byte(700_000 + i * 1_042);
        }
        assert_eq!(slots.missed(), 0);
        slots.end();
        assert_eq!(slots.missed(), 0);
        // After a break, a resumed stream confirms what was counted.
        let mut slots = streaming();
        telegram(&mut slots, 0);
        bytes(&mut slots, 600_000, 0.5);
        assert_eq!(slots.missed(), 0);
        telegram(&mut slots, 600_000 + PERIOD_US);
        assert_eq!(slots.missed(), 1);
        slots.end();
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn not_counting_outside_a_session() {
        let mut slots = ScanSlots::new();
        bytes(&mut slots, 0, 0.5);
        let last_us = bytes(&mut slots, PERIOD_US, 1.0);
        slots.on_scan(last_us);
        assert_eq!(slots.missed(), 0);
    }

    #[test]
    fn telegrams_read_in_one_burst_keep_a_slot_each() {
        let mut slots = streaming();
        telegram(&mut slots, 5_000);
        // The next two are read together 10 ms after the second's end, with one stamp.
        let late_us = 5_000 + 2 * PERIOD_US + AIRTIME_US + 10_000;
        for _ in 0..2 {
            for _ in 0..732 {
                slots.on_byte(late_us);
            }
            slots.on_scan(late_us);
        }
        telegram(&mut slots, 5_000 + 3 * PERIOD_US);
        assert_eq!(slots.missed(), 0);
    }

    #[test]
    fn a_telegram_cut_after_one_read_in_a_burst_is_counted() {
        // The first byte of a telegram read in one burst is stamped 124 ms late; the bytes
        // of the next one, which a power cycle cuts off after 20 ms and which are read as
        // they come, must not fall into its slot.
        let mut slots = ScanSlots::new();
        slots.start(361, 50, 38_400);
        for k in 0..3 {
            let read_us = k * SLOW_PERIOD_US + SLOW_AIRTIME_US;
            let last_us = read_in_one_burst(&mut slots, read_us, 732, SLOW_CHAR_US);
            slots.on_scan(last_us);
        }
        let cut_us = 3 * SLOW_PERIOD_US;
        for i in 1..=76 {
            slots.on_byte(cut_us + i * SLOW_CHAR_US);
        }
        assert_eq!(slots.missed(), 1);
        // 0.7 s later the restarting sensor's hello, at another rate: noise, then the
        // watchdog ends the session.
        for i in 0..29 {
            slots.on_byte(cut_us + 720_000 + i * 1_042);
        }
        slots.end();
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn telegrams_read_in_bursts_are_counted_once_each() {
        // Intact and damaged telegrams alike, every one read in one burst at its end, its
        // first byte up to two thirds of its air time late. At 500 kBd the first of the
        // session is damaged: its late first byte is the first byte heard. (At 38 400 Bd it
        // is 124 ms late, more than half a period from the accepted one's start: the limit.)
        for (baud, period_us, airtime_us, char_us, first_damaged) in [
            (38_400, SLOW_PERIOD_US, SLOW_AIRTIME_US, SLOW_CHAR_US, 1),
            (500_000, PERIOD_US, AIRTIME_US, CHAR_US, 0),
        ] {
            let mut slots = ScanSlots::new();
            slots.start(361, 50, baud);
            for k in 0..12 {
                let last_us =
                    read_in_one_burst(&mut slots, k * period_us + airtime_us, 732, char_us);
                if k % 3 != first_damaged {
                    slots.on_scan(last_us);
                }
            }
            assert_eq!(slots.missed(), 4, "{baud} Bd");
            // Cut off by a power cycle after one byte: a scan all the same.
            slots.on_byte(12 * period_us + char_us);
            assert_eq!(slots.missed(), 5, "{baud} Bd");
        }
    }

    #[test]
    fn a_cut_telegram_read_in_a_burst_keeps_its_own_slot() {
        // 500 kBd, every telegram read in one burst at its end; a power cycle cuts one off
        // after 4 ms (the first 200 bytes), read in one burst too.
        let mut slots = streaming();
        for k in 0..4 {
            let last_us = read_in_one_burst(&mut slots, k * PERIOD_US + AIRTIME_US, 732, CHAR_US);
            slots.on_scan(last_us);
        }
        read_in_one_burst(&mut slots, 4 * PERIOD_US + 4_000, 200, CHAR_US);
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn slow_lines_send_every_mth_scan() {
        // At 38 400 Bd a 0.5° telegram takes 191 ms: one scan in eight is sent.
        let mut slots = ScanSlots::new();
        slots.start(361, 50, 38_400);
        for k in 0..20 {
            let start = k * SLOW_PERIOD_US;
            for i in 0..732 {
                slots.on_byte(start + (i + 1) * SLOW_AIRTIME_US / 732);
            }
            slots.on_scan(start + SLOW_AIRTIME_US);
        }
        assert_eq!(slots.missed(), 0);
    }

    #[test]
    fn late_last_bytes_do_not_count_the_next_slot() {
        // The reader is held up 20 ms (more than the 11 ms between a telegram's end and the
        // next slot) before the last 30 bytes of every telegram, accepted or damaged.
        let mut slots = ScanSlots::new();
        slots.start(361, 50, 38_400);
        for k in 0..12 {
            let last_us = held_up_telegram(&mut slots, k * SLOW_PERIOD_US, 30, 20_000);
            if k % 4 != 2 {
                slots.on_scan(last_us);
            }
        }
        assert_eq!(slots.missed(), 3);
        // The limit: a damaged last telegram's late bytes count the slot after it too.
        let mut slots = ScanSlots::new();
        slots.start(361, 50, 38_400);
        for k in 0..2 {
            let last_us = held_up_telegram(&mut slots, k * SLOW_PERIOD_US, 0, 0);
            slots.on_scan(last_us);
        }
        held_up_telegram(&mut slots, 2 * SLOW_PERIOD_US, 30, 20_000);
        assert_eq!(slots.missed(), 2);
    }

    #[test]
    fn a_telegram_read_more_than_half_a_period_late_is_placed_by_the_next() {
        // 38 400 Bd; the second telegram is read in one burst 150 ms after its end, so it
        // looks nearer the third slot than its own; the third, on time, corrects that.
        let mut slots = ScanSlots::new();
        slots.start(361, 50, 38_400);
        let last_us = held_up_telegram(&mut slots, 0, 0, 0);
        slots.on_scan(last_us);
        let read_us = SLOW_PERIOD_US + SLOW_AIRTIME_US + 150_000;
        let last_us = read_in_one_burst(&mut slots, read_us, 732, SLOW_CHAR_US);
        slots.on_scan(last_us);
        let last_us = held_up_telegram(&mut slots, 2 * SLOW_PERIOD_US, 0, 0);
        slots.on_scan(last_us);
        assert_eq!(slots.missed(), 0);
        // A damaged one later is still counted.
        held_up_telegram(&mut slots, 3 * SLOW_PERIOD_US, 0, 0);
        let last_us = held_up_telegram(&mut slots, 4 * SLOW_PERIOD_US, 0, 0);
        slots.on_scan(last_us);
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn a_run_of_telegrams_read_late_is_counted_by_the_next_on_time() {
        // 500 kBd; the reader falls 20 ms behind (more than half a period) for a run of
        // telegrams, each read in one burst 20 ms after its end, which puts each start nearer
        // the next slot than its own; the one after the run is read on time. In the second
        // run one telegram is damaged.
        let mut slots = streaming();
        telegram(&mut slots, 0);
        for (first, damaged) in [(1, None), (5, Some(7))] {
            for k in first..first + 3 {
                let read_us = k * PERIOD_US + AIRTIME_US + 20_000;
                let last_us = read_in_one_burst(&mut slots, read_us, 732, CHAR_US);
                if Some(k) != damaged {
                    slots.on_scan(last_us);
                }
            }
            telegram(&mut slots, (first + 3) * PERIOD_US);
        }
        assert_eq!(slots.missed(), 1);
        slots.end();
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn a_telegram_read_just_over_half_a_period_late_does_not_shift_the_grid() {
        // 500 kBd on a loaded host: every start read 0–5 ms late, and now and then one read
        // in one burst 14–16 ms after its end, which puts it nearer the next slot's grid
        // point, before it. Taking that for a grid anchored late would move every later slot
        // by one and count a scan missed for good.
        let mut slots = streaming();
        let lag_us = |k: u64| (k * 7_919) % 5_000;
        for k in 0..200 {
            let start_us = 5_000 + k * PERIOD_US;
            if k % 17 == 9 {
                let read_us = start_us + AIRTIME_US + 14_000 + (k % 3) * 1_000;
                let last_us = read_in_one_burst(&mut slots, read_us, 732, CHAR_US);
                slots.on_scan(last_us);
            } else {
                telegram(&mut slots, start_us + lag_us(k));
            }
        }
        assert_eq!(slots.missed(), 0);
        // Two in a row read that late, then a steady lag of 1.5 ms.
        for k in 200..203 {
            let start_us = 5_000 + k * PERIOD_US;
            let last_us =
                read_in_one_burst(&mut slots, start_us + AIRTIME_US + 14_000, 732, CHAR_US);
            slots.on_scan(last_us);
        }
        for k in 203..230 {
            telegram(&mut slots, 5_000 + k * PERIOD_US + 1_500);
        }
        assert_eq!(slots.missed(), 0);
        // One lost whole after them still counts, once.
        for k in 231..260 {
            telegram(&mut slots, 5_000 + k * PERIOD_US + lag_us(k));
        }
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn two_telegrams_read_just_over_half_a_period_late_do_not_shift_the_grid() {
        // 500 kBd: on time, then two telegrams each read 14 ms after its end, then every one
        // read 1.5 ms late. The second of the two bounds the first no better than it was
        // read: the grid must not move back to it.
        let mut slots = streaming();
        for k in 0..9 {
            telegram(&mut slots, k * PERIOD_US);
        }
        for k in 9..11 {
            let read_us = k * PERIOD_US + AIRTIME_US + 14_000;
            let last_us = read_in_one_burst(&mut slots, read_us, 732, CHAR_US);
            slots.on_scan(last_us);
        }
        for k in 11..40 {
            telegram(&mut slots, k * PERIOD_US + 1_500);
        }
        assert_eq!(slots.missed(), 0);
    }

    #[test]
    fn telegrams_read_whole_periods_late_are_placed_by_the_next_on_time() {
        // 500 kBd; the reader stalls for two periods: three telegrams are read in one burst
        // 1 ms after the third's end, the first of them two periods late, which puts its
        // start on the grid. The next one is read on time.
        let mut slots = streaming();
        telegram(&mut slots, 5_000);
        let read_us = 5_000 + 3 * PERIOD_US + AIRTIME_US + 1_000;
        for _ in 1..=3 {
            let last_us = read_in_one_burst(&mut slots, read_us, 732, CHAR_US);
            slots.on_scan(last_us);
        }
        telegram(&mut slots, 5_000 + 4 * PERIOD_US);
        assert_eq!(slots.missed(), 0);
        // One lost whole after them still counts.
        telegram(&mut slots, 5_000 + 6 * PERIOD_US);
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn a_first_telegram_read_late_does_not_hold_the_grid_late() {
        // 500 kBd; the first telegram is read in one burst 10 ms after its end, which anchors
        // the grid 10 ms late; the next ones are read on time and move it back. Then one is
        // cut off after 4 ms: its bytes must fall into its own slot.
        let mut slots = streaming();
        let last_us = read_in_one_burst(&mut slots, AIRTIME_US + 10_000, 732, CHAR_US);
        slots.on_scan(last_us);
        for k in 1..=4 {
            telegram(&mut slots, k * PERIOD_US);
        }
        for i in 0..200 {
            slots.on_byte(5 * PERIOD_US + i * CHAR_US);
        }
        assert_eq!(slots.missed(), 1);
        // And the grid follows a sensor whose clock runs 110 ppm fast: one telegram lost
        // whole among 3 000 is counted, once.
        let mut slots = streaming();
        let fast_period_us = PERIOD_US - 3;
        let last_us = read_in_one_burst(&mut slots, AIRTIME_US + 10_000, 732, CHAR_US);
        slots.on_scan(last_us);
        for k in (1..3_000).filter(|&k| k != 1_500) {
            telegram(&mut slots, k * fast_period_us);
        }
        assert_eq!(slots.missed(), 1);
    }
}
