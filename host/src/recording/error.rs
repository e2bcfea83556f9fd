//! What can go wrong writing or reading a recording.

use std::path::PathBuf;

/// Why a recording could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The recording file could not be created (it exists already, or the folder is missing
    /// or not writable).
    #[error("cannot create the recording {path}: {source}")]
    Create {
        /// The file asked for.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The recording file could not be opened or read.
    #[error("cannot read the recording {path}: {source}")]
    Open {
        /// The file asked for.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// Writing to the recording failed (disk full, file system error).
    #[error("cannot write to the recording {path}: {source}")]
    Write {
        /// The recording.
        path: PathBuf,
        /// What the MCAP writer said.
        source: mcap::McapError,
    },
    /// The file does not start with the MCAP magic bytes.
    #[error("{path} is not an MCAP file (it does not start with the MCAP magic bytes)")]
    NotMcap {
        /// The file read.
        path: PathBuf,
    },
    /// The file is an MCAP file but damaged other than by being cut short.
    #[error("the recording {path} is damaged: {source}")]
    Corrupt {
        /// The file read.
        path: PathBuf,
        /// What the MCAP reader found.
        source: mcap::McapError,
    },
    /// A record of the file has a field that claims more bytes than the record holds:
    /// damaged, and refused before the MCAP library reserves what the field claims.
    #[error("the recording {path} is damaged: in a record with opcode {opcode:#04x}, {overrun}")]
    FieldOverrun {
        /// The file read.
        path: PathBuf,
        /// The record's MCAP opcode.
        opcode: u8,
        /// Which field, and by how much.
        overrun: super::record_fields::FieldOverrun,
    },
    /// A message could not be encoded for its channel.
    #[error("cannot encode a message for {topic}: {reason}")]
    Encode {
        /// The channel's topic.
        topic: &'static str,
        /// What the encoder said.
        reason: String,
    },
    /// A time that is negative, not a number, or beyond the year 2554 (MCAP stores times as
    /// unsigned nanoseconds).
    #[error("time {time_s} s cannot be recorded: it must be finite and non-negative")]
    InvalidTime {
        /// The time given, s.
        time_s: f64,
    },
    /// Recorder options that cannot work.
    #[error("invalid recorder options: {0}")]
    InvalidOptions(String),
}
