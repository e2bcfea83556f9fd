//! The byte-level receiver for the LMS2xx → host direction (protocol notes §2, §4, §5, §10).
//!
//! [`Receiver::push`] takes one byte and its arrival time and returns at most one [`Event`]:
//! a validated [`Telegram`] (borrowed from the receiver's 814-byte buffer, stamped with the
//! arrival time of its first byte), or an unframed ACK (`06h`) / NAK (`15h`) byte seen
//! between telegrams.
//!
//! A candidate telegram starts at STX and is checked step by step: the address must have bit
//! 7 set (`80h..=FFh`), the length field must lie in `2..=808`, the bytes must not pause for
//! longer than the inter-byte timeout (default 35 ms, above the sensor's 14 ms limit), and
//! the checksum over `L + 4` bytes must match. After any failure the receiver drops only the
//! false STX and re-examines every byte it had buffered after it, so that a corrupted or
//! truncated telegram never swallows the good one that follows (the failure sicktoolbox has
//! when it drops the whole candidate). ACK and NAK bytes are recognised wherever the receiver
//! is between telegrams, including in re-examined bytes: a host request interrupts a scan in
//! flight, and the sensor's ACK then follows the fragment.
//!
//! Cost: bytes inside a telegram body are only stored; the checksum is computed once, when
//! the last byte arrives. Re-examination happens only after an error. No allocation.
//!
//! Time stamps: an event carries the arrival time of its first byte, and a telegram also that
//! of its last byte. For body bytes the
//! receiver does not record times as they arrive; should such a byte later start a telegram
//! found by re-examination, its time is interpolated between the exact times around it
//! (exact when the bytes came at a constant rate, as they do within a sensor transmission).
//! Arrival times are kept modulo 2³² µs (71 min), which bounds the pauses it can measure.
//!
//! Accounting: every byte pushed is, in the end, part of exactly one accepted telegram, an
//! ACK, a NAK or garbage; bytes still being examined are [`Receiver::pending_bytes`]. So
//! `bytes == telegram_bytes + acks + naks + garbage_bytes + pending_bytes()` at all times.
//!
//! When a byte unlocks more than one event (a re-examination can uncover several), the
//! following ones are returned by the next calls; [`Receiver::poll`] returns them without a
//! new byte, and also applies the inter-byte timeout when the line goes quiet.

use super::crc::crc16;
use super::telegram::{ACK, MAX_LEN_FIELD, MAX_TELEGRAM_LEN, NAK, OVERHEAD_LEN, STX, Telegram};

/// The default inter-byte timeout: sicktoolbox's 35 ms.
pub const DEFAULT_INTER_BYTE_TIMEOUT_US: u64 = 35_000;
/// The longest pause the LMS makes inside a telegram; the timeout must exceed it.
pub const MAX_SENSOR_GAP_US: u64 = 14_000;
/// The smallest length field of a reply: code and status.
const MIN_REPLY_LEN_FIELD: u16 = 2;
/// Buffer capacity: the largest telegram.
const CAPACITY: usize = MAX_TELEGRAM_LEN;

/// What the receiver recognised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event<'a> {
    /// A telegram whose address, length and checksum are valid.
    Telegram {
        /// The telegram, borrowed from the receiver until its next call.
        telegram: Telegram<&'a [u8]>,
        /// Arrival time of the telegram's first byte (STX), µs.
        stamp_us: u64,
        /// Arrival time of the telegram's last byte, µs.
        end_us: u64,
    },
    /// The unframed acknowledge byte `06h`.
    Ack {
        /// Arrival time, µs.
        stamp_us: u64,
    },
    /// The unframed not-acknowledge byte `15h`.
    Nak {
        /// Arrival time, µs.
        stamp_us: u64,
    },
}

/// Counters kept by the [`Receiver`]. All wrap at 2³².
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReceiverStats {
    /// Bytes pushed.
    pub bytes: u32,
    /// Telegrams accepted.
    pub telegrams_ok: u32,
    /// Bytes of accepted telegrams.
    pub telegram_bytes: u32,
    /// Candidates dropped because the checksum did not match.
    pub crc_errors: u32,
    /// Candidates dropped because the length field was outside `2..=808`.
    pub bad_length: u32,
    /// Candidates dropped because the address lacked bit 7 (not a reply).
    pub bad_address: u32,
    /// Candidates dropped because the line paused longer than the inter-byte timeout.
    pub timeouts: u32,
    /// Candidates dropped for any reason, each followed by a search from the byte after its
    /// STX.
    pub resyncs: u32,
    /// ACK bytes between telegrams.
    pub acks: u32,
    /// NAK bytes between telegrams.
    pub naks: u32,
    /// Bytes that belong to no telegram: noise between telegrams and the STX of every
    /// dropped candidate.
    pub garbage_bytes: u32,
}

/// Why a candidate was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Drop {
    Crc,
    Length,
    Address,
    Timeout,
}

/// What [`Receiver::advance`] found, by position in the buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Found {
    Telegram { start: usize, len: usize },
    Ack(usize),
    Nak(usize),
}

/// The LMS → host byte receiver. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct Receiver {
    /// Bytes not yet consumed: `buf[start..end]`.
    buf: [u8; CAPACITY],
    /// Low 32 bits of each byte's arrival time, µs.
    stamps: [u32; CAPACITY],
    /// First byte not yet classified; the candidate's STX while `in_candidate`.
    start: usize,
    /// Next byte to examine.
    scan: usize,
    /// One past the last stored byte.
    end: usize,
    /// Whether `buf[start]` is the STX of a candidate under examination.
    in_candidate: bool,
    /// Total length of the candidate once its length field is known, else 0.
    total: usize,
    /// When nonzero: the candidate's body is being received with nothing else pending, and
    /// it is complete when `end` reaches this index (at most `CAPACITY`). Lets
    /// [`Self::push`] just store bytes, without their stamps and without counting them.
    fast_end: usize,
    /// Index of the first byte stored by the fast path in the current run.
    fast_from: usize,
    /// Bytes `unstamped.0 .. unstamped.1` were stored by the fast path without their arrival
    /// times; they are interpolated before anyone needs them.
    unstamped: (usize, usize),
    /// Arrival time of the last byte pushed, µs.
    last_us: u64,
    /// Set by [`Self::poll`] when the line has been quiet longer than the timeout: a
    /// candidate still incomplete at the end of the buffer is dropped.
    quiet: bool,
    timeout_us: u64,
    stats: ReceiverStats,
}

impl Default for Receiver {
    fn default() -> Self {
        Self::new()
    }
}

impl Receiver {
    /// A receiver with the default 35 ms inter-byte timeout.
    pub const fn new() -> Receiver {
        Self::with_timeout_us(DEFAULT_INTER_BYTE_TIMEOUT_US)
    }

    /// A receiver that drops a partial telegram after a pause longer than `timeout_us`
    /// between two of its bytes. Values at or below the sensor's 14 ms
    /// ([`MAX_SENSOR_GAP_US`]) would drop good telegrams and are raised to just above it.
    pub const fn with_timeout_us(timeout_us: u64) -> Receiver {
        let timeout_us = if timeout_us > MAX_SENSOR_GAP_US {
            timeout_us
        } else {
            MAX_SENSOR_GAP_US + 1
        };
        Receiver {
            buf: [0; CAPACITY],
            stamps: [0; CAPACITY],
            start: 0,
            scan: 0,
            end: 0,
            in_candidate: false,
            total: 0,
            fast_end: 0,
            fast_from: 0,
            unstamped: (0, 0),
            last_us: 0,
            quiet: false,
            timeout_us,
            stats: ReceiverStats {
                bytes: 0,
                telegrams_ok: 0,
                telegram_bytes: 0,
                crc_errors: 0,
                bad_length: 0,
                bad_address: 0,
                timeouts: 0,
                resyncs: 0,
                acks: 0,
                naks: 0,
                garbage_bytes: 0,
            },
        }
    }

    /// The counters.
    pub fn stats(&self) -> ReceiverStats {
        let mut stats = self.stats;
        if self.fast_end != 0 {
            stats.bytes = stats.bytes.wrapping_add((self.end - self.fast_from) as u32);
        }
        stats
    }

    /// The inter-byte timeout in µs.
    pub fn timeout_us(&self) -> u64 {
        self.timeout_us
    }

    /// Bytes pushed but not yet classified (a partial telegram, or bytes still to be
    /// re-examined after an error).
    pub fn pending_bytes(&self) -> usize {
        self.end - self.start
    }

    /// Drops every buffered byte (counted as garbage), e.g. after the UART changed its baud
    /// rate.
    pub fn clear(&mut self) {
        self.end_fast_run();
        self.unstamped = (0, 0);
        self.stats.garbage_bytes = self
            .stats
            .garbage_bytes
            .wrapping_add(self.pending_bytes() as u32);
        self.start = 0;
        self.scan = 0;
        self.end = 0;
        self.in_candidate = false;
        self.total = 0;
        self.fast_end = 0;
    }

    /// Takes the next byte from the sensor, received at `now_us` (any monotonic µs clock).
    ///
    /// Returns the event this byte completes, or one left over from an earlier byte.
    ///
    /// Time stamps must not go backwards; one that does (an estimate from a chunked read, for
    /// instance) is taken as the previous one.
    #[inline]
    pub fn push(&mut self, byte: u8, now_us: u64) -> Option<Event<'_>> {
        let i = self.end;
        // Fast path: inside a telegram body, nothing else pending, no pause. A stamp that
        // steps back makes the difference wrap and takes the slow path, which handles it.
        if i < self.fast_end && now_us.wrapping_sub(self.last_us) <= self.timeout_us {
            // `i < fast_end <= CAPACITY`, so the slot exists.
            if let Some(slot) = self.buf.get_mut(i) {
                *slot = byte;
            }
            self.end = i + 1;
            self.last_us = now_us;
            if i + 1 < self.fast_end {
                return None;
            }
            self.scan = i + 1;
        } else {
            self.store(byte, now_us);
        }
        let found = self.advance()?;
        Some(self.event(found))
    }

    /// Returns an event still pending from earlier bytes, after applying the inter-byte
    /// timeout at `now_us`: if the line has been quiet for longer than the timeout, a partial
    /// telegram is dropped and the bytes after its STX are re-examined.
    ///
    /// Call it when the UART has been idle for a while, and after an event until it returns
    /// `None`, to drain events without waiting for the next byte.
    pub fn poll(&mut self, now_us: u64) -> Option<Event<'_>> {
        let now_us = now_us.max(self.last_us);
        if self.end > self.start && now_us.wrapping_sub(self.last_us) > self.timeout_us {
            self.quiet = true;
        } else if self.fast_end != 0 {
            // Inside a body with nothing else pending: nothing to do.
            return None;
        }
        let found = self.advance()?;
        Some(self.event(found))
    }

    /// Appends a byte outside the fast path, making room first.
    #[cold]
    fn store(&mut self, byte: u8, now_us: u64) {
        let now_us = now_us.max(self.last_us);
        self.quiet = false;
        self.stats.bytes = self.stats.bytes.wrapping_add(1);
        if self.fast_end != 0 {
            // A pause inside a body, or the buffer end: the slow path takes over and needs
            // every byte examined and stamped.
            self.scan = self.end;
            self.end_fast_run();
        }
        self.fill_stamps();
        if self.start == self.end {
            self.start = 0;
            self.scan = 0;
            self.end = 0;
        } else if self.end == CAPACITY {
            self.compact();
        }
        // After `compact`, `end - start` < CAPACITY: an unfinished region never holds more
        // than a partial telegram plus the byte that completes it (see `advance`).
        if let (Some(slot), Some(stamp)) =
            (self.buf.get_mut(self.end), self.stamps.get_mut(self.end))
        {
            *slot = byte;
            *stamp = now_us as u32;
            self.end += 1;
        } else {
            self.stats.garbage_bytes = self.stats.garbage_bytes.wrapping_add(1);
        }
        self.last_us = now_us;
    }

    /// Ends a run of the fast path: counts its bytes and remembers they lack stamps.
    fn end_fast_run(&mut self) {
        if self.fast_end != 0 {
            self.stats.bytes = self
                .stats
                .bytes
                .wrapping_add((self.end - self.fast_from) as u32);
            self.unstamped = (self.fast_from, self.end);
            self.fast_end = 0;
        }
    }

    /// Gives the bytes stored by the fast path arrival times interpolated between the byte
    /// before them and the last byte (whose times are exact). Every interpolated pause is at
    /// most the longest real one, so no inter-byte timeout appears or disappears.
    #[cold]
    fn fill_stamps(&mut self) {
        let (from, to) = self.unstamped;
        self.unstamped = (0, 0);
        if from >= to || from == 0 || to != self.end {
            return;
        }
        let first = self.stamps[from - 1];
        let span = u64::from((self.last_us as u32).wrapping_sub(first));
        let count = (to - from) as u64;
        for (k, stamp) in self.stamps[from..to].iter_mut().enumerate() {
            *stamp = first.wrapping_add((span * (k as u64 + 1) / count) as u32);
        }
    }

    /// Moves the unconsumed bytes to the front of the buffer.
    fn compact(&mut self) {
        let start = self.start;
        self.buf.copy_within(start..self.end, 0);
        self.stamps.copy_within(start..self.end, 0);
        self.end -= start;
        self.scan -= start;
        if self.fast_end != 0 {
            self.fast_end -= start;
        }
        self.start = 0;
    }

    /// Examines buffered bytes until one event is found or every byte has been examined.
    fn advance(&mut self) -> Option<Found> {
        self.end_fast_run();
        loop {
            if self.in_candidate && self.total != 0 && self.scan == self.start + self.total {
                if let Some(found) = self.finish() {
                    return Some(found);
                }
                continue;
            }
            if self.scan >= self.end {
                if self.in_candidate && self.quiet {
                    self.drop_candidate(Drop::Timeout);
                    continue;
                }
                if self.in_candidate && self.total != 0 {
                    // Body bytes up to the end of the buffer need no examination until the
                    // last one arrives.
                    let fast_end = (self.start + self.total).min(CAPACITY);
                    if fast_end > self.end {
                        self.fast_end = fast_end;
                        self.fast_from = self.end;
                    }
                }
                return None;
            }
            let i = self.scan;
            let byte = self.buf[i];
            if !self.in_candidate {
                self.scan = i + 1;
                match byte {
                    STX => {
                        self.in_candidate = true;
                        self.total = 0;
                    }
                    ACK => {
                        self.start = i + 1;
                        self.stats.acks = self.stats.acks.wrapping_add(1);
                        return Some(Found::Ack(i));
                    }
                    NAK => {
                        self.start = i + 1;
                        self.stats.naks = self.stats.naks.wrapping_add(1);
                        return Some(Found::Nak(i));
                    }
                    _ => {
                        self.start = i + 1;
                        self.stats.garbage_bytes = self.stats.garbage_bytes.wrapping_add(1);
                    }
                }
                continue;
            }
            // Inside a candidate: `start < i`.
            let gap = self.stamps[i].wrapping_sub(self.stamps[i - 1]);
            if u64::from(gap) > self.timeout_us {
                self.drop_candidate(Drop::Timeout);
                continue;
            }
            match i - self.start {
                1 if byte & 0x80 == 0 => {
                    self.drop_candidate(Drop::Address);
                    continue;
                }
                1 | 2 => self.scan = i + 1,
                3 => {
                    let len_field = u16::from_le_bytes([self.buf[i - 1], byte]);
                    if !(MIN_REPLY_LEN_FIELD..=MAX_LEN_FIELD).contains(&len_field) {
                        self.drop_candidate(Drop::Length);
                        continue;
                    }
                    self.total = usize::from(len_field) + OVERHEAD_LEN;
                    self.scan = i + 1;
                }
                _ => {
                    let stop = (self.start + self.total).min(self.end);
                    let mut at = i + 1;
                    while at < stop {
                        if u64::from(self.stamps[at].wrapping_sub(self.stamps[at - 1]))
                            > self.timeout_us
                        {
                            break;
                        }
                        at += 1;
                    }
                    // A pause before `stop` is checked (and the candidate dropped) on the
                    // next turn.
                    self.scan = at;
                }
            }
        }
    }

    /// Checks the checksum of the complete candidate `buf[start..start + total]`.
    fn finish(&mut self) -> Option<Found> {
        let start = self.start;
        let total = self.total;
        let crc_at = start + total - 2;
        let (covered, crc) = self.buf[start..start + total].split_at(total - 2);
        let transmitted = u16::from_le_bytes([crc[0], crc[1]]);
        if crc16(covered) != transmitted {
            self.drop_candidate(Drop::Crc);
            return None;
        }
        debug_assert_eq!(crc_at + 2, self.scan);
        self.unstamped = (0, 0);
        self.in_candidate = false;
        self.total = 0;
        self.start = start + total;
        self.stats.telegrams_ok = self.stats.telegrams_ok.wrapping_add(1);
        self.stats.telegram_bytes = self.stats.telegram_bytes.wrapping_add(total as u32);
        Some(Found::Telegram { start, len: total })
    }

    /// Drops the candidate: its STX becomes garbage and the search resumes at the next byte.
    #[cold]
    fn drop_candidate(&mut self, why: Drop) {
        self.fill_stamps();
        let counter = match why {
            Drop::Crc => &mut self.stats.crc_errors,
            Drop::Length => &mut self.stats.bad_length,
            Drop::Address => &mut self.stats.bad_address,
            Drop::Timeout => &mut self.stats.timeouts,
        };
        *counter = counter.wrapping_add(1);
        self.stats.resyncs = self.stats.resyncs.wrapping_add(1);
        self.stats.garbage_bytes = self.stats.garbage_bytes.wrapping_add(1);
        self.in_candidate = false;
        self.total = 0;
        self.fast_end = 0;
        self.start += 1;
        self.scan = self.start;
    }

    /// The full arrival time of the byte at `index` (which is at or before the last byte).
    fn stamp_us(&self, index: usize) -> u64 {
        let last = self.last_us as u32;
        self.last_us
            .wrapping_sub(u64::from(last.wrapping_sub(self.stamps[index])))
    }

    fn event(&self, found: Found) -> Event<'_> {
        match found {
            Found::Telegram { start, len } => Event::Telegram {
                telegram: Telegram::new_unchecked(&self.buf[start..start + len]),
                stamp_us: self.stamp_us(start),
                // The last byte pushed has no stamp stored when the fast path took it.
                end_us: if start + len == self.end {
                    self.last_us
                } else {
                    self.stamp_us(start + len - 1)
                },
            },
            Found::Ack(at) => Event::Ack {
                stamp_us: self.stamp_us(at),
            },
            Found::Nak(at) => Event::Nak {
                stamp_us: self.stamp_us(at),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_stepping_back_is_not_a_pause() {
        // Chunked reads give estimated stamps that may step back a little between chunks.
        let telegram = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
        let mut rx = Receiver::new();
        let stamps = [
            1_000u64, 1_020, 1_040, 1_010, 1_030, 1_050, 1_060, 1_045, 1_065,
        ];
        let mut got = 0;
        for (&b, &t) in telegram.iter().zip(&stamps) {
            if let Some(Event::Telegram { stamp_us, .. }) = rx.push(b, t) {
                assert_eq!(stamp_us, 1_000);
                got += 1;
            }
        }
        assert_eq!(got, 1);
        assert_eq!(rx.stats().timeouts, 0);
    }

    #[test]
    fn a_telegram_carries_the_stamps_of_its_first_and_last_bytes() {
        let telegram = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
        // Received as sent: the last byte is the one that completes it.
        let mut rx = Receiver::new();
        let mut ends = Vec::new();
        for (i, &b) in telegram.iter().enumerate() {
            if let Some(Event::Telegram {
                stamp_us, end_us, ..
            }) = rx.push(b, 1_000 + 10 * i as u64)
            {
                ends.push((stamp_us, end_us));
            }
        }
        assert_eq!(ends, [(1_000, 1_080)]);
        // Behind a false start whose length swallows it: found when the false candidate
        // fails, after more bytes came; its last byte is still its own.
        let mut rx = Receiver::new();
        let mut stream = vec![0x02, 0x80, 0x0A, 0x00];
        stream.extend_from_slice(&telegram);
        stream.extend_from_slice(&[0x00; 3]);
        let mut ends = Vec::new();
        for (i, &b) in stream.iter().enumerate() {
            if let Some(Event::Telegram {
                stamp_us, end_us, ..
            }) = rx.push(b, 2_000 + 10 * i as u64)
            {
                ends.push((stamp_us, end_us));
            }
        }
        while let Some(event) = rx.poll(2_000 + 10 * stream.len() as u64) {
            if let Event::Telegram {
                stamp_us, end_us, ..
            } = event
            {
                ends.push((stamp_us, end_us));
            }
        }
        assert_eq!(ends, [(2_040, 2_120)]);
    }
    use crate::sick::test_data::{hex, real_b0};
    use proptest::prelude::*;

    /// What a test keeps of an event.
    #[derive(Debug, Clone, PartialEq, Eq)]
    enum Seen {
        Telegram(Vec<u8>, u64),
        Ack(u64),
        Nak(u64),
    }

    fn own(event: Event<'_>) -> Seen {
        match event {
            Event::Telegram {
                telegram, stamp_us, ..
            } => Seen::Telegram(telegram.as_bytes().to_vec(), stamp_us),
            Event::Ack { stamp_us } => Seen::Ack(stamp_us),
            Event::Nak { stamp_us } => Seen::Nak(stamp_us),
        }
    }

    /// Pushes `bytes` one every `byte_us` from `t0_us`, then drains with `poll` after a long
    /// pause.
    fn run(receiver: &mut Receiver, bytes: &[u8], t0_us: u64, byte_us: u64) -> Vec<Seen> {
        let mut seen = Vec::new();
        let mut now = t0_us;
        for &byte in bytes {
            if let Some(event) = receiver.push(byte, now) {
                seen.push(own(event));
            }
            now += byte_us;
        }
        now += 1_000_000;
        while let Some(event) = receiver.poll(now) {
            seen.push(own(event));
        }
        seen
    }

    fn telegrams(seen: &[Seen]) -> Vec<Vec<u8>> {
        seen.iter()
            .filter_map(|s| match s {
                Seen::Telegram(bytes, _) => Some(bytes.clone()),
                _ => None,
            })
            .collect()
    }

    fn assert_accounted(receiver: &Receiver) {
        let s = receiver.stats();
        assert_eq!(
            s.bytes as usize,
            s.telegram_bytes as usize
                + s.acks as usize
                + s.naks as usize
                + s.garbage_bytes as usize
                + receiver.pending_bytes(),
            "{s:?}"
        );
    }

    const A0: &str = "02 80 03 00 A0 00 10 16 0A";
    const B0: &str = "02 80 0A 00 B0 03 40 E8 03 D0 07 FF 1F 10 16 B1";

    #[test]
    fn ack_then_reply() {
        let mut receiver = Receiver::new();
        let bytes = hex(&format!("06 {A0}"));
        let seen = run(&mut receiver, &bytes, 1000, 100);
        assert_eq!(seen, vec![Seen::Ack(1000), Seen::Telegram(hex(A0), 1100)]);
        let s = receiver.stats();
        assert_eq!(
            (s.telegrams_ok, s.acks, s.garbage_bytes, s.resyncs),
            (1, 1, 0, 0)
        );
        assert_accounted(&receiver);
    }

    #[test]
    fn nak_and_garbage() {
        let mut receiver = Receiver::new();
        let bytes = hex(&format!("FF 15 33 {B0} 00"));
        let seen = run(&mut receiver, &bytes, 0, 10);
        assert_eq!(seen, vec![Seen::Nak(10), Seen::Telegram(hex(B0), 30)]);
        assert_eq!(receiver.stats().garbage_bytes, 3);
        assert_accounted(&receiver);
    }

    #[test]
    fn ack_inside_telegram_is_data() {
        // A0 with result 06h, then B0 whose values contain 02 80 and 15h.
        let mut a0 = hex("02 80 03 00 A0 06 10 00 00");
        let mut view = Telegram::new_unchecked(&mut a0[..]);
        view.fill_crc();
        let mut receiver = Receiver::new();
        let seen = run(&mut receiver, &a0, 0, 10);
        assert_eq!(telegrams(&seen), vec![a0]);
        assert_eq!(receiver.stats().acks, 0);
    }

    #[test]
    fn corrupted_telegram_does_not_swallow_the_next() {
        // A B0 whose length announces 726 bytes but which is cut after 9 bytes, directly
        // followed by a good reply: the reply lies inside the false candidate.
        let mut bytes = hex("02 80 D6 02 B0 69 41 FD 3F");
        bytes.extend(hex(&format!("06 {A0}")));
        bytes.extend(std::iter::repeat_n(0x33, 800));
        let mut receiver = Receiver::new();
        let seen = run(&mut receiver, &bytes, 0, 20);
        assert_eq!(telegrams(&seen), vec![hex(A0)]);
        assert!(seen.contains(&Seen::Ack(9 * 20)));
        assert_eq!(seen.last(), Some(&Seen::Telegram(hex(A0), 10 * 20)));
        let s = receiver.stats();
        assert_eq!(s.crc_errors, 1);
        assert_accounted(&receiver);
    }

    #[test]
    fn bad_crc_resyncs_on_next_byte() {
        let mut bad = hex(B0);
        bad[8] ^= 0x40;
        let mut bytes = bad.clone();
        bytes.extend(hex(B0));
        let mut receiver = Receiver::new();
        let seen = run(&mut receiver, &bytes, 0, 10);
        assert_eq!(telegrams(&seen), vec![hex(B0)]);
        assert_eq!(receiver.stats().crc_errors, 1);
        assert_eq!(receiver.stats().garbage_bytes, bad.len() as u32);
        assert_accounted(&receiver);
    }

    #[test]
    fn bad_address_and_length() {
        let mut receiver = Receiver::new();
        // 02 00: request address; 02 80 01 00: length 1; 02 80 FF 7F: length too big.
        let bytes = hex(&format!("02 00 02 80 01 00 02 80 FF 7F {A0}"));
        let seen = run(&mut receiver, &bytes, 0, 10);
        assert_eq!(telegrams(&seen), vec![hex(A0)]);
        let s = receiver.stats();
        assert_eq!((s.bad_address, s.bad_length), (1, 2));
        assert_accounted(&receiver);
    }

    #[test]
    fn stx_address_pair_found_after_false_stx() {
        // `02 02 80 …`: the first STX fails on its address, which is the real STX.
        let mut receiver = Receiver::new();
        let bytes = hex(&format!("02 {A0}"));
        let seen = run(&mut receiver, &bytes, 0, 10);
        assert_eq!(seen, vec![Seen::Telegram(hex(A0), 10)]);
    }

    #[test]
    fn inter_byte_timeout_drops_partial() {
        let mut receiver = Receiver::new();
        let b0 = hex(B0);
        let mut seen = Vec::new();
        for (i, &byte) in b0[..8].iter().enumerate() {
            assert!(receiver.push(byte, i as u64 * 100).is_none());
        }
        // 40 ms pause, then a full telegram.
        for (i, &byte) in b0.iter().enumerate() {
            if let Some(event) = receiver.push(byte, 40_000 + i as u64 * 100) {
                seen.push(own(event));
            }
        }
        assert_eq!(seen, vec![Seen::Telegram(b0, 40_000)]);
        assert_eq!(receiver.stats().timeouts, 1);
        assert_accounted(&receiver);
    }

    #[test]
    fn pause_below_timeout_is_fine() {
        let mut receiver = Receiver::new();
        let b0 = hex(B0);
        let mut seen = Vec::new();
        for (i, &byte) in b0.iter().enumerate() {
            let now = i as u64 * 14_000;
            if let Some(event) = receiver.push(byte, now) {
                seen.push(own(event));
            }
        }
        assert_eq!(seen, vec![Seen::Telegram(b0, 0)]);
    }

    #[test]
    fn poll_releases_reply_inside_fragment() {
        // Fragment (length 726) that contains a complete reply, then silence.
        let mut bytes = hex("02 80 D6 02 B0 69 41");
        bytes.extend(hex(A0));
        let mut receiver = Receiver::new();
        for (i, &byte) in bytes.iter().enumerate() {
            assert!(receiver.push(byte, i as u64 * 20).is_none());
        }
        assert!(receiver.poll(1_000).is_none());
        let event = receiver.poll(100_000).map(own);
        assert_eq!(event, Some(Seen::Telegram(hex(A0), 7 * 20)));
        assert!(receiver.poll(100_000).is_none());
        assert_eq!(receiver.stats().timeouts, 1);
        assert_eq!(receiver.pending_bytes(), 0);
        assert_accounted(&receiver);
    }

    #[test]
    fn largest_telegram_and_overflowing_length() {
        let mut big = vec![0u8; MAX_TELEGRAM_LEN];
        let mut view = Telegram::new_unchecked(&mut big[..]);
        view.set_header(0x80, 0xB0, usize::from(MAX_LEN_FIELD) - 1);
        view.fill_crc();
        let mut receiver = Receiver::new();
        let mut bytes = big.clone();
        bytes.extend(big.clone());
        let seen = run(&mut receiver, &bytes, 0, 2);
        assert_eq!(telegrams(&seen), vec![big.clone(), big]);
        assert_accounted(&receiver);
    }

    /// A telegram of `len` bytes with data `fill`.
    fn filled(len: usize, fill: u8) -> Vec<u8> {
        let mut bytes = vec![fill; len];
        let mut view = Telegram::new_unchecked(&mut bytes[..]);
        view.set_header(0x80, 0xB0, len - 7);
        view.fill_crc();
        bytes
    }

    #[test]
    fn good_telegram_deep_inside_a_cut_one_is_moved_and_found() {
        // 700 bytes of an 800-byte telegram, then a whole 600-byte one: it starts at buffer
        // index 700 and runs past the buffer end.
        let cut = filled(800, 0x11);
        let good = filled(600, 0x22);
        let mut bytes = cut[..700].to_vec();
        bytes.extend(&good);
        let mut receiver = Receiver::new();
        let seen = run(&mut receiver, &bytes, 0, 20);
        assert_eq!(seen, vec![Seen::Telegram(good, 700 * 20)]);
        let s = receiver.stats();
        assert_eq!((s.crc_errors, s.resyncs, s.garbage_bytes), (1, 1, 700));
        assert_accounted(&receiver);
    }

    #[test]
    fn real_b0_with_timestamp() {
        let Some(b0) = real_b0("real_b0_with_timestamp") else {
            return;
        };
        let mut receiver = Receiver::new();
        let mut bytes = hex("06 00 02 80");
        bytes.extend(&b0);
        let seen = run(&mut receiver, &bytes, 5_000, 20);
        assert_eq!(seen[0], Seen::Ack(5_000));
        assert_eq!(seen[1], Seen::Telegram(b0, 5_000 + 4 * 20));
        assert_eq!(receiver.stats().garbage_bytes, 3);
    }

    #[test]
    fn clear_counts_garbage() {
        let mut receiver = Receiver::new();
        for &byte in &hex("02 80 D6 02 B0") {
            receiver.push(byte, 0);
        }
        assert_eq!(receiver.pending_bytes(), 5);
        receiver.clear();
        assert_eq!(receiver.pending_bytes(), 0);
        assert_accounted(&receiver);
    }

    #[test]
    fn timeout_below_sensor_gap_is_raised() {
        assert_eq!(
            Receiver::with_timeout_us(1_000).timeout_us(),
            MAX_SENSOR_GAP_US + 1
        );
        assert_eq!(Receiver::with_timeout_us(20_000).timeout_us(), 20_000);
    }

    /// A valid reply telegram with 1 to 59 random data bytes.
    fn telegram_strategy() -> impl Strategy<Value = Vec<u8>> {
        sized_telegram_strategy(1..60)
    }

    /// A valid reply telegram with a number of random data bytes in `data_len`.
    fn sized_telegram_strategy(
        data_len: core::ops::Range<usize>,
    ) -> impl Strategy<Value = Vec<u8>> {
        (
            0x80u8..=0xFF,
            any::<u8>(),
            prop::collection::vec(any::<u8>(), data_len),
        )
            .prop_map(|(address, code, data)| {
                let mut bytes = vec![0u8; data.len() + 7];
                let mut view = Telegram::new_unchecked(&mut bytes[..]);
                view.set_header(address, code, data.len());
                view.data_mut().copy_from_slice(&data);
                view.fill_crc();
                bytes
            })
    }

    /// How a telegram is damaged before it is sent.
    #[derive(Debug, Clone)]
    enum Damage {
        None,
        Flip { at: usize, mask: u8 },
        Truncate { keep: usize },
        Garbage(Vec<u8>),
    }

    fn damage_strategy() -> impl Strategy<Value = Damage> {
        prop_oneof![
            3 => Just(Damage::None),
            1 => (any::<usize>(), 1u8..=255).prop_map(|(at, mask)| Damage::Flip { at, mask }),
            1 => any::<usize>().prop_map(|keep| Damage::Truncate { keep }),
            1 => prop::collection::vec(any::<u8>(), 1..40).prop_map(Damage::Garbage),
        ]
    }

    /// Checks that every intact telegram (first-byte time, bytes) was delivered with its time,
    /// unless a telegram that passed every check covers some of its bytes: random bytes
    /// around it formed, against odds of 2⁻¹⁶, a telegram with a valid checksum, or the
    /// remains of a damaged telegram plus its first bytes rebuilt the undamaged one.
    fn check_delivery(
        intact: &[(u64, Vec<u8>)],
        seen: &[Seen],
        byte_us: u64,
    ) -> Result<(), TestCaseError> {
        let delivered: Vec<(u64, &Vec<u8>)> = seen
            .iter()
            .filter_map(|s| match s {
                Seen::Telegram(bytes, stamp) => Some((*stamp, bytes)),
                _ => None,
            })
            .collect();
        let span = |t: u64, len: usize| (t, t + byte_us * (len as u64 - 1));
        for (t, bytes) in intact {
            if delivered.iter().any(|(t2, b2)| t2 == t && *b2 == bytes) {
                continue;
            }
            let (a0, a1) = span(*t, bytes.len());
            let covered = delivered.iter().any(|(t2, b2)| {
                let (b0, b1) = span(*t2, b2.len());
                b0 <= a1 && a0 <= b1
            });
            prop_assert!(covered, "lost {:02x?} at {}", bytes, t);
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Every intact telegram is delivered, with the time of its first byte, whatever damage
        /// precedes it (see `check_delivery` for the one exception).
        #[test]
        fn intact_telegrams_survive_damage(
            items in prop::collection::vec((telegram_strategy(), damage_strategy()), 1..12),
        ) {
            let mut stream = Vec::new();
            let mut intact = Vec::new();
            for (telegram, damage) in &items {
                match damage {
                    Damage::None => {
                        intact.push((stream.len() as u64 * 20, telegram.clone()));
                        stream.extend(telegram);
                    }
                    Damage::Flip { at, mask } => {
                        let mut t = telegram.clone();
                        let at = at % t.len();
                        t[at] ^= mask;
                        stream.extend(t);
                    }
                    Damage::Truncate { keep } => stream.extend(&telegram[..keep % telegram.len()]),
                    Damage::Garbage(g) => {
                        stream.extend(g);
                        intact.push((stream.len() as u64 * 20, telegram.clone()));
                        stream.extend(telegram);
                    }
                }
            }
            let mut receiver = Receiver::new();
            let seen = run(&mut receiver, &stream, 0, 20);
            check_delivery(&intact, &seen, 20)?;
            assert_accounted(&receiver);
        }

        /// Telegrams up to the largest size, damaged or not: re-examination then starts deep
        /// inside the buffer and the unconsumed bytes must be moved to its front.
        #[test]
        fn large_telegrams_survive_damage(
            items in prop::collection::vec(
                (sized_telegram_strategy(300..usize::from(MAX_LEN_FIELD)), damage_strategy()),
                1..6,
            ),
        ) {
            let mut stream = Vec::new();
            let mut intact = Vec::new();
            for (telegram, damage) in &items {
                match damage {
                    Damage::None | Damage::Garbage(_) => {
                        if let Damage::Garbage(g) = damage {
                            stream.extend(g);
                        }
                        intact.push((stream.len() as u64 * 20, telegram.clone()));
                        stream.extend(telegram);
                    }
                    Damage::Flip { at, mask } => {
                        let mut t = telegram.clone();
                        let at = at % t.len();
                        t[at] ^= mask;
                        stream.extend(t);
                    }
                    Damage::Truncate { keep } => stream.extend(&telegram[..keep % telegram.len()]),
                }
            }
            let mut receiver = Receiver::new();
            let seen = run(&mut receiver, &stream, 0, 20);
            check_delivery(&intact, &seen, 20)?;
            assert_accounted(&receiver);
        }

        /// Intact telegrams separated by pauses longer than the timeout from truncated ones.
        #[test]
        fn truncation_with_pause(
            items in prop::collection::vec((telegram_strategy(), any::<usize>(), any::<bool>()), 1..8),
        ) {
            let mut receiver = Receiver::new();
            let mut now = 0u64;
            let mut seen = Vec::new();
            let mut intact = Vec::new();
            for (telegram, keep, cut) in &items {
                let part = if *cut { &telegram[..keep % telegram.len()] } else { &telegram[..] };
                if !cut {
                    intact.push((now, telegram.clone()));
                }
                for &byte in part {
                    if let Some(event) = receiver.push(byte, now) {
                        seen.push(own(event));
                    }
                    now += 20;
                }
                now += 50_000;
            }
            while let Some(event) = receiver.poll(now + 1_000_000) {
                seen.push(own(event));
            }
            check_delivery(&intact, &seen, 20)?;
            assert_accounted(&receiver);
        }

        /// Arbitrary bytes never panic, every byte is accounted for, and every telegram
        /// delivered is valid.
        #[test]
        fn arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..3000), step in 0u64..40_000) {
            let mut receiver = Receiver::new();
            let mut now = 0u64;
            for &byte in &bytes {
                if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now) {
                    prop_assert!(telegram.check_len().is_ok());
                    prop_assert!(telegram.check_crc().is_ok());
                    prop_assert!(telegram.address() & 0x80 != 0);
                }
                now += step;
            }
            assert_accounted(&receiver);
            while receiver.poll(now + 1_000_000).is_some() {}
            assert_accounted(&receiver);
            prop_assert_eq!(receiver.pending_bytes(), 0);
        }

        /// Bytes made mostly of STX, address and length-like values stress re-examination.
        #[test]
        fn dense_false_starts(bytes in prop::collection::vec(prop::sample::select(vec![0x02u8, 0x80, 0x06, 0x15, 0x03, 0x00, 0xA0, 0x10]), 0..4000)) {
            let mut receiver = Receiver::new();
            let mut stream = bytes.clone();
            stream.extend(hex(A0));
            let seen = telegrams(&run(&mut receiver, &stream, 0, 20));
            prop_assert_eq!(seen.last(), Some(&hex(A0)));
            assert_accounted(&receiver);
        }
    }
}
