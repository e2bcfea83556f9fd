//! Sensor emulators: pure state machines that turn time, host bytes and a world into the
//! bytes a real sensor would send, built only with the firmware's own `emit` code (so the
//! emulators and the firmware's parsers cannot drift apart). No emulator reads a clock or
//! touches a port: [`crate::devices`] connects them to ptys.
//!
//! * [`Lms2xx`] ([`lms2xx`]): a SICK LMS200 over RS-232/RS-422, byte-exact, with its
//!   timing, baud switching, streaming and scan skipping; its scan geometry is
//!   [`Variant`] ([`lms_variant`]) and its measurement [`RangeModel`] ([`range_model`]);
//!   it can stream recorded scans instead ([`ScanSource`], fed by [`crate::replay`]).
//! * [`GpsEmulator`] ([`gps`]): an NMEA 0183 GNSS receiver with noise, outages and no-fix
//!   periods; [`utc`] turns its clock into UTC date and time.
//! * [`TxLine`] ([`tx_line`]): when each byte leaves a UART; [`garble`] ([`baud_mismatch`]):
//!   what a receiver at the wrong baud rate hears.

pub mod baud_mismatch;
pub mod gps;
pub mod lms2xx;
pub mod lms_variant;
pub mod range_model;
pub mod tx_line;
pub mod utc;

pub use baud_mismatch::garble;
pub use gps::{GpsCounters, GpsEmulator, GpsEmulatorOptions, GpsTruth, Trajectory};
pub use lms_variant::Variant;
pub use lms2xx::{
    BeamMapping, Lms2xx, Lms2xxCounters, Lms2xxOptions, Lms2xxTiming, RecordedScan, ReplayPace,
    ReplayProgress, ScanSource, StreamStart, recorded_words,
};
pub use range_model::RangeModel;
pub use tx_line::{TxLine, TxRun};
