//! A tap on the emulated laser's clean output that tells its telegrams apart as their bytes
//! leave the sensor, so that faults can be applied per telegram and every scan the sensor sent
//! can be accounted for, while the bytes go on to the board as a UART would receive them: each
//! when it has left the line, not a whole telegram at once at its end.
//!
//! The sensor's own output (before any fault) holds only ACK (`06h`), NAK (`15h`) and
//! telegrams (`02h`, address, length LE, `length` bytes, CRC LE), so it splits exactly. A
//! telegram's first five bytes (up to its command byte) are held until the fifth has left:
//! then its length and kind are known.

/// The `B0h` measured-value reply code.
pub(crate) const SCAN_CODE: u8 = 0xB0;

/// Bytes before a telegram's data: STX, address, length.
pub(crate) const HEADER_LEN: usize = 4;

/// What the tap hands on, in the order the bytes left the sensor.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Piece {
    /// Bytes outside telegrams (ACK, NAK).
    Other(Vec<u8>),
    /// A telegram begins, `len` bytes in all as its length field says; `is_scan` by its
    /// command byte, whatever its CRC (a replayed capture can hold scans damaged before they
    /// were recorded). Its bytes follow in [`Piece::Part`]s.
    Start {
        /// Its length.
        len: usize,
        /// Whether it is a `B0h` scan.
        is_scan: bool,
    },
    /// Bytes of the telegram begun last.
    Part(Vec<u8>),
    /// The telegram begun last is over; every byte of it has been handed on in parts.
    End {
        /// All its bytes.
        bytes: Vec<u8>,
        /// Whether it is a `B0h` scan.
        is_scan: bool,
        /// Whether the sensor stopped before its end (power cycle, or a request that
        /// interrupted a scan).
        cut: bool,
    },
    /// The first bytes of a telegram the sensor stopped sending before its command byte,
    /// not handed on before: its kind is unknown.
    Fragment(Vec<u8>),
}

/// The splitter. Feed it bytes in order with [`TelegramTap::push`].
#[derive(Debug, Default)]
pub struct TelegramTap {
    /// The telegram under way, its bytes so far.
    partial: Vec<u8>,
    /// Whether it is a scan, once its command byte is known.
    is_scan: Option<bool>,
}

impl TelegramTap {
    /// An idle tap.
    pub fn new() -> TelegramTap {
        TelegramTap::default()
    }

    /// Splits `bytes`, which have just left the sensor, into pieces.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Piece> {
        let mut out = Vec::new();
        let mut other = Vec::new();
        let mut part = Vec::new();
        for &byte in bytes {
            if self.partial.is_empty() && byte != firmware::sick::telegram::STX {
                other.push(byte);
                continue;
            }
            if !other.is_empty() {
                out.push(Piece::Other(std::mem::take(&mut other)));
            }
            self.partial.push(byte);
            match self.is_scan {
                Some(_) => part.push(byte),
                None if self.partial.len() > HEADER_LEN => {
                    let is_scan = self.partial.get(HEADER_LEN) == Some(&SCAN_CODE);
                    self.is_scan = Some(is_scan);
                    out.push(Piece::Start {
                        len: self.expected_len().unwrap_or(self.partial.len()),
                        is_scan,
                    });
                    part.extend_from_slice(&self.partial);
                }
                None => {}
            }
            if let Some(total) = self.expected_len()
                && self.partial.len() >= total
                && let Some(is_scan) = self.is_scan.take()
            {
                out.push(Piece::Part(std::mem::take(&mut part)));
                out.push(Piece::End {
                    bytes: std::mem::take(&mut self.partial),
                    is_scan,
                    cut: false,
                });
            }
        }
        if !part.is_empty() {
            out.push(Piece::Part(part));
        }
        if !other.is_empty() {
            out.push(Piece::Other(other));
        }
        out
    }

    /// The sensor stopped mid-telegram: ends the telegram under way, or hands on the bytes
    /// held of one whose command byte never came.
    pub fn cut(&mut self) -> Option<Piece> {
        if self.partial.is_empty() {
            return None;
        }
        let bytes = std::mem::take(&mut self.partial);
        Some(match self.is_scan.take() {
            Some(is_scan) => Piece::End {
                bytes,
                is_scan,
                cut: true,
            },
            None => Piece::Fragment(bytes),
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

    /// The bytes handed on, whatever the pieces.
    fn handed_on(pieces: &[Piece]) -> Vec<u8> {
        pieces
            .iter()
            .flat_map(|p| match p {
                Piece::Other(b) | Piece::Part(b) | Piece::Fragment(b) => b.clone(),
                Piece::Start { .. } | Piece::End { .. } => Vec::new(),
            })
            .collect()
    }

    #[test]
    fn hands_bytes_on_as_they_come_and_splits_telegrams() {
        let request = Request::Status.to_bytes();
        let telegram = request.as_bytes().to_vec();
        let mut stream = vec![0x06];
        stream.extend_from_slice(&telegram);
        stream.push(0x15);
        stream.extend_from_slice(&telegram[..3]);
        let mut tap = TelegramTap::new();
        let mut got = Vec::new();
        for chunk in stream.chunks(2) {
            got.extend(tap.push(chunk));
        }
        assert_eq!(handed_on(&got), stream[..stream.len() - 3]);
        assert_eq!(got[0], Piece::Other(vec![0x06]));
        assert!(got.contains(&Piece::Start {
            len: telegram.len(),
            is_scan: false
        }));
        assert!(got.contains(&Piece::End {
            bytes: telegram.clone(),
            is_scan: false,
            cut: false
        }));
        assert!(got.contains(&Piece::Other(vec![0x15])));
        // Cut before its command byte: the held bytes go on as a fragment.
        assert!(tap.in_telegram());
        assert_eq!(tap.cut(), Some(Piece::Fragment(telegram[..3].to_vec())));
        assert!(!tap.in_telegram());
        assert_eq!(tap.cut(), None);
    }

    #[test]
    fn a_scan_is_handed_on_byte_by_byte_and_cut_short() {
        // A B0h header of 732 bytes in all, then some of its body.
        let mut scan = vec![0x02, 0x80, 0xD6, 0x02, 0xB0, 0x69, 0x01];
        scan.extend(std::iter::repeat_n(0x11, 100));
        let mut tap = TelegramTap::new();
        let mut pieces = Vec::new();
        for &byte in &scan {
            let out = tap.push(&[byte]);
            if tap.partial.len() > HEADER_LEN {
                // From the command byte on, every byte goes on as it comes.
                assert!(matches!(out.last(), Some(Piece::Part(_))), "{out:?}");
            } else {
                assert!(out.is_empty());
            }
            pieces.extend(out);
        }
        assert_eq!(
            pieces[0],
            Piece::Start {
                len: 732,
                is_scan: true
            }
        );
        assert_eq!(handed_on(&pieces), scan);
        assert_eq!(
            tap.cut(),
            Some(Piece::End {
                bytes: scan,
                is_scan: true,
                cut: true
            })
        );
    }
}
