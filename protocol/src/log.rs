//! Log events from the board.

use serde::{Deserialize, Serialize};

/// The longest log text carried.
pub const MAX_LOG_TEXT_LEN: usize = 64;

/// Severity of a log event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum LogLevel {
    /// Detail for debugging.
    Debug,
    /// Normal operation.
    Info,
    /// Something recoverable went wrong.
    Warn,
    /// Something failed.
    Error,
}

/// One log event.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct LogMsg {
    /// Board time (µs since boot).
    pub stamp_us: u64,
    /// Severity.
    pub level: LogLevel,
    /// The text, cut at [`MAX_LOG_TEXT_LEN`] bytes.
    #[cfg_attr(feature = "schemars", schemars(with = "String"))]
    pub text: heapless::String<MAX_LOG_TEXT_LEN>,
}
