//! The board link on the host side.
//!
//! * [`clock_sync::ClockSync`]: maps the board's monotonic microseconds to host seconds from
//!   time-sync round trips.
//! * [`reader::LinkReader`]: turns a byte stream from the board into messages and keeps the
//!   accounting (lost frames, CRC errors, skipped kinds).
//! * [`time_sync::TimeSync`]: the pings that feed the clock mapping.

pub mod clock_sync;
pub mod reader;
pub mod time_sync;

pub use clock_sync::ClockSync;
pub use reader::{LinkReader, LinkStats};
pub use time_sync::TimeSync;
