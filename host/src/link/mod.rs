//! The board link on the host side.
//!
//! * [`clock_sync::ClockSync`]: maps the board's monotonic microseconds to host seconds from
//!   time-sync round trips.
//! * [`reader::LinkReader`]: turns a byte stream from the board into messages and keeps the
//!   accounting (lost frames, CRC errors, skipped kinds).

pub mod clock_sync;
pub mod reader;

pub use clock_sync::ClockSync;
pub use reader::{LinkReader, LinkStats};
