//! Sequence-number bookkeeping: how many frames went missing between two that arrived.

/// Tracks the per-direction sequence number of received frames and counts the gaps.
///
/// A frame whose number is not the one expected means the frames in between were lost
/// (sequence numbers wrap at 65 536, so a gap of more than 32 767 frames cannot be told
/// apart from a restart of the sender and is counted as a restart instead).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct SeqTracker {
    expected: Option<u16>,
    lost: u64,
    restarts: u32,
}

impl SeqTracker {
    /// A tracker that has seen nothing yet.
    pub const fn new() -> Self {
        SeqTracker {
            expected: None,
            lost: 0,
            restarts: 0,
        }
    }

    /// Records an arriving sequence number; returns how many frames were lost just before it.
    pub fn observe(&mut self, seq: u16) -> u16 {
        let gap = match self.expected {
            None => 0,
            Some(expected) => {
                let gap = seq.wrapping_sub(expected);
                if gap >= 0x8000 {
                    // An older or repeated number: the sender restarted its count.
                    self.restarts += 1;
                    0
                } else {
                    gap
                }
            }
        };
        self.lost += u64::from(gap);
        self.expected = Some(seq.wrapping_add(1));
        gap
    }

    /// Total frames lost so far.
    pub fn lost(&self) -> u64 {
        self.lost
    }

    /// How many times the sequence went backwards (a sender restart or reconnect).
    pub fn restarts(&self) -> u32 {
        self.restarts
    }

    /// Forgets the expected number (after a reconnect, for instance) but keeps the counts.
    pub fn resync(&mut self) {
        self.expected = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_gaps_and_wraps() {
        let mut t = SeqTracker::new();
        assert_eq!(t.observe(65_534), 0);
        assert_eq!(t.observe(65_535), 0);
        assert_eq!(t.observe(0), 0);
        assert_eq!(t.observe(3), 2);
        assert_eq!(t.lost(), 2);
    }

    #[test]
    fn backwards_is_a_restart() {
        let mut t = SeqTracker::new();
        t.observe(100);
        assert_eq!(t.observe(0), 0);
        assert_eq!(t.restarts(), 1);
        assert_eq!(t.observe(1), 0);
        assert_eq!(t.lost(), 0);
    }
}
