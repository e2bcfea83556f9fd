//! The wire protocol between the sensor interface board and the robot computer.
//!
//! Every message travels in one frame:
//!
//! ```text
//! +---------+------+---------+------------------+-----------+
//! | version | kind | seq(LE) | postcard payload | CRC-32 LE |   <- raw frame (`Frame`)
//! |   u8    |  u8  |   u16   |   0..=MAX bytes  |    u32    |
//! +---------+------+---------+------------------+-----------+
//!            COBS-encoded, then terminated by one 0x00 byte   <- on the wire
//! ```
//!
//! * [`Frame`] is a zero-copy view over the raw (COBS-decoded) bytes with accessors for each
//!   header field, in the style of smoltcp's `wire` module.
//! * [`Message`] is the high-level representation (one variant per [`Kind`]); it parses from and
//!   emits into a [`Frame`].
//! * [`Encoder`] turns messages into wire bytes and numbers them; [`Decoder`] accepts a byte
//!   stream, finds frame boundaries, checks the CRC, the version and the kind, counts every
//!   lost, corrupt or skipped frame in [`DecoderStats`] and never panics on any input.
//!
//! Sequence numbers are per direction: the board numbers what it sends, the host numbers its
//! commands. A gap seen by the receiver is a lost frame.
//!
//! A frame is at most [`MAX_FRAME_LEN`] bytes raw and [`MAX_WIRE_LEN`] bytes on the wire
//! (delimiter included), enough for the largest SICK LMS2xx scan (401 range words).
//!
//! With the `schemars` feature every message type implements `schemars::JsonSchema`, so the
//! host can describe the JSON form of each message (the channels of its MCAP recordings).

#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]

mod ack;
mod codec;
mod command;
mod frame;
mod gps;
mod heartbeat;
mod kind;
mod log;
mod message;
mod nmea;
mod pps;
mod range;
mod scan;
mod seq;
mod status;

pub use ack::{AckMsg, AckResult};
pub use codec::{DecodeError, Decoder, DecoderStats, Encoder, Received};
pub use command::{
    AngularResolution, ConfigureLaserCmd, RequestStatusCmd, ScanAngle, SetStreamingCmd,
    TimeSyncPingCmd,
};
pub use frame::{
    Error as FrameError, FRAME_OVERHEAD, Frame, Header, MAX_FRAME_LEN, MAX_PAYLOAD_LEN,
    MAX_WIRE_LEN,
};
pub use gps::{Date, FixQuality, FixSource, GpsFixMsg, GstSigmas, Position, TimeOfDay};
pub use heartbeat::HeartbeatMsg;
pub use kind::{Direction, Kind};
pub use log::{LogLevel, LogMsg, MAX_LOG_TEXT_LEN};
pub use message::{Error as MessageError, Message};
pub use nmea::{MAX_NMEA_LEN, NmeaMsg};
pub use pps::PpsMsg;
pub use range::{MeasuringMode, RangeDecoder};
pub use scan::{MAX_SCAN_VALUES, RangeUnit, ScanMsg};
pub use seq::SeqTracker;
pub use status::{GpsState, LaserState, LinkCounters, StatusMsg};

/// The protocol version this crate speaks. Frames with another version are skipped and counted.
pub const PROTOCOL_VERSION: u8 = 2;
