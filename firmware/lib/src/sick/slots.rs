//! Counting the scans a streaming LMS sent that did not arrive intact.
//!
//! While streaming, the sensor sends one `B0h` telegram per scan period `P` (13.3 ms at 1°,
//! 26.7 ms at 0.5°, 53.3 ms at 0.25°; every `m`-th period when a telegram takes longer than
//! `m − 1` periods on the line). A telegram occupies its *slot*: it starts at a multiple of
//! the period and lasts its air time `A < P`. A telegram damaged on the way (bit errors,
//! lost or cut bytes) is not accepted, but its remaining bytes still arrive in its slot. So
//! the receiver can count what it missed without any help from the sensor: every slot in
//! which bytes arrived but no telegram was accepted held a lost scan.
//!
//! Slots are numbered from an anchor: the start of the last accepted telegram, or, before the
//! first one of a streaming session (or after a break), the first byte heard. A byte at `t`
//! lies in slot `⌊(t − anchor + (P − A)/2) / P⌋`, so slot boundaries fall in the middle of the
//! quiet gap between telegrams and stamp jitter below `(P − A)/2` changes nothing. Each slot
//! that receives bytes counts once; each slot holds one telegram at most, so the scans missed
//! are the slots with bytes less the telegrams accepted.
//!
//! A byte's stamp is never earlier than its arrival, but it can be later: bytes read in one
//! burst well after they arrived (a reader that fell behind, a whole telegram delivered at
//! once) are stamped back from the read by one character time each, which reaches back only
//! over that read. The first byte of a 732-byte telegram read in 256-byte reads is then
//! stamped up to two thirds of its air time late, while the bytes of the next telegram, read
//! as they come, are stamped on time. An anchor at that late first byte would put the next
//! telegram's first bytes into the accepted one's slot (at 38 400 Bd, the first 110 ms of
//! it: exactly what a power cycle leaves of a telegram it cuts off). So the anchor is taken
//! from the telegram's last byte, less the air time of the bytes before it: the line is quiet
//! after a telegram, so its last byte is read as it arrives. (The first byte's stamp is no
//! better when read on time, and after a resynchronisation the receiver interpolates it,
//! possibly too early.)
//!
//! After a silence of [`BREAK_US`] the stream is broken: a power-cycled sensor says hello at
//! another baud rate (`90h` at 9 600 Bd reads as noise at 500 kBd). Slots counted after a
//! break become certain only when another telegram is accepted, and count as missed only then;
//! when the session ends first ([`ScanSlots::end`], the stream watchdog), they are discarded.
//! So [`ScanSlots::missed`] never goes down, also when it is read while a restarting sensor
//! is still being heard. A telegram whose every byte
//! was lost, and a damaged last telegram before a break that never resumes, cannot be told
//! from silence; they are the limits of this count.

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
    /// Slot 0 of the grid: the first byte of a telegram, ns.
    anchor_ns: Option<u64>,
    /// Whether an accepted telegram set the anchor (else the first byte heard did).
    anchor_confirmed: bool,
    /// The highest slot with bytes since the anchor.
    last_slot: u64,
    /// The last byte's stamp, ns.
    last_byte_ns: u64,
    /// Slots with bytes since the last break, while the stream is broken.
    after_break: u32,
    /// Whether a break happened since the last accepted telegram.
    broken: bool,
    /// Whether a telegram was accepted in the last slot counted.
    slot_taken: bool,
    /// Slots that received bytes, since boot.
    active: u32,
    /// Telegrams accepted while counting, since boot.
    accepted: u32,
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

    /// The slot of `t_ns` on the grid anchored at `anchor_ns`.
    fn slot(&self, anchor_ns: u64, t_ns: u64) -> u64 {
        (t_ns.saturating_sub(anchor_ns) + self.lead_ns()) / self.period_ns
    }
}

impl ScanSlots {
    /// A counter that is not counting (no stream).
    pub const fn new() -> ScanSlots {
        ScanSlots {
            timing: None,
            anchor_ns: None,
            anchor_confirmed: false,
            last_slot: 0,
            last_byte_ns: 0,
            after_break: 0,
            broken: false,
            slot_taken: false,
            active: 0,
            accepted: 0,
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
    /// counted after a break are discarded.
    pub fn end(&mut self) {
        self.active = self.active.wrapping_sub(self.after_break);
        self.timing = None;
        self.anchor_ns = None;
        self.anchor_confirmed = false;
        self.last_slot = 0;
        self.after_break = 0;
        self.broken = false;
        self.slot_taken = false;
    }

    /// A byte arrived at `stamp_us`. Feed every byte, before the receiver sees it.
    pub fn on_byte(&mut self, stamp_us: u64) {
        let Some(timing) = self.timing else { return };
        let t_ns = stamp_us.saturating_mul(1_000);
        let silence_ns = t_ns.saturating_sub(self.last_byte_ns);
        self.last_byte_ns = t_ns;
        if self.anchor_ns.is_some() && silence_ns > BREAK_US * 1_000 {
            // What follows may be noise from a restarting sensor: counted apart.
            self.broken = true;
            self.anchor_ns = None;
            self.anchor_confirmed = false;
        }
        let Some(anchor_ns) = self.anchor_ns else {
            self.anchor_ns = Some(t_ns);
            self.last_slot = 0;
            self.count_slot();
            return;
        };
        let slot = timing.slot(anchor_ns, t_ns);
        if slot > self.last_slot {
            self.last_slot = slot;
            self.count_slot();
        }
    }

    /// A scan telegram was accepted. Call it once its last byte has been fed to
    /// [`Self::on_byte`].
    ///
    /// Its bytes have already counted its slot, unless another accepted telegram took that
    /// slot (bytes read late in one burst with the next telegram's carry the same stamps):
    /// each telegram has a slot of its own, so it counts one then. Its start (see the
    /// [module documentation](self)) becomes the anchor: the grid follows the sensor's clock,
    /// which drifts from the board's. Once an accepted telegram has set the anchor, a start
    /// far from the grid does not move it: the last byte heard may be a later one than the
    /// telegram's own when the receiver found the telegram by re-examining its buffer.
    pub fn on_scan(&mut self) {
        let Some(timing) = self.timing else { return };
        if self.slot_taken {
            self.count_slot();
        }
        self.slot_taken = true;
        self.accepted = self.accepted.wrapping_add(1);
        self.after_break = 0;
        self.broken = false;
        let start_ns = self
            .last_byte_ns
            .saturating_sub(timing.airtime_ns.saturating_sub(timing.char_ns));
        let Some(anchor_ns) = self.anchor_ns else {
            self.anchor_ns = Some(start_ns);
            self.anchor_confirmed = true;
            self.last_slot = 0;
            return;
        };
        // The slot the telegram's bytes were counted in, which becomes slot 0.
        let slot = if self.anchor_confirmed {
            let slot = timing.slot(anchor_ns, start_ns);
            let on_grid_ns = anchor_ns + slot * timing.period_ns;
            if start_ns.abs_diff(on_grid_ns) > timing.lead_ns() / 2 {
                return;
            }
            slot
        } else {
            // The anchor is the first byte heard, stamped on time or late, at the start of a
            // telegram or inside it (streaming began mid-telegram): that telegram started
            // within an air time before it, and the accepted one a whole number of periods
            // after that.
            start_ns
                .saturating_sub(anchor_ns + timing.lead_ns())
                .div_ceil(timing.period_ns)
        };
        self.anchor_ns = Some(start_ns);
        self.anchor_confirmed = true;
        self.last_slot = self.last_slot.saturating_sub(slot);
    }

    /// Scans known to have been sent but not accepted, since boot (wraps at 2³²): slots that
    /// received bytes, less accepted telegrams. Slots counted after a break count only once a
    /// telegram accepted after them has confirmed them.
    pub fn missed(&self) -> u32 {
        self.active
            .wrapping_sub(self.after_break)
            .wrapping_sub(self.accepted)
    }

    fn count_slot(&mut self) {
        self.slot_taken = false;
        self.active = self.active.wrapping_add(1);
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

    /// The bytes of a telegram starting at `start_us`, `fraction` of it arriving.
    fn bytes(slots: &mut ScanSlots, start_us: u64, fraction: f64) {
        let n = (732.0 * fraction) as u64;
        for i in 0..n {
            slots.on_byte(start_us + i * AIRTIME_US / 732);
        }
    }

    fn telegram(slots: &mut ScanSlots, start_us: u64) {
        bytes(slots, start_us, 1.0);
        slots.on_scan();
    }

    #[test]
    fn telegrams_read_in_one_burst_keep_a_slot_each() {
        let mut slots = streaming();
        telegram(&mut slots, 5_000);
        // The next two telegrams are read late, together, with one stamp.
        let late_us = 5_000 + 3 * PERIOD_US;
        for _ in 0..2 {
            for _ in 0..732 {
                slots.on_byte(late_us);
            }
            slots.on_scan();
        }
        telegram(&mut slots, 5_000 + 4 * PERIOD_US);
        assert_eq!(slots.missed(), 0);
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
        telegram(&mut slots, 5_000 + 3 * PERIOD_US);
        assert_eq!(slots.missed(), 2);
        // A damaged first telegram of a session counts too.
        let mut slots = streaming();
        bytes(&mut slots, 1_000, 0.9);
        telegram(&mut slots, 1_000 + PERIOD_US);
        assert_eq!(slots.missed(), 1);
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
        bytes(&mut slots, 0, 1.0);
        slots.on_scan();
        assert_eq!(slots.missed(), 0);
    }

    /// 38 400 Bd: a 0.5° telegram takes 190.6 ms on the line, one goes out every 213.3 ms.
    const SLOW_PERIOD_US: u64 = 213_333;
    const SLOW_AIRTIME_US: u64 = 190_625;
    /// One character at 38 400 Bd and at 500 kBd, as the laser task rounds it, µs.
    const SLOW_CHAR_US: u64 = 260;
    const CHAR_US: u64 = 20;

    /// Feeds the first `count` of the 732 bytes of a telegram whose transmission ended at
    /// `end_us`, read in one burst then, 256 bytes per read and stamped as the laser task
    /// stamps them: back from the read by one character time per byte, never before the
    /// previous stamp.
    fn read_in_one_burst(slots: &mut ScanSlots, end_us: u64, count: u64, char_us: u64) {
        let mut last_us = 0;
        let mut left = count;
        while left > 0 {
            let chunk = left.min(256);
            for i in 0..chunk {
                let stamp_us = (end_us - (chunk - 1 - i) * char_us).max(last_us);
                last_us = stamp_us;
                slots.on_byte(stamp_us);
            }
            left -= chunk;
        }
    }

    #[test]
    fn a_telegram_cut_after_one_read_in_a_burst_is_counted() {
        // The first byte of a telegram read in one burst is stamped 124 ms late; the bytes
        // of the next one, which a power cycle cuts off after 20 ms and which are read as
        // they come, must not fall into its slot.
        let mut slots = ScanSlots::new();
        slots.start(361, 50, 38_400);
        for k in 0..3 {
            read_in_one_burst(
                &mut slots,
                k * SLOW_PERIOD_US + SLOW_AIRTIME_US,
                732,
                SLOW_CHAR_US,
            );
            slots.on_scan();
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
        // Intact and damaged telegrams alike, every one read late in one burst, the first
        // of the session damaged: its late stamp is the first anchor.
        for (baud, period_us, airtime_us, char_us) in [
            (38_400, SLOW_PERIOD_US, SLOW_AIRTIME_US, SLOW_CHAR_US),
            (500_000, PERIOD_US, AIRTIME_US, CHAR_US),
        ] {
            let mut slots = ScanSlots::new();
            slots.start(361, 50, baud);
            for k in 0..12 {
                read_in_one_burst(&mut slots, k * period_us + airtime_us, 732, char_us);
                if k % 3 != 0 {
                    slots.on_scan();
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
            read_in_one_burst(&mut slots, k * PERIOD_US + AIRTIME_US, 732, CHAR_US);
            slots.on_scan();
        }
        read_in_one_burst(&mut slots, 4 * PERIOD_US + 4_000, 200, CHAR_US);
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn slow_lines_send_every_mth_scan() {
        // At 38 400 Bd a 0.5° telegram takes 191 ms: one scan in eight is sent.
        let mut slots = ScanSlots::new();
        slots.start(361, 50, 38_400);
        let period_us = 8 * PERIOD_US;
        for k in 0..20 {
            let start = k * period_us;
            for i in 0..732 {
                slots.on_byte(start + i * 190_625 / 732);
            }
            slots.on_scan();
        }
        assert_eq!(slots.missed(), 0);
    }
}
