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
//! Slots are numbered from an anchor: the first byte of the last accepted telegram, or, before
//! the first one of a streaming session, the first byte after streaming started. A byte at
//! `t` lies in slot `⌊(t − anchor + (P − A)/2) / P⌋`, so slot boundaries fall in the middle of
//! the quiet gap between telegrams and stamp jitter below `(P − A)/2` changes nothing. Each
//! slot that receives bytes counts once; each slot holds one telegram at most, so the scans
//! missed are the slots with bytes less the telegrams accepted.
//!
//! After a silence of [`BREAK_US`] the stream is broken: a power-cycled sensor says hello at
//! another baud rate (`90h` at 9 600 Bd reads as noise at 500 kBd). Slots counted after a
//! break become certain only when another telegram is accepted; when the session ends first
//! ([`ScanSlots::end`], the stream watchdog), they are discarded. A telegram whose every byte
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
        let airtime_ns = bytes * BITS_PER_BYTE * 1_000_000_000 / u64::from(baud.max(1));
        // The sensor skips the scans that end while the line is still busy.
        let period_ns = scan_ns * airtime_ns.div_ceil(scan_ns).max(1);
        self.end();
        self.timing = Some(Timing {
            period_ns,
            airtime_ns,
        });
    }

    /// The session ends (streaming stopped, or the watchdog gave up on the stream). Slots
    /// counted after a break are discarded.
    pub fn end(&mut self) {
        self.active = self.active.wrapping_sub(self.after_break);
        self.timing = None;
        self.anchor_ns = None;
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

    /// A scan telegram whose first byte arrived at `first_byte_us` was accepted.
    ///
    /// Its bytes have already counted its slot, unless another accepted telegram took that
    /// slot (bytes read late in one burst with the next telegram's carry the same stamps):
    /// each telegram has a slot of its own, so it counts one then. Its start moves the grid
    /// along (the sensor's clock and the board's drift apart), unless the stamp lies far from
    /// the grid: a stamp interpolated by the receiver after a resynchronisation is not
    /// trusted for that.
    pub fn on_scan(&mut self, first_byte_us: u64) {
        let Some(timing) = self.timing else { return };
        if self.slot_taken {
            self.count_slot();
        }
        self.slot_taken = true;
        self.accepted = self.accepted.wrapping_add(1);
        self.after_break = 0;
        self.broken = false;
        let t_ns = first_byte_us.saturating_mul(1_000);
        let Some(anchor_ns) = self.anchor_ns else {
            self.anchor_ns = Some(t_ns);
            self.last_slot = 0;
            return;
        };
        let slot = timing.slot(anchor_ns, t_ns);
        let on_grid_ns = anchor_ns + slot * timing.period_ns;
        if t_ns.abs_diff(on_grid_ns) <= timing.lead_ns() / 2 {
            self.anchor_ns = Some(t_ns);
            self.last_slot = self.last_slot.saturating_sub(slot);
        }
    }

    /// Scans known to have been sent but not accepted, since boot (wraps at 2³²): slots that
    /// received bytes, less accepted telegrams. Includes slots counted after a break, which
    /// [`Self::end`] may still take back.
    pub fn missed(&self) -> u32 {
        self.active.wrapping_sub(self.accepted)
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
        slots.on_scan(start_us);
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
            slots.on_scan(late_us);
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
        // The sensor restarts: 0.7 s of silence, then its hello at the wrong rate.
        for i in 0..29 {
            slots.on_byte(700_000 + i * 1_042);
        }
        assert_eq!(slots.missed(), 2);
        slots.end();
        assert_eq!(slots.missed(), 0);
        // After a break, a resumed stream confirms what was counted.
        let mut slots = streaming();
        telegram(&mut slots, 0);
        bytes(&mut slots, 600_000, 0.5);
        telegram(&mut slots, 600_000 + PERIOD_US);
        slots.end();
        assert_eq!(slots.missed(), 1);
    }

    #[test]
    fn not_counting_outside_a_session() {
        let mut slots = ScanSlots::new();
        bytes(&mut slots, 0, 1.0);
        slots.on_scan(0);
        assert_eq!(slots.missed(), 0);
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
            slots.on_scan(start);
        }
        assert_eq!(slots.missed(), 0);
    }
}
