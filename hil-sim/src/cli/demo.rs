//! `hil-sim demo`: the whole system on a seeded world with no hardware and no data files, up
//! to the robot-host daemon and its web view.

use std::path::PathBuf;

use super::CliResult;
use super::camera_args::CameraArgs;

/// The whole system, no hardware and no data files: a seeded world with a generated,
/// geo-referenced aerial image; emulated laser and GPS → the firmware tasks on the host →
/// a pty → the robot-host daemon, which maps (EKF with GPS outdoors, occupancy grid
/// indoors), records to MCAP and serves the web view, whose address it prints. With
/// `--method camera` (outdoors) the robot computer's camera is rendered too, and the daemon
/// runs the camera method on its frames with the board's GPS, shows them with the tracked
/// features and records them. At the end OUT holds the map PNG, the map over the image, the
/// trajectory, GeoJSON/KML, the MCAP recording and a summary; the report is printed as JSON.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// The world: `outdoor` (a park with trees and a building, GPS, aerial image) or
    /// `indoor` (rooms and corridors, occupancy grid).
    #[arg(long, default_value = "outdoor")]
    world: hil_sim::world::WorldKind,
    /// Seed of the world, its route and the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seconds of driving.
    #[arg(long, default_value_t = 60.0)]
    duration: f64,
    #[command(flatten)]
    camera: CameraArgs,
    /// Address of the web view (port 0 picks a free one).
    #[arg(long, default_value = "127.0.0.1:8080")]
    serve: std::net::SocketAddr,
    /// Also stream the live state to Foxglove on this WebSocket address.
    #[arg(long)]
    foxglove: Option<std::net::SocketAddr>,
    /// Where the outputs go.
    #[arg(long, default_value = "demo-out")]
    out: PathBuf,
    /// Run as fast as the machine allows instead of at the wall clock. The emulated board's
    /// clock then runs ahead of the host's, at whatever rate the machine allows, and the
    /// daemon's board-to-host time mapping (made for a real board's crystal) steps at each
    /// time sync: the outputs test the chain, and GPS fixes paired with poses across a step
    /// are set aside as receiver jumps.
    #[arg(long)]
    fast: bool,
    /// After the drive, keep the web view up this many seconds.
    #[arg(long, default_value_t = 0.0)]
    linger: f64,
}

/// Runs the demo; prints the web view's address when it is up and the report at the end.
pub fn run(args: DemoArgs) -> CliResult {
    let options = hil_sim::demo::DemoOptions {
        world: args.world,
        seed: args.seed,
        duration_s: args.duration,
        serve: args.serve,
        foxglove: args.foxglove,
        out: args.out,
        realtime: !args.fast,
        linger_s: args.linger,
        camera: args.camera.options()?,
    };
    let report = hil_sim::demo::run(&options, |ready| {
        if let Some(web) = ready.web {
            println!("web view: http://{web}/");
        }
        if let Some(foxglove) = ready.foxglove {
            println!("foxglove: ws://{foxglove}");
        }
        eprintln!(
            "driving the {} world (seed {}) for {} s …",
            options.world, options.seed, options.duration_s
        );
    })?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
