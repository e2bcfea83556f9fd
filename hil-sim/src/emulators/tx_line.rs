//! The transmit side of an emulated UART: when each byte an emulator sends leaves the line.
//!
//! A byte takes 10 bit times (start bit, 8 data bits, stop bit). Chunks are sent back to
//! back in the order they were pushed; a chunk starts at the time it was pushed for or when
//! the line is free, whichever is later, at the baud rate it was pushed with. A byte counts as
//! sent when its stop bit has left: byte `k` of a chunk that starts at `start_us` is sent at
//! `start_us + ⌈(k + 1) · 10 · 10⁶ / baud⌉` µs, so pacing never drifts.

use std::collections::VecDeque;

/// Bit times per byte on the line (8N1).
pub const BITS_PER_BYTE: u64 = 10;

/// Bytes that left the line back to back at one baud rate.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TxRun {
    /// The baud rate they were sent at.
    pub baud: u32,
    /// The bytes.
    pub bytes: Vec<u8>,
}

#[derive(Debug, Clone)]
struct Chunk {
    start_us: u64,
    baud: u32,
    bytes: Vec<u8>,
    /// Bytes already handed out.
    sent: usize,
    /// Whether [`TxLine::interrupt`] may cut it short.
    interruptible: bool,
}

impl Chunk {
    /// When byte `index` has left the line.
    fn byte_end_us(&self, index: usize) -> u64 {
        self.start_us + byte_offset_us(index as u64 + 1, self.baud)
    }

    fn end_us(&self) -> u64 {
        self.byte_end_us(self.bytes.len().saturating_sub(1))
    }
}

/// Time for `bytes` bytes at `baud`, rounded up to whole µs.
pub fn byte_offset_us(bytes: u64, baud: u32) -> u64 {
    (bytes * BITS_PER_BYTE * 1_000_000).div_ceil(u64::from(baud.max(1)))
}

/// A paced transmitter. See the [module documentation](self).
#[derive(Debug, Clone, Default)]
pub struct TxLine {
    chunks: VecDeque<Chunk>,
    free_at_us: u64,
}

impl TxLine {
    /// An idle line.
    pub fn new() -> TxLine {
        TxLine::default()
    }

    /// When everything pushed so far has left the line.
    pub fn free_at_us(&self) -> u64 {
        self.free_at_us
    }

    /// Queues `bytes` to start at `start_us` or when the line is free, at `baud`; returns the
    /// time the last byte will have left. An `interruptible` chunk may be cut short by
    /// [`Self::interrupt`].
    pub fn push(&mut self, start_us: u64, baud: u32, bytes: Vec<u8>, interruptible: bool) -> u64 {
        if bytes.is_empty() {
            return self.free_at_us;
        }
        let chunk = Chunk {
            start_us: start_us.max(self.free_at_us),
            baud,
            bytes,
            sent: 0,
            interruptible,
        };
        self.free_at_us = chunk.end_us();
        self.chunks.push_back(chunk);
        self.free_at_us
    }

    /// When the next byte not yet handed out leaves the line.
    pub fn next_byte_end_us(&self) -> Option<u64> {
        self.chunks.front().map(|c| c.byte_end_us(c.sent))
    }

    /// Hands out every byte that has left the line by `now_us`, grouped by baud rate.
    pub fn transmit_until(&mut self, now_us: u64, out: &mut Vec<TxRun>) {
        while let Some(chunk) = self.chunks.front_mut() {
            let mut end = chunk.sent;
            while end < chunk.bytes.len() && chunk.byte_end_us(end) <= now_us {
                end += 1;
            }
            if end > chunk.sent {
                let bytes = &chunk.bytes[chunk.sent..end];
                match out.last_mut() {
                    Some(run) if run.baud == chunk.baud => run.bytes.extend_from_slice(bytes),
                    _ => out.push(TxRun {
                        baud: chunk.baud,
                        bytes: bytes.to_vec(),
                    }),
                }
                chunk.sent = end;
            }
            if chunk.sent < chunk.bytes.len() {
                break;
            }
            self.chunks.pop_front();
        }
    }

    /// Cuts short the chunk being sent at `now_us` if it is interruptible and nothing is
    /// queued after it: bytes not completely sent by then are dropped and the line is free at
    /// `now_us`. Call [`Self::transmit_until`] for `now_us` first. Returns whether a chunk
    /// was cut.
    pub fn interrupt(&mut self, now_us: u64) -> bool {
        if self.chunks.len() != 1 {
            return false;
        }
        let Some(chunk) = self.chunks.back_mut() else {
            return false;
        };
        if !chunk.interruptible || chunk.start_us > now_us || chunk.sent == chunk.bytes.len() {
            return false;
        }
        chunk.bytes.truncate(chunk.sent);
        self.chunks.clear();
        self.free_at_us = now_us;
        true
    }

    /// Drops everything not sent by `now_us` (the transmitter lost power). Call
    /// [`Self::transmit_until`] for `now_us` first.
    pub fn cut(&mut self, now_us: u64) {
        self.chunks.clear();
        self.free_at_us = now_us;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_leave_at_the_baud_rate() {
        let mut line = TxLine::new();
        // 9 600 Bd: 1 041.67 µs per byte.
        let end = line.push(1_000, 9_600, vec![1, 2, 3], false);
        assert_eq!(end, 1_000 + 3_125);
        let mut out = Vec::new();
        line.transmit_until(2_041, &mut out);
        assert!(out.is_empty());
        line.transmit_until(2_042, &mut out);
        assert_eq!(
            out,
            [TxRun {
                baud: 9_600,
                bytes: vec![1]
            }]
        );
        assert_eq!(line.next_byte_end_us(), Some(1_000 + 2_084));
        // A chunk pushed for an earlier time waits for the line.
        line.push(0, 500_000, vec![4, 5], false);
        line.transmit_until(10_000, &mut out);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].bytes, [1, 2, 3]);
        assert_eq!(
            out[1],
            TxRun {
                baud: 500_000,
                bytes: vec![4, 5]
            }
        );
        assert_eq!(line.free_at_us(), 4_125 + 40);
    }

    #[test]
    fn interrupt_drops_the_rest() {
        let mut line = TxLine::new();
        line.push(0, 500_000, vec![0; 100], true);
        let mut out = Vec::new();
        line.transmit_until(200, &mut out);
        assert!(line.interrupt(200));
        assert_eq!(line.free_at_us(), 200);
        line.transmit_until(10_000, &mut out);
        assert_eq!(out[0].bytes.len(), 10);
        assert_eq!(line.next_byte_end_us(), None);
        // Not interruptible.
        line.push(300, 500_000, vec![0; 100], false);
        line.transmit_until(400, &mut out);
        assert!(!line.interrupt(400));
    }
}
