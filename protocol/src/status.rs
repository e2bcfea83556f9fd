//! Device status: per-link counters and the state of each sensor.

use serde::{Deserialize, Serialize};

/// Counters for one serial link. All counts are since boot and wrap at 2³².
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct LinkCounters {
    /// Bytes received.
    pub bytes: u32,
    /// Telegrams, sentences or frames accepted.
    pub telegrams: u32,
    /// Checksum failures.
    pub crc_errors: u32,
    /// Times the receiver dropped a partial unit and searched for the next start.
    pub resyncs: u32,
    /// UART receive overruns (bytes lost in hardware).
    pub uart_overruns: u32,
    /// Whole frames dropped because the outgoing queue was full.
    pub dropped_frames: u32,
    /// Units the sender sent that were not accepted, as far as the receiver can tell (laser:
    /// scan periods between valid scans, or in which bytes arrived but no valid scan; GPS:
    /// lines rejected).
    pub missed: u32,
}

/// Where the laser bring-up stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum LaserState {
    /// Looking for the baud rate the sensor talks at.
    DetectingBaud,
    /// Setting variant and units.
    Configuring,
    /// Switching the sensor and the UART to the streaming baud rate.
    SwitchingBaud,
    /// Configured and streaming scans.
    Streaming,
    /// Configured, streaming stopped on request.
    Idle,
    /// Bring-up failed after all retries; it starts again after a pause.
    Failed,
}

/// What the GPS receiver is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum GpsState {
    /// No valid sentence received recently.
    Silent,
    /// Sentences arrive but without a fix.
    NoFix,
    /// A valid fix.
    Fix,
}

/// A status report, sent every second and on request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct StatusMsg {
    /// Board time (µs since boot).
    pub uptime_us: u64,
    /// Laser link counters.
    pub laser: LinkCounters,
    /// GPS link counters.
    pub gps: LinkCounters,
    /// Host link counters: `bytes` and `telegrams` count frames sent to the host,
    /// `dropped_frames` those that could not be sent, and the error counters what arrived
    /// from the host.
    pub host: LinkCounters,
    /// Laser bring-up state.
    pub laser_state: LaserState,
    /// Baud rate the laser UART runs at.
    pub laser_baud: u32,
    /// GPS state.
    pub gps_state: GpsState,
    /// PPS edges seen (0 when the pin is not wired).
    pub pps_edges: u32,
}
