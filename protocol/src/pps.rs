//! GPS pulse-per-second edges, stamped by the board.

use serde::{Deserialize, Serialize};

/// One rising edge of the receiver's PPS output: the start of a UTC second, in board time.
/// The host pairs it with the fix whose time names that second.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct PpsMsg {
    /// Board time (µs since boot) of the edge, taken in the pin's interrupt.
    pub edge_us: u64,
    /// Edges seen since boot, this one included.
    pub count: u32,
}
