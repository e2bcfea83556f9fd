//! Messages from a byte stream of the board, with the accounting of everything that did not
//! arrive.

use protocol::{Decoder, DecoderStats, Received};

/// Counters of a link reader.
pub type LinkStats = DecoderStats;

/// Decodes the board's frames. A thin layer over [`protocol::Decoder`] that keeps a
/// per-kind count.
#[derive(Debug)]
pub struct LinkReader {
    decoder: Decoder,
    per_kind: [u64; 256],
}

impl Default for LinkReader {
    fn default() -> Self {
        Self::new()
    }
}

impl LinkReader {
    /// A reader waiting for the first frame.
    pub fn new() -> Self {
        LinkReader {
            decoder: Decoder::new(),
            per_kind: [0; 256],
        }
    }

    /// Feeds bytes; returns the messages they completed. Bad frames are counted in
    /// [`LinkReader::stats`].
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<Received> {
        let mut out = Vec::new();
        for &b in bytes {
            if let Some(Ok(received)) = self.decoder.push(b) {
                self.per_kind[usize::from(u8::from(received.header.kind))] += 1;
                out.push(received);
            }
        }
        out
    }

    /// Forgets a partial frame after a reconnect, keeping the counters.
    pub fn reconnected(&mut self) {
        self.decoder.reset();
    }

    /// Counters so far.
    pub fn stats(&self) -> LinkStats {
        self.decoder.stats()
    }

    /// Messages received of `kind`.
    pub fn count(&self, kind: protocol::Kind) -> u64 {
        self.per_kind[usize::from(u8::from(kind))]
    }
}
