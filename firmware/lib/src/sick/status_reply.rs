//! The status reply `B1h` to request `31h` (protocol notes §6.4; Telegram Listing
//! "Response B1h").
//!
//! The reply carries 152 data bytes and the status byte (`L = 9Ah`). Only the fields drivers
//! rely on are decoded, at the offsets sicktoolbox uses (counted from the `B1h` byte, so
//! data offset = listed offset − 1): firmware version 1–7, operating mode 8, device status
//! 9, measuring mode 102, scan angle 107–108, angular resolution 109–110, baud code
//! 116–117, permanent-baud flag 119, address 120, unit 122. These offsets were checked
//! against real replies of an LMS200 with firmware V02.19. Every access is bounds-checked:
//! a shorter reply is rejected, never indexed out of range.

use protocol::RangeUnit;

use super::command::LmsBaud;
use super::error::{Error, Result};
use protocol::MeasuringMode;

mod field {
    pub type Field = core::ops::Range<usize>;

    /// Offsets inside the reply data (after the `B1h` byte).
    pub const VERSION: Field = 0..7;
    pub const OPERATING_MODE: usize = 7;
    pub const DEVICE_STATUS: usize = 8;
    pub const MEASURING_MODE: usize = 101;
    pub const ANGLE: Field = 106..108;
    pub const RESOLUTION: Field = 108..110;
    pub const BAUD: Field = 115..117;
    pub const PERMANENT_BAUD: usize = 118;
    pub const ADDRESS: usize = 119;
    pub const UNIT: usize = 121;
    /// The reply must reach the unit byte.
    pub const MIN_LEN: usize = UNIT + 1;
}

/// The `20h` sub-command the status reports while the sensor streams every scan.
pub const OPERATING_MODE_STREAMING: u8 = 0x24;
/// The `20h` sub-command the status reports while values are sent only on request.
pub const OPERATING_MODE_ON_REQUEST: u8 = 0x25;

/// The decoded fields of a `B1h` status reply.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StatusReply {
    /// Firmware version, ASCII (e.g. `V02.19 `).
    pub version: [u8; 7],
    /// Operating mode: the `20h` sub-command in force (`24h` streaming, `25h` on request).
    pub operating_mode: u8,
    /// Device status: 0 = no error.
    pub device_status: u8,
    /// Measuring mode (how range words are coded).
    pub measuring_mode: MeasuringMode,
    /// Scan angle in degrees.
    pub angle_deg: u16,
    /// Angular resolution in hundredths of a degree.
    pub resolution_cdeg: u16,
    /// Baud code (`8001h` = 500 000 … `8067h` = 9 600).
    pub baud_code: u16,
    /// Whether the baud rate is kept over a power cycle.
    pub permanent_baud: bool,
    /// Device address.
    pub address: u8,
    /// Raw unit byte: 0 = cm, 1 = mm.
    pub unit_byte: u8,
    /// The telegram's status byte.
    pub status: u8,
}

impl StatusReply {
    /// Data bytes of a current-firmware `B1h` reply, without the status byte.
    pub const DATA_LEN: usize = 152;

    /// Decodes the reply data (without code and status byte).
    ///
    /// # Errors
    /// [`Error::Malformed`] when the data are too short to hold the unit byte.
    pub fn parse_data(data: &[u8], status: u8) -> Result<StatusReply> {
        if data.len() < field::MIN_LEN {
            return Err(Error::Malformed);
        }
        let word = |range: core::ops::Range<usize>| {
            u16::from_le_bytes([data[range.start], data[range.start + 1]])
        };
        let mut version = [0u8; 7];
        version.copy_from_slice(&data[field::VERSION]);
        Ok(StatusReply {
            version,
            operating_mode: data[field::OPERATING_MODE],
            device_status: data[field::DEVICE_STATUS],
            measuring_mode: MeasuringMode(data[field::MEASURING_MODE]),
            angle_deg: word(field::ANGLE),
            resolution_cdeg: word(field::RESOLUTION),
            baud_code: word(field::BAUD),
            permanent_baud: data[field::PERMANENT_BAUD] != 0,
            address: data[field::ADDRESS],
            unit_byte: data[field::UNIT],
            status,
        })
    }

    /// Writes the decoded fields into `data` (the [`Self::DATA_LEN`] bytes between code and
    /// status); bytes without a decoded field are written as zero.
    ///
    /// # Panics
    /// When `data` is shorter than the unit byte's offset + 1.
    pub fn emit_data(&self, data: &mut [u8]) {
        data.fill(0);
        data[field::VERSION].copy_from_slice(&self.version);
        data[field::OPERATING_MODE] = self.operating_mode;
        data[field::DEVICE_STATUS] = self.device_status;
        data[field::MEASURING_MODE] = self.measuring_mode.0;
        data[field::ANGLE].copy_from_slice(&self.angle_deg.to_le_bytes());
        data[field::RESOLUTION].copy_from_slice(&self.resolution_cdeg.to_le_bytes());
        data[field::BAUD].copy_from_slice(&self.baud_code.to_le_bytes());
        data[field::PERMANENT_BAUD] = u8::from(self.permanent_baud);
        data[field::ADDRESS] = self.address;
        data[field::UNIT] = self.unit_byte;
    }

    /// The baud rate the sensor reports, if the code is known.
    pub fn baud(&self) -> Option<LmsBaud> {
        LmsBaud::from_status_code(self.baud_code)
    }

    /// The unit of the range words, if the byte is known.
    pub fn unit(&self) -> Option<RangeUnit> {
        match self.unit_byte {
            0 => Some(RangeUnit::Cm),
            1 => Some(RangeUnit::Mm),
            _ => None,
        }
    }

    /// Whether the sensor streams every scan.
    pub fn is_streaming(&self) -> bool {
        self.operating_mode == OPERATING_MODE_STREAMING
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sick::reply::Reply;
    use crate::sick::telegram::Telegram;
    use crate::sick::test_data::hex;

    /// A real `B1h` of an LMS200 (S18063, V02.19) from the AtlasBuggy sessions
    /// (`2017_Aug_04_23-25-00.lms-to-host.bin`, the first status reply).
    fn real_b1() -> Vec<u8> {
        hex(
            "02 80 9a 00 b1 56 30 32 2e 31 39 20 25 00 30 35 32 37 30 34 39 37 00 92 01 00 00 1a \
             01 00 00 de 01 00 00 9a 02 00 00 77 01 10 01 c0 01 46 01 b0 01 52 02 67 01 ee 01 d8 \
             01 d8 01 94 02 8b 03 65 01 65 01 b2 01 b2 01 94 00 01 00 01 00 02 00 00 00 01 00 00 \
             00 00 00 9c 00 25 01 0c 0b 26 01 80 0a ff 01 ff 01 00 02 00 02 08 04 00 03 00 02 b4 \
             00 32 00 02 00 00 00 01 19 80 02 00 00 01 01 01 56 30 32 2e 30 32 20 c8 9c 07 00 f8 \
             bf 1e 00 1c a2 07 00 c4 c5 1e 00 52 06 8e 06 58 02 10 00 00",
        )
    }

    #[test]
    fn real_status_reply() {
        let mut bytes = real_b1();
        let mut telegram = Telegram::new_unchecked(&mut bytes[..]);
        telegram.fill_crc();
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(telegram.length(), 0x9A);
        let Ok(Reply::Status(status)) = Reply::parse(&telegram) else {
            panic!()
        };
        assert_eq!(&status.version, b"V02.19 ");
        assert_eq!(status.operating_mode, OPERATING_MODE_ON_REQUEST);
        assert!(!status.is_streaming());
        assert_eq!(status.device_status, 0);
        assert_eq!(status.measuring_mode, MeasuringMode(0x04));
        assert_eq!((status.angle_deg, status.resolution_cdeg), (180, 50));
        assert_eq!(status.baud(), Some(LmsBaud::B38400));
        assert!(!status.permanent_baud);
        assert_eq!(status.address, 0);
        assert_eq!(status.unit(), Some(RangeUnit::Mm));
        assert_eq!(status.status, 0x10);
    }

    #[test]
    fn emit_round_trip() {
        let bytes = real_b1();
        let status = StatusReply::parse_data(&bytes[5..5 + 152], 0x10).unwrap();
        let mut data = [0xEEu8; StatusReply::DATA_LEN];
        status.emit_data(&mut data);
        assert_eq!(StatusReply::parse_data(&data, 0x10).unwrap(), status);
    }

    #[test]
    fn test_impossible_len() {
        let data = [0u8; 121];
        assert_eq!(StatusReply::parse_data(&data, 0x10), Err(Error::Malformed));
        assert!(StatusReply::parse_data(&[0u8; 122], 0x10).is_ok());
    }
}
