//! The subcommands of the `hil-sim` binary: one module each, holding the subcommand's flags
//! (a `clap::Args` struct) and its `run`, which turns them into the library's options and
//! prints what the library returns. [`hardware`] holds the flags `run` and `replay` share,
//! [`parsers`] the value parsers of several subcommands and [`report`] the output of a chain
//! run.

pub mod bench_match;
pub mod bench_slam;
pub mod bringup;
pub mod camera_args;
pub mod decode_nmea;
pub mod decode_sick;
pub mod demo;
pub mod hardware;
pub mod nees;
pub mod parsers;
pub mod render_camera;
pub mod replay;
pub mod replay_camera;
pub mod replay_carmen;
pub mod replay_victoria;
pub mod report;
pub mod run;
pub mod soak;

/// What a subcommand's `run` returns: its error is printed by `main`, which then fails.
pub type CliResult = Result<(), Box<dyn std::error::Error>>;
