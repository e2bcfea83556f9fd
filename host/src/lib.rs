//! Host software for the robot computer: the board link and its time base.
//!
//! * [`link`]: reading the board's frames from a serial port, counting every lost frame,
//!   and mapping board time to host time.
//! * [`scan_match`]: aligning laser scans by raster overlap, a reference and a fast exact matcher.

pub mod link;
pub mod scan_match;
