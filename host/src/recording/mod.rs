//! Recording a run to MCAP, reading it back.
//!
//! Every read from the serial port is recorded byte for byte (so that replay feeds the same
//! bytes to the link reader and reproduces the run), with the decoded messages on one JSON
//! channel per kind and the host's pose as Foxglove's well-known messages, so that a run
//! opens in Foxglove as it is. The file survives a kill of the daemon up to its last flushed
//! chunk.
//!
//! * [`Recorder`]: writes a recording as the run goes.
//! * [`read_recording`]: reads one back, cut short or not, with its further parts
//!   ([`part_path`]; [`read_recording_from`] reads one file from any reader).
//! * [`topics`]: the channels the host writes besides the board's ([`board_topic`]).
//! * [`foxglove_messages`] and [`json_schema`]: the encodings the recording shares with the
//!   daemon's live view.

mod board_message;
mod durable_file;
mod error;
pub mod foxglove_messages;
pub mod json_schema;
pub mod reader;
mod record_fields;
pub mod recorder;
pub mod topics;

pub use board_message::board_topic;
pub use error::RecordingError;
pub use reader::{
    CameraImage, LinkDirection, LinkRecord, RawRead, Recording, read_recording,
    read_recording_from, read_recording_with_camera,
};
pub use record_fields::FieldOverrun;
pub use recorder::{Recorder, RecorderOptions, RecordingSummary, existing_parts, part_path};
