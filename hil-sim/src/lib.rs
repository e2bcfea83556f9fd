//! hil-sim: runs the firmware logic on the host against real captures and emulated sensors.

pub mod bench_match;
pub mod bench_slam;
pub mod board;
pub mod bringup;
pub mod camera_nees;
pub mod camera_render;
pub mod camera_replay;
pub mod decode_nmea;
pub mod decode_sick;
pub mod demo;
pub mod devices;
pub mod emulators;
pub mod executor;
pub mod faults;
pub mod landmark_sim;
pub mod nees;
pub mod proc_status;
pub mod pty;
pub mod qemu;
pub mod replay;
pub mod run;
pub mod sim_time;
pub mod slam_replay;
pub mod soak;
pub mod victoria_slam;
pub mod world;
