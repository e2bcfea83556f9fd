//! SICK LMS2xx (LMS200/211/221/291) over RS-232/RS-422: everything the board needs to bring the
//! laser up and stream its scans, free of any HAL (protocol notes in
//! `shared/protocols/sick-lms2xx.md`; SICK *Telegram Listing LMS2xx*).
//!
//! * [`crc`]: the SICK checksum (§3), incremental ([`SickCrc`]) or over a slice ([`crc16`]).
//! * [`telegram`]: the zero-copy [`Telegram`] view (§2) and the framing constants.
//! * [`scan`]: [`ScanRepr`], the measured-value reply `B0h` (§7), and its conversion to the
//!   host's [`protocol::ScanMsg`]; range words decode with [`protocol::RangeDecoder`] (§7.3).
//! * [`command`]: host requests ([`Request`], §6); [`reply`] and [`status_reply`]: the
//!   sensor's replies ([`Reply`], [`StatusReply`]); [`config`]: the configuration block.
//! * [`receiver`]: the byte-level [`Receiver`] that validates telegrams, recognises ACK/NAK
//!   and resynchronises after errors (§10); [`slots`]: [`ScanSlots`], which counts the scans
//!   a streaming sensor sent that did not arrive intact.
//! * [`bringup`]: the sans-IO [`BringUp`] state machine: baud detection, configuration,
//!   variant, baud switch, streaming (§6.5), with retries and recovery.
//!
//! Data flow on the board: UART bytes → [`Receiver::push`] → [`Event`]s → `B0h` telegrams to
//! [`ScanRepr::parse`] → [`ScanRepr::to_msg`] → host link; every event also goes to
//! [`BringUp::handle`], whose [`Action`]s the lidar task carries out (send, set baud, timer).

pub mod bringup;
pub mod command;
pub mod config;
pub mod crc;
pub mod error;

pub mod receiver;
pub mod reply;
pub mod scan;
pub mod slots;
pub mod status_reply;
pub mod telegram;

#[cfg(test)]
mod fake_lms;
#[cfg(test)]
mod test_data;

pub use bringup::{Action, Actions, BringUp, BringUpConfig, Input, StreamingSetup};
pub use command::{LmsBaud, OperatingMode, Request, RequestBytes};
pub use config::ConfigBlock;
pub use crc::{SickCrc, crc16};
pub use error::{Error, Result};
pub use protocol::{MeasuringMode, RangeDecoder};
pub use receiver::{Event, Receiver, ReceiverStats};
pub use reply::Reply;
pub use scan::ScanRepr;
pub use slots::ScanSlots;
pub use status_reply::StatusReply;
pub use telegram::{MAX_LEN_FIELD, MAX_TELEGRAM_LEN, STX, Telegram};
