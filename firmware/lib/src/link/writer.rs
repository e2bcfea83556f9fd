//! Outgoing frames: numbering, encoding, and skipping the numbers of dropped frames.

use protocol::{Encoder, MAX_WIRE_LEN, Message, MessageError};

/// Turns messages into wire frames for the host link.
pub struct LinkWriter {
    encoder: Encoder,
    wire: [u8; MAX_WIRE_LEN],
}

impl Default for LinkWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl LinkWriter {
    /// A writer whose first frame has sequence number 0.
    pub const fn new() -> Self {
        LinkWriter {
            encoder: Encoder::new(),
            wire: [0; MAX_WIRE_LEN],
        }
    }

    /// Encodes `message` after skipping `dropped_before` sequence numbers (frames dropped
    /// before they were encoded), and returns the complete wire frame.
    ///
    /// # Errors
    /// [`MessageError::BufferTooSmall`] if the message exceeds the protocol maximum, which no
    /// message built by the board does.
    pub fn frame(&mut self, message: &Message, dropped_before: u16) -> Result<&[u8], MessageError> {
        self.encoder.skip(dropped_before);
        self.encoder.encode(message, &mut self.wire)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::{Decoder, HeartbeatMsg};

    #[test]
    fn skipped_numbers_show_up_as_lost_frames() {
        let mut writer = LinkWriter::new();
        let mut decoder = Decoder::new();
        let m = Message::Heartbeat(HeartbeatMsg { uptime_us: 3 });
        let mut got = Vec::new();
        decoder.feed(writer.frame(&m, 0).unwrap(), |r| got.push(r.lost_before));
        decoder.feed(writer.frame(&m, 2).unwrap(), |r| got.push(r.lost_before));
        assert_eq!(got, [0, 2]);
        assert_eq!(decoder.stats().lost, 2);
    }
}
