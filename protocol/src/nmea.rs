//! Raw NMEA sentences passed through for recording.

use serde::{Deserialize, Serialize};

/// The longest sentence the board accepts and forwards, `$` through the checksum, without
/// the line ending. NMEA allows 82 characters with CR LF; real receivers send up to about
/// 120, so the bound is set above that.
pub const MAX_NMEA_LEN: usize = 126;

/// One sentence exactly as received (without CR LF).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct NmeaMsg {
    /// Board time (µs since boot) when the `$` arrived.
    pub stamp_us: u64,
    /// The sentence text.
    #[cfg_attr(feature = "schemars", schemars(with = "String"))]
    pub sentence: heapless::String<MAX_NMEA_LEN>,
}
