//! A zero-copy view of one SICK LMS2xx telegram (protocol notes §2; Telegram Listing §3).
//!
//! ```text
//! offset  0    1        2..4        4             5 .. 4+L            4+L .. 6+L
//!        STX  address  length L   command/reply  data (last byte =   CRC (LE)
//!                      (LE)        code           status in replies)
//! ```
//!
//! Contract (as smoltcp's `wire` views): [`Telegram::new_unchecked`] wraps any buffer;
//! [`Telegram::check_len`] makes every accessor panic-free; [`Telegram::new_checked`] does both
//! and also checks STX. The checksum is verified separately with [`Telegram::check_crc`], so a
//! receiver that already verified it incrementally does not pay twice. The buffer may be
//! longer than the telegram; bytes after the CRC are ignored.

use super::crc::crc16;
use super::error::{Error, Result};

/// Start of every telegram.
pub const STX: u8 = 0x02;
/// The unframed acknowledge byte the LMS sends after accepting a request (§4).
pub const ACK: u8 = 0x06;
/// The unframed not-acknowledge byte the LMS sends after a request with a bad checksum (§4).
pub const NAK: u8 = 0x15;
/// The largest length field of a standard LMS2xx telegram (401 values with real-time indices).
pub const MAX_LEN_FIELD: u16 = 808;
/// The largest telegram, in bytes: `MAX_LEN_FIELD` plus STX, address, length and CRC.
pub const MAX_TELEGRAM_LEN: usize = MAX_LEN_FIELD as usize + OVERHEAD_LEN;
/// Bytes of a telegram not counted by its length field: STX, address, length (2), CRC (2).
pub const OVERHEAD_LEN: usize = 6;
/// Bytes before the command byte: STX, address, length.
pub const HEADER_LEN: usize = 4;
/// Address of host requests to any device (what every driver uses).
pub const HOST_ADDRESS: u8 = 0x00;
/// Bit set in the address of every reply from the LMS.
pub const REPLY_ADDRESS_BIT: u8 = 0x80;
/// Address of replies to broadcast requests.
pub const REPLY_ADDRESS: u8 = HOST_ADDRESS | REPLY_ADDRESS_BIT;

mod field {
    pub type Field = core::ops::Range<usize>;

    pub const STX: usize = 0;
    pub const ADDRESS: usize = 1;
    pub const LENGTH: Field = 2..4;
    pub const COMMAND: usize = 4;
    pub const DATA_START: usize = 5;
}

/// Total size in bytes of a telegram whose length field is `len_field`.
pub const fn telegram_len(len_field: u16) -> usize {
    len_field as usize + OVERHEAD_LEN
}

/// A view of a SICK telegram in a byte buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Telegram<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Telegram<T> {
    /// Wraps `buffer` without any check.
    pub const fn new_unchecked(buffer: T) -> Telegram<T> {
        Telegram { buffer }
    }

    /// Wraps `buffer` after [`Self::check_len`] and the STX check.
    ///
    /// # Errors
    /// [`Error::Truncated`], [`Error::BadLength`] as in [`Self::check_len`];
    /// [`Error::BadStx`] when the first byte is not `02h`.
    pub fn new_checked(buffer: T) -> Result<Telegram<T>> {
        let telegram = Self::new_unchecked(buffer);
        telegram.check_len()?;
        if telegram.buffer.as_ref()[field::STX] != STX {
            return Err(Error::BadStx);
        }
        Ok(telegram)
    }

    /// Checks that the buffer holds the header and the whole telegram its length field
    /// announces. After it succeeds no accessor panics.
    ///
    /// # Errors
    /// [`Error::Truncated`] when the buffer is shorter than the header or than
    /// `length + 6` bytes; [`Error::BadLength`] when the length field is 0 or above
    /// [`MAX_LEN_FIELD`].
    pub fn check_len(&self) -> Result<()> {
        let bytes = self.buffer.as_ref();
        if bytes.len() < field::DATA_START {
            return Err(Error::Truncated);
        }
        let len_field = self.length();
        if len_field == 0 || len_field > MAX_LEN_FIELD {
            return Err(Error::BadLength);
        }
        if bytes.len() < telegram_len(len_field) {
            return Err(Error::Truncated);
        }
        Ok(())
    }

    /// Checks the transmitted checksum against the one computed over STX … last data byte.
    ///
    /// # Errors
    /// [`Error::BadCrc`] when they differ.
    ///
    /// # Panics
    /// When [`Self::check_len`] would fail.
    pub fn check_crc(&self) -> Result<()> {
        if crc16(self.covered()) == self.crc() {
            Ok(())
        } else {
            Err(Error::BadCrc)
        }
    }

    /// Returns the underlying buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The address byte (`00h` for host requests, `80h` for replies to them).
    #[inline]
    pub fn address(&self) -> u8 {
        self.buffer.as_ref()[field::ADDRESS]
    }

    /// The length field `L`: command byte through the last data byte.
    #[inline]
    pub fn length(&self) -> u16 {
        let b = &self.buffer.as_ref()[field::LENGTH];
        u16::from_le_bytes([b[0], b[1]])
    }

    /// Total size of the telegram in bytes (`L + 6`).
    #[inline]
    pub fn total_len(&self) -> usize {
        telegram_len(self.length())
    }

    /// The command (host requests) or reply code (LMS replies, command + `80h`).
    #[inline]
    pub fn command(&self) -> u8 {
        self.buffer.as_ref()[field::COMMAND]
    }

    /// The bytes after the command byte, up to the CRC. For replies the last of them is the
    /// status byte.
    #[inline]
    pub fn data(&self) -> &[u8] {
        &self.buffer.as_ref()[field::DATA_START..self.crc_start()]
    }

    /// The data of a reply without its trailing status byte (empty if there is no data).
    #[inline]
    pub fn reply_data(&self) -> &[u8] {
        let data = self.data();
        &data[..data.len().saturating_sub(1)]
    }

    /// The status byte of a reply (§8): the last data byte; `None` when there is no data.
    #[inline]
    pub fn status(&self) -> Option<u8> {
        self.data().last().copied()
    }

    /// The transmitted checksum.
    #[inline]
    pub fn crc(&self) -> u16 {
        let start = self.crc_start();
        let b = &self.buffer.as_ref()[start..start + 2];
        u16::from_le_bytes([b[0], b[1]])
    }

    /// The whole telegram, STX through CRC.
    #[inline]
    pub fn as_bytes(&self) -> &[u8] {
        &self.buffer.as_ref()[..self.total_len()]
    }

    /// The bytes the checksum covers: STX through the last data byte.
    #[inline]
    fn covered(&self) -> &[u8] {
        &self.buffer.as_ref()[..self.crc_start()]
    }

    #[inline]
    fn crc_start(&self) -> usize {
        HEADER_LEN + self.length() as usize
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Telegram<T> {
    /// Writes STX, `address`, the length field and the command byte: the frame around
    /// `data_len` data bytes. Call it first when emitting.
    ///
    /// # Panics
    /// When the buffer is shorter than `data_len + 7` bytes (the telegram with its CRC).
    pub fn set_header(&mut self, address: u8, command: u8, data_len: usize) {
        let bytes = self.buffer.as_mut();
        let len_field = (data_len + 1) as u16;
        assert!(
            bytes.len() >= telegram_len(len_field),
            "telegram buffer too small"
        );
        bytes[field::STX] = STX;
        bytes[field::ADDRESS] = address;
        bytes[field::LENGTH].copy_from_slice(&len_field.to_le_bytes());
        bytes[field::COMMAND] = command;
    }

    /// Sets the address byte.
    ///
    /// # Panics
    /// When the buffer is shorter than the header (5 bytes).
    pub fn set_address(&mut self, address: u8) {
        self.buffer.as_mut()[field::ADDRESS] = address;
    }

    /// Sets the length field.
    ///
    /// # Panics
    /// When the buffer is shorter than the header (5 bytes).
    pub fn set_length(&mut self, len_field: u16) {
        self.buffer.as_mut()[field::LENGTH].copy_from_slice(&len_field.to_le_bytes());
    }

    /// Sets the command or reply code.
    ///
    /// # Panics
    /// When the buffer is shorter than the header (5 bytes).
    pub fn set_command(&mut self, command: u8) {
        self.buffer.as_mut()[field::COMMAND] = command;
    }

    /// The data bytes (after the command byte, up to the CRC), mutable.
    ///
    /// # Panics
    /// When the buffer is shorter than the length field announces.
    pub fn data_mut(&mut self) -> &mut [u8] {
        let end = self.crc_start();
        &mut self.buffer.as_mut()[field::DATA_START..end]
    }

    /// Computes the checksum over STX … last data byte and writes it.
    ///
    /// # Panics
    /// When the buffer is shorter than the length field announces.
    pub fn fill_crc(&mut self) {
        let start = self.crc_start();
        let crc = crc16(self.covered());
        self.buffer.as_mut()[start..start + 2].copy_from_slice(&crc.to_le_bytes());
    }
}

impl<T: AsRef<[u8]>> AsRef<[u8]> for Telegram<T> {
    fn as_ref(&self) -> &[u8] {
        self.buffer.as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sick::test_data::{EXAMPLE_TELEGRAMS, hex};

    /// Reply `A0h` to a mode switch: result 00h (switched), status 10h (§11).
    static TELEGRAM_BYTES: [u8; 9] = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];

    #[test]
    fn test_deconstruct() {
        let telegram = Telegram::new_checked(&TELEGRAM_BYTES[..]).unwrap();
        assert_eq!(telegram.address(), 0x80);
        assert_eq!(telegram.length(), 3);
        assert_eq!(telegram.total_len(), 9);
        assert_eq!(telegram.command(), 0xA0);
        assert_eq!(telegram.data(), &[0x00, 0x10]);
        assert_eq!(telegram.reply_data(), &[0x00]);
        assert_eq!(telegram.status(), Some(0x10));
        assert_eq!(telegram.crc(), 0x0A16);
        assert_eq!(telegram.check_crc(), Ok(()));
    }

    #[test]
    fn test_construct() {
        let mut bytes = [0xAAu8; 9];
        let mut telegram = Telegram::new_unchecked(&mut bytes[..]);
        telegram.set_header(0x80, 0xA0, 2);
        telegram.data_mut().copy_from_slice(&[0x00, 0x10]);
        telegram.fill_crc();
        assert_eq!(bytes, TELEGRAM_BYTES);
    }

    #[test]
    fn setters_round_trip() {
        let mut bytes = TELEGRAM_BYTES;
        let mut telegram = Telegram::new_unchecked(&mut bytes[..]);
        telegram.set_address(0x81);
        telegram.set_command(0xA1);
        telegram.set_length(3);
        telegram.fill_crc();
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!((telegram.address(), telegram.command()), (0x81, 0xA1));
        assert_eq!(telegram.check_crc(), Ok(()));
    }

    #[test]
    fn examples_check() {
        for text in EXAMPLE_TELEGRAMS {
            let bytes = hex(text);
            let telegram = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(telegram.check_crc(), Ok(()), "{text}");
            assert_eq!(telegram.total_len(), bytes.len());
        }
    }

    #[test]
    fn bad_crc_detected() {
        let mut bytes = TELEGRAM_BYTES;
        bytes[5] ^= 0x01;
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(telegram.check_crc(), Err(Error::BadCrc));
    }

    #[test]
    fn bad_stx_detected() {
        let mut bytes = TELEGRAM_BYTES;
        bytes[0] = 0x03;
        assert_eq!(Telegram::new_checked(&bytes[..]), Err(Error::BadStx));
    }

    #[test]
    fn longer_buffer_is_accepted() {
        let mut bytes = TELEGRAM_BYTES.to_vec();
        bytes.extend_from_slice(&[0x06, 0x02]);
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(telegram.as_bytes(), &TELEGRAM_BYTES);
        assert_eq!(telegram.check_crc(), Ok(()));
    }

    #[test]
    fn test_impossible_len() {
        for len in 0..TELEGRAM_BYTES.len() {
            assert_eq!(
                Telegram::new_checked(&TELEGRAM_BYTES[..len]),
                Err(Error::Truncated),
                "{len}"
            );
        }
        let mut bytes = [0u8; 16];
        bytes[0] = STX;
        bytes[2..4].copy_from_slice(&0u16.to_le_bytes());
        assert_eq!(Telegram::new_checked(&bytes[..]), Err(Error::BadLength));
        bytes[2..4].copy_from_slice(&(MAX_LEN_FIELD + 1).to_le_bytes());
        assert_eq!(Telegram::new_checked(&bytes[..]), Err(Error::BadLength));
        let big = [0u8; MAX_TELEGRAM_LEN];
        let mut big = big;
        big[0] = STX;
        big[2..4].copy_from_slice(&MAX_LEN_FIELD.to_le_bytes());
        assert!(Telegram::new_checked(&big[..]).is_ok());
        assert_eq!(
            Telegram::new_checked(&big[..MAX_TELEGRAM_LEN - 1]),
            Err(Error::Truncated)
        );
    }

    #[test]
    fn constants() {
        assert_eq!(MAX_TELEGRAM_LEN, 814);
        assert_eq!(telegram_len(726), 732);
    }
}
