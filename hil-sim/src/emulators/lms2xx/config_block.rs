//! The configuration block the emulated LMS2xx keeps in EEPROM (`74h` reads it, `77h`
//! writes it): its state as delivered, which written blocks the sensor accepts, and how a
//! written block replaces the stored one.

use firmware::sick::ConfigBlock;

/// Measuring modes the sensor accepts in a configuration write.
const KNOWN_MEASURING_MODES: [u8; 9] = [0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F, 0x3F];

/// The configuration block of an LMS200 as delivered: no blanking, stop threshold `46h`,
/// default measuring mode, cm.
pub(super) fn default_config() -> ConfigBlock {
    let mut block = [0u8; firmware::sick::config::CONFIG_LEN];
    block[2] = 0x46;
    // A 34-byte block is always valid.
    ConfigBlock::from_bytes(&block).unwrap_or_else(|_| unreachable!())
}

/// Whether a written block holds a unit and measuring mode the sensor knows.
pub(super) fn is_valid_config(block: &ConfigBlock) -> bool {
    block.unit().is_some() && KNOWN_MEASURING_MODES.contains(&block.measuring_mode().0)
}

/// `current` with its first bytes replaced by `written` (an old-firmware block has 32).
pub(super) fn merge_config(current: ConfigBlock, written: &ConfigBlock) -> ConfigBlock {
    let mut bytes = [0u8; firmware::sick::config::CONFIG_LEN];
    let current = current.as_bytes();
    bytes[..current.len()].copy_from_slice(current);
    let written = written.as_bytes();
    bytes[..written.len()].copy_from_slice(written);
    ConfigBlock::from_bytes(&bytes).unwrap_or_else(|_| unreachable!())
}
