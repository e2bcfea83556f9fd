//! Laser scans, as the SICK LMS2xx measured them.

use serde::{Deserialize, Serialize};

/// The most range words one LMS2xx telegram carries (100° at 0.25°).
pub const MAX_SCAN_VALUES: usize = 401;

/// The unit of the distance bits of a range word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum RangeUnit {
    /// Centimetres (80 m modes).
    Cm,
    /// Millimetres (8/16/32 m modes).
    Mm,
}

/// One complete scan from the laser.
///
/// The range words are forwarded exactly as the sensor sent them, flag bits included: which
/// bits are distance and which are flags depends on the sensor's measuring mode, which the
/// host knows from its configuration.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct ScanMsg {
    /// Board time (µs since boot) when the telegram's first byte arrived.
    pub stamp_us: u64,
    /// Scans forwarded by the board since boot (gaps mean scans the board dropped).
    pub scan_counter: u32,
    /// Angle of the first value, in hundredths of a degree, in the sensor's 0°–180° frame
    /// (0 for the 180° variant, 4 000 for the 100° variant).
    pub start_angle_cdeg: u16,
    /// Angle between two values, in hundredths of a degree (25, 50 or 100).
    pub step_angle_cdeg: u16,
    /// Unit of the distance bits.
    pub unit: RangeUnit,
    /// The count word of the telegram as sent.
    pub count_word: u16,
    /// The raw 16-bit range words in ascending angle order.
    #[cfg_attr(feature = "schemars", schemars(with = "Vec<u16>"))]
    pub values: heapless::Vec<u16, MAX_SCAN_VALUES>,
    /// The telegram's status byte.
    pub status: u8,
    /// The sensor's own (scan index, telegram index) when real-time indices are enabled.
    pub sensor_indices: Option<(u8, u8)>,
}
