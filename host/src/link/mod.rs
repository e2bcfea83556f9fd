//! The board link on the host side.
//!
//! * [`board_time_order::BoardTimeOrder`]: holds events briefly to hand them on in the order
//!   the board stamped them, not the order they arrived in.
//! * [`clock_sync::ClockSync`]: maps the board's monotonic microseconds to host seconds from
//!   time-sync round trips.
//! * [`laser_scan::LaserScan`]: a scan message's range words in metres, in the sensor frame.
//! * [`GpsFix`]: a fix report in degrees, metres and radians, converted once at the edge.
//! * [`counters::LinkCounters`]: what one link has received and lost, for the live view.
//! * [`session::LinkSession`]: one link as the pipelines see it: bytes in, time-synced
//!   [`SensorEvent`]s in SI units out, the same for the live run and the replay of a
//!   recording.
//! * [`reader::LinkReader`]: turns a byte stream from the board into messages and keeps the
//!   accounting (lost frames, CRC errors, skipped kinds).
//! * [`time_sync::TimeSync`]: the pings that feed the clock mapping.

pub mod board_time_order;
pub mod clock_sync;
mod counters;
mod gps_fix;
pub mod laser_scan;
pub mod reader;
pub mod session;
pub mod time_sync;

pub use board_time_order::BoardTimeOrder;
pub use clock_sync::ClockSync;
pub use counters::LinkCounters;
pub use gps_fix::{ErrorEllipse, GpsFix};
pub use laser_scan::LaserScan;
pub use reader::{LinkReader, LinkStats};
pub use session::{Decoded, LinkSession, SensorEvent};
pub use time_sync::TimeSync;
