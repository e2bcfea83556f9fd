//! Heartbeats carry the board clock so the host can map board time to its own.

use serde::{Deserialize, Serialize};

/// The board's monotonic clock at the moment the frame was queued.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct HeartbeatMsg {
    /// Board time (µs since boot).
    pub uptime_us: u64,
}
