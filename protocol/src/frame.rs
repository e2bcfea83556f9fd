//! The raw frame: a zero-copy view over the bytes between two COBS delimiters, once decoded.
//!
//! Contract (as smoltcp's `wire` types): after [`Frame::new_checked`] succeeds no accessor
//! panics; [`Frame::check_crc`] says whether the trailing CRC-32 matches the rest.

use core::fmt;

use crate::kind::Kind;

/// CRC-32 (ISO-HDLC, the one of Ethernet and zlib) over header and payload.
pub(crate) const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

mod field {
    pub type Field = core::ops::Range<usize>;
    pub const VERSION: usize = 0;
    pub const KIND: usize = 1;
    pub const SEQ: Field = 2..4;
    pub const PAYLOAD_START: usize = 4;
    pub const CRC_LEN: usize = 4;
}

/// Offset of the payload in a raw frame.
pub(crate) const PAYLOAD_START: usize = field::PAYLOAD_START;

/// Length of the trailing CRC.
pub(crate) const CRC_LEN: usize = field::CRC_LEN;

/// Header plus CRC: the bytes a frame carries besides its payload.
pub const FRAME_OVERHEAD: usize = field::PAYLOAD_START + field::CRC_LEN;

/// The largest payload a frame may carry. The biggest message, a 401-value scan with every
/// optional field and every range word at its 3-byte varint worst case, needs 1 232 bytes.
pub const MAX_PAYLOAD_LEN: usize = 1280;

/// The largest raw (COBS-decoded) frame.
pub const MAX_FRAME_LEN: usize = MAX_PAYLOAD_LEN + FRAME_OVERHEAD;

/// The largest frame on the wire: COBS adds one byte per started 254 bytes plus one, and the
/// 0x00 delimiter ends it.
pub const MAX_WIRE_LEN: usize = MAX_FRAME_LEN + MAX_FRAME_LEN.div_ceil(254) + 1 + 1;

/// What can be wrong with a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// Shorter than a header and a CRC, or a buffer too small for what must go in it.
    Truncated,
    /// Longer than [`MAX_WIRE_LEN`] before its delimiter.
    Oversize,
    /// The COBS encoding is invalid.
    BadCobs,
    /// The CRC-32 does not match.
    BadCrc,
    /// A protocol version this side does not speak.
    UnsupportedVersion(u8),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Truncated => f.write_str("frame truncated"),
            Error::Oversize => f.write_str("frame longer than the protocol maximum"),
            Error::BadCobs => f.write_str("invalid COBS encoding"),
            Error::BadCrc => f.write_str("CRC-32 mismatch"),
            Error::UnsupportedVersion(v) => write!(f, "unsupported protocol version {v}"),
        }
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for Error {}

/// The header fields of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// Protocol version of the sender.
    pub version: u8,
    /// What the payload is.
    pub kind: Kind,
    /// Per-direction sequence number, wrapping at 65 536.
    pub seq: u16,
}

/// A read/write view of a raw frame.
#[derive(Debug, Clone)]
pub struct Frame<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Frame<T> {
    /// Wraps a buffer without checking anything; accessors may panic on a short buffer.
    pub const fn new_unchecked(buffer: T) -> Frame<T> {
        Frame { buffer }
    }

    /// Wraps a buffer after [`Frame::check_len`].
    ///
    /// # Errors
    /// [`Error::Truncated`] if the buffer cannot hold a header and a CRC.
    pub fn new_checked(buffer: T) -> Result<Frame<T>, Error> {
        let frame = Self::new_unchecked(buffer);
        frame.check_len()?;
        Ok(frame)
    }

    /// Checks that the buffer holds at least a header and a CRC.
    ///
    /// # Errors
    /// [`Error::Truncated`] otherwise.
    pub fn check_len(&self) -> Result<(), Error> {
        if self.buffer.as_ref().len() < FRAME_OVERHEAD {
            Err(Error::Truncated)
        } else {
            Ok(())
        }
    }

    /// Checks the trailing CRC-32 against the header and payload.
    ///
    /// # Errors
    /// [`Error::BadCrc`] if they differ.
    pub fn check_crc(&self) -> Result<(), Error> {
        if self.crc() == self.compute_crc() {
            Ok(())
        } else {
            Err(Error::BadCrc)
        }
    }

    /// Consumes the view and returns the buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The sender's protocol version.
    pub fn version(&self) -> u8 {
        self.buffer.as_ref()[field::VERSION]
    }

    /// The payload kind.
    pub fn kind(&self) -> Kind {
        Kind::from(self.buffer.as_ref()[field::KIND])
    }

    /// The sequence number.
    pub fn seq(&self) -> u16 {
        let b = &self.buffer.as_ref()[field::SEQ];
        u16::from_le_bytes([b[0], b[1]])
    }

    /// All header fields.
    pub fn header(&self) -> Header {
        Header {
            version: self.version(),
            kind: self.kind(),
            seq: self.seq(),
        }
    }

    /// The postcard payload.
    pub fn payload(&self) -> &[u8] {
        let data = self.buffer.as_ref();
        &data[field::PAYLOAD_START..data.len() - field::CRC_LEN]
    }

    /// The CRC-32 carried by the frame.
    pub fn crc(&self) -> u32 {
        let data = self.buffer.as_ref();
        let b = &data[data.len() - field::CRC_LEN..];
        u32::from_le_bytes([b[0], b[1], b[2], b[3]])
    }

    /// The CRC-32 of the header and payload as they are now.
    pub fn compute_crc(&self) -> u32 {
        let data = self.buffer.as_ref();
        CRC32.checksum(&data[..data.len() - field::CRC_LEN])
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Frame<T> {
    /// Writes the header fields.
    pub fn set_header(&mut self, header: Header) {
        let data = self.buffer.as_mut();
        data[field::VERSION] = header.version;
        data[field::KIND] = header.kind.into();
        data[field::SEQ].copy_from_slice(&header.seq.to_le_bytes());
    }

    /// The payload, writable.
    pub fn payload_mut(&mut self) -> &mut [u8] {
        let data = self.buffer.as_mut();
        let end = data.len() - field::CRC_LEN;
        &mut data[field::PAYLOAD_START..end]
    }

    /// Computes the CRC-32 over header and payload and stores it.
    pub fn fill_crc(&mut self) {
        let crc = self.compute_crc();
        let data = self.buffer.as_mut();
        let start = data.len() - field::CRC_LEN;
        data[start..].copy_from_slice(&crc.to_le_bytes());
    }
}

/// The raw frame length for a payload of `payload_len` bytes.
pub const fn frame_len(payload_len: usize) -> usize {
    payload_len + FRAME_OVERHEAD
}

#[cfg(test)]
mod tests {
    use super::*;

    // version 1, kind Heartbeat, seq 0x0102, payload = postcard(u64 5) = [05], CRC-32 LE.
    static FRAME_BYTES: [u8; 9] = [0x01, 0x05, 0x02, 0x01, 0x05, 0x3F, 0x3F, 0x69, 0xA6];

    #[test]
    fn test_deconstruct() {
        let frame = Frame::new_checked(&FRAME_BYTES[..]).unwrap();
        assert_eq!(frame.version(), 1);
        assert_eq!(frame.kind(), Kind::Heartbeat);
        assert_eq!(frame.seq(), 0x0102);
        assert_eq!(frame.payload(), &[0x05]);
        assert_eq!(frame.check_crc(), Ok(()));
    }

    #[test]
    fn test_construct() {
        let mut bytes = [0u8; 9];
        let mut frame = Frame::new_unchecked(&mut bytes[..]);
        frame.set_header(Header {
            version: 1,
            kind: Kind::Heartbeat,
            seq: 0x0102,
        });
        frame.payload_mut()[0] = 0x05;
        frame.fill_crc();
        assert_eq!(bytes, FRAME_BYTES);
    }

    #[test]
    fn test_bad_crc() {
        let mut bytes = FRAME_BYTES;
        bytes[4] ^= 0x40;
        let frame = Frame::new_checked(&bytes[..]).unwrap();
        assert_eq!(frame.check_crc(), Err(Error::BadCrc));
    }

    #[test]
    fn test_impossible_len() {
        for len in 0..FRAME_OVERHEAD {
            assert_eq!(
                Frame::new_checked(&FRAME_BYTES[..len]).err(),
                Some(Error::Truncated)
            );
        }
        // Exactly a header and a CRC: an empty payload, which is legal for unit messages.
        let frame = Frame::new_checked(&FRAME_BYTES[..FRAME_OVERHEAD]).unwrap();
        assert!(frame.payload().is_empty());
    }

    #[test]
    fn wire_bound_covers_cobs_worst_case() {
        assert!(MAX_WIRE_LEN > cobs::max_encoding_length(MAX_FRAME_LEN));
    }
}
