//! The LMS2xx configuration block ("configuration part 1"), read with `74h` and written with
//! `77h` (protocol notes §6.3; Telegram Listing "Command 77h").
//!
//! The block is 34 bytes on current firmware and 32 on old firmware. Only bytes 4–6 have a
//! meaning for this code (availability flags, measuring mode, unit); every other byte is
//! carried unchanged, so that a read-modify-write never alters settings it does not know.

use protocol::RangeUnit;

use super::error::{Error, Result};
use protocol::MeasuringMode;

/// Size of the configuration block on current firmware.
pub const CONFIG_LEN: usize = 34;
/// Size of the configuration block on old firmware.
pub const OLD_CONFIG_LEN: usize = 32;

mod field {
    /// Availability flags; bit 1 appends the real-time indices to `B0h`.
    pub const AVAILABILITY: usize = 4;
    pub const REAL_TIME_INDICES: u8 = 0x02;
    pub const MEASURING_MODE: usize = 5;
    pub const UNIT: usize = 6;
    pub const UNIT_CM: u8 = 0x00;
    pub const UNIT_MM: u8 = 0x01;
}

/// A configuration block as the sensor sent it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigBlock {
    bytes: [u8; CONFIG_LEN],
    len: u8,
}

impl ConfigBlock {
    /// Wraps a block of 34 (or 32) bytes.
    ///
    /// # Errors
    /// [`Error::Malformed`] for any other length.
    pub fn from_bytes(block: &[u8]) -> Result<ConfigBlock> {
        if block.len() != CONFIG_LEN && block.len() != OLD_CONFIG_LEN {
            return Err(Error::Malformed);
        }
        let mut bytes = [0u8; CONFIG_LEN];
        bytes[..block.len()].copy_from_slice(block);
        Ok(ConfigBlock {
            bytes,
            len: block.len() as u8,
        })
    }

    /// The block's bytes, 34 or 32 of them.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// The measuring mode (byte 5).
    pub fn measuring_mode(&self) -> MeasuringMode {
        MeasuringMode(self.bytes[field::MEASURING_MODE])
    }

    /// Sets the measuring mode (byte 5).
    pub fn set_measuring_mode(&mut self, mode: MeasuringMode) {
        self.bytes[field::MEASURING_MODE] = mode.0;
    }

    /// The unit of the range words (byte 6); `None` for an undocumented value.
    pub fn unit(&self) -> Option<RangeUnit> {
        match self.bytes[field::UNIT] {
            field::UNIT_CM => Some(RangeUnit::Cm),
            field::UNIT_MM => Some(RangeUnit::Mm),
            _ => None,
        }
    }

    /// Sets the unit of the range words (byte 6).
    pub fn set_unit(&mut self, unit: RangeUnit) {
        self.bytes[field::UNIT] = match unit {
            RangeUnit::Cm => field::UNIT_CM,
            RangeUnit::Mm => field::UNIT_MM,
        };
    }

    /// Whether `B0h` telegrams carry the real-time indices (byte 4, bit 1).
    pub fn real_time_indices(&self) -> bool {
        self.bytes[field::AVAILABILITY] & field::REAL_TIME_INDICES != 0
    }

    /// Enables or disables the real-time indices (byte 4, bit 1).
    pub fn set_real_time_indices(&mut self, enabled: bool) {
        if enabled {
            self.bytes[field::AVAILABILITY] |= field::REAL_TIME_INDICES;
        } else {
            self.bytes[field::AVAILABILITY] &= !field::REAL_TIME_INDICES;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sick::test_data::hex;

    /// The block of a real LMS200 (`S18063`, firmware V02.19) in the AtlasBuggy sessions.
    fn real_block() -> Vec<u8> {
        hex("00 00 70 00 00 04 01 00 00 02 02 00 00 00 00 00 00 00 \
             00 00 00 00 00 00 00 00 00 00 00 00 00 00 02 00")
    }

    #[test]
    fn real_block_fields() {
        let block = ConfigBlock::from_bytes(&real_block()).unwrap();
        assert_eq!(block.measuring_mode(), MeasuringMode(0x04));
        assert_eq!(block.unit(), Some(RangeUnit::Mm));
        assert!(!block.real_time_indices());
        assert_eq!(block.as_bytes(), &real_block()[..]);
    }

    #[test]
    fn modify_keeps_other_bytes() {
        let mut block = ConfigBlock::from_bytes(&real_block()).unwrap();
        block.set_unit(RangeUnit::Cm);
        block.set_real_time_indices(true);
        let mut expected = real_block();
        expected[6] = 0;
        expected[4] = 0x02;
        assert_eq!(block.as_bytes(), &expected[..]);
        block.set_real_time_indices(false);
        block.set_measuring_mode(MeasuringMode(0x06));
        assert_eq!(block.measuring_mode(), MeasuringMode(0x06));
        assert_eq!(block.as_bytes()[4], 0);
    }

    #[test]
    fn old_firmware_block() {
        let block = ConfigBlock::from_bytes(&real_block()[..32]).unwrap();
        assert_eq!(block.as_bytes().len(), 32);
        assert_eq!(
            ConfigBlock::from_bytes(&real_block()[..33]),
            Err(Error::Malformed)
        );
    }
}
