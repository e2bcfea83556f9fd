//! `hil-sim`: runs the firmware logic on the host against real captures and emulated sensors.
//!
//! Each subcommand lives in its own module of [`cli`], with its flags and its `run`; this
//! file only parses the command line and dispatches.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli;

/// Hardware-in-the-loop simulator and decode tools for the sensor interface board.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Demo(cli::demo::DemoArgs),
    Soak(cli::soak::SoakArgs),
    Run(cli::run::RunArgs),
    Replay(cli::replay::ReplayArgs),
    ReplayCarmen(cli::replay_carmen::ReplayCarmenArgs),
    ReplayCamera(cli::replay_camera::ReplayCameraArgs),
    RenderCamera(cli::render_camera::RenderCameraArgs),
    Nees(cli::nees::NeesArgs),
    ReplayVictoria(cli::replay_victoria::ReplayVictoriaArgs),
    BenchMatch(cli::bench_match::BenchMatchArgs),
    BenchSlam(cli::bench_slam::BenchSlamArgs),
    DecodeSick(cli::decode_sick::DecodeSickArgs),
    DecodeNmea(cli::decode_nmea::DecodeNmeaArgs),
    Bringup(cli::bringup::BringupArgs),
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Demo(args) => cli::demo::run(args),
        Command::Soak(args) => cli::soak::run(args),
        Command::Run(args) => cli::run::run(args),
        Command::Replay(args) => cli::replay::run(args),
        Command::ReplayCarmen(args) => cli::replay_carmen::run(args),
        Command::ReplayCamera(args) => cli::replay_camera::run(args),
        Command::RenderCamera(args) => cli::render_camera::run(args),
        Command::Nees(args) => cli::nees::run(args),
        Command::ReplayVictoria(args) => cli::replay_victoria::run(args),
        Command::BenchMatch(args) => cli::bench_match::run(args),
        Command::BenchSlam(args) => cli::bench_slam::run(args),
        Command::DecodeSick(args) => cli::decode_sick::run(args),
        Command::DecodeNmea(args) => cli::decode_nmea::run(args),
        Command::Bringup(args) => cli::bringup::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hil-sim: {e}");
            ExitCode::FAILURE
        }
    }
}
