//! The host link, HAL-free: what to answer to each host command ([`commands`]) and how
//! outgoing messages become numbered frames ([`writer`]).

pub mod commands;
pub mod writer;

pub use commands::{CommandOutcome, handle_command};
pub use writer::LinkWriter;
