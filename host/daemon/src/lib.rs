//! The robot-host daemon: the board link read on its own thread, the SLAM pipelines on theirs,
//! the live state the web view and the goal API read, the live view in Foxglove
//! ([`foxglove_live`]) and the recording ([`host::recording`]).
//!
//! The algorithms live in the `host` library, which knows nothing of threads, HTTP or files;
//! this crate reads the inputs, drives the library's pipelines
//! ([`host::slam::GridPipeline`], [`host::ekf_slam::EkfPipeline`]) and serves and writes the
//! outputs.

pub mod camera_capture;
pub(crate) mod camera_runner;
#[cfg(feature = "v4l2")]
pub mod camera_v4l2;
pub mod config;
pub mod foxglove_live;
pub mod goal;
pub mod memory_policy;
pub mod outputs;
pub mod publish;
pub mod replay;
pub mod runner;
pub mod state;
pub mod web;

pub use foxglove_live::{LiveServer, LiveServerError, start_live_server};
pub use state::{
    GoalError, GoalInMap, GoalRequest, GoalResolver, GridView, ImageView, LandmarkView,
    LinkCounters, LiveState, PoseView, SharedState, TrackingView,
};
