//! hil-sim: runs the firmware logic on the host against real captures and emulated sensors.

pub mod decode_nmea;
pub mod decode_sick;
pub mod pty;
