//! The sensor interface board's logic, free of any HAL: it runs on the STM32 board, on the
//! host under embassy's std executor (hil-sim), and in unit tests.
//!
//! * [`sick`]: SICK LMS2xx telegrams (CRC, view, scan representation), the byte-level
//!   receiver that resynchronises after errors, and the bring-up state machine.
//! * [`nmea`]: NMEA 0183 sentences (checksum, GGA/RMC/GLL/GSA/VTG/GST) and exact lat/lon.
//! * [`link`]: the host link: framing outgoing messages, dropping whole frames when congested,
//!   decoding host commands.
//! * [`tasks`]: the async tasks the board spawns, generic over `embedded-io-async` ports.

#![cfg_attr(not(test), no_std)]

pub mod link;
pub mod nmea;
pub mod sick;
pub mod tasks;
