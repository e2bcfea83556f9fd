//! A tap on the emulated laser's clean output that cuts it into telegrams, so that faults
//! can be applied per telegram and every scan the sensor sent can be accounted for.
//!
//! The sensor's own output (before any fault) holds only ACK (`06h`), NAK (`15h`) and
//! telegrams (`02h`, address, length LE, `length` bytes, CRC LE), so it splits exactly.

/// The `B0h` measured-value reply code.
pub(crate) const SCAN_CODE: u8 = 0xB0;

/// A piece of the sensor's output.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Segment {
    /// A whole telegram, or the start of one the sensor stopped sending (power cycle).
    Telegram {
        /// Its bytes.
        bytes: Vec<u8>,
        /// Whether it is a `B0h` scan.
        is_scan: bool,
        /// Whether the sensor stopped before its end.
        cut: bool,
    },
    /// Bytes outside telegrams (ACK, NAK).
    Other(Vec<u8>),
}

/// The splitter. Feed it bytes in order with [`TelegramTap::push`].
#[derive(Debug, Default)]
pub struct TelegramTap {
    partial: Vec<u8>,
}

/// Bytes before a telegram's data: STX, address, length.
pub(crate) const HEADER_LEN: usize = 4;

impl TelegramTap {
    /// An idle tap.
    pub fn new() -> TelegramTap {
        TelegramTap::default()
    }

    /// Splits `bytes` into complete segments; a telegram not yet complete is kept.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Segment> {
        let mut out = Vec::new();
        let mut other = Vec::new();
        for &byte in bytes {
            if self.partial.is_empty() && byte != firmware::sick::telegram::STX {
                other.push(byte);
                continue;
            }
            if !other.is_empty() {
                out.push(Segment::Other(std::mem::take(&mut other)));
            }
            self.partial.push(byte);
            if let Some(total) = self.expected_len()
                && self.partial.len() == total
            {
                let bytes = std::mem::take(&mut self.partial);
                // By its command byte, whatever its CRC: a replayed capture can hold scans
                // damaged before they were recorded.
                let is_scan = bytes.get(HEADER_LEN) == Some(&SCAN_CODE);
                out.push(Segment::Telegram {
                    bytes,
                    is_scan,
                    cut: false,
                });
            }
        }
        if !other.is_empty() {
            out.push(Segment::Other(other));
        }
        out
    }

    /// The sensor stopped mid-telegram: returns what it sent of it.
    pub fn cut(&mut self) -> Option<Segment> {
        if self.partial.is_empty() {
            return None;
        }
        let bytes = std::mem::take(&mut self.partial);
        // The command byte follows the header.
        let is_scan = bytes.get(HEADER_LEN) == Some(&SCAN_CODE);
        Some(Segment::Telegram {
            bytes,
            is_scan,
            cut: true,
        })
    }

    /// Whether a telegram has started and not ended.
    pub fn in_telegram(&self) -> bool {
        !self.partial.is_empty()
    }

    fn expected_len(&self) -> Option<usize> {
        let len = u16::from_le_bytes([*self.partial.get(2)?, *self.partial.get(3)?]);
        Some(HEADER_LEN + usize::from(len) + 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::sick::Request;

    #[test]
    fn splits_acks_and_telegrams_across_pushes() {
        let request = Request::Status.to_bytes();
        let telegram = request.as_bytes().to_vec();
        let mut stream = vec![0x06];
        stream.extend_from_slice(&telegram);
        stream.push(0x15);
        stream.extend_from_slice(&telegram[..3]);
        let mut tap = TelegramTap::new();
        let mut got = Vec::new();
        for chunk in stream.chunks(5) {
            got.extend(tap.push(chunk));
        }
        assert_eq!(got.len(), 3, "{got:?}");
        assert_eq!(got[0], Segment::Other(vec![0x06]));
        assert!(
            matches!(&got[1], Segment::Telegram { bytes, cut: false, .. } if *bytes == telegram)
        );
        assert_eq!(got[2], Segment::Other(vec![0x15]));
        assert!(tap.in_telegram());
        assert!(matches!(
            tap.cut(),
            Some(Segment::Telegram { cut: true, .. })
        ));
        assert!(!tap.in_telegram());
    }
}
