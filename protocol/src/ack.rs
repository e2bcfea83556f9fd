//! Acknowledgements of host commands.

use serde::{Deserialize, Serialize};

/// What the board did with a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum AckResult {
    /// Accepted and being carried out.
    Accepted,
    /// Understood but not possible (an unsupported laser variant, for instance).
    Rejected,
    /// The board is busy with an earlier command; try again.
    Busy,
}

/// The answer to one host command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct AckMsg {
    /// Sequence number of the command frame.
    pub command_seq: u16,
    /// Kind byte of the command frame.
    pub command_kind: u8,
    /// The outcome.
    pub result: AckResult,
    /// Board time (µs since boot) when the command was received.
    pub board_time_us: u64,
    /// For a time-sync ping: the host time it carried; otherwise 0.
    pub host_time_us: u64,
}
