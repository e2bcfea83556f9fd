//! The link and sensor counters of one board link, as the live view shows them.

use serde::{Deserialize, Serialize};

/// The link and sensor counters shown live.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct LinkCounters {
    /// Frames decoded.
    pub frames: u64,
    /// Frames lost: gaps in the board's sequence numbers.
    pub frames_lost: u64,
    /// Frames whose CRC failed.
    pub crc_errors: u64,
    /// Scan telegrams received (one frame each).
    pub telegrams: u64,
    /// Telegrams the board reported as failing their CRC on the laser line.
    pub telegram_crc_errors: u64,
    /// GPS fixes received.
    pub gps_fixes: u64,
    /// The last fix's quality: 0 none, 1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float.
    pub gps_fix_quality: u8,
    /// Satellites used in the last fix.
    pub gps_satellites: u8,
    /// Times the serial port was reopened.
    pub reconnects: u64,
    /// Times the board restarted its clock (see [`super::LinkSession`]); 0 from a daemon that
    /// does not report it.
    #[serde(default)]
    pub board_restarts: u64,
    /// Whether the board clock is synchronised to host time.
    pub clock_synchronised: bool,
}
