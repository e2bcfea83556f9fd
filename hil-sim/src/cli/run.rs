//! `hil-sim run`: the whole chain on a seeded world, lock-step on a virtual clock, with the
//! firmware in this process, on a flashed board (`--hardware`) or in QEMU (`--qemu`).

use std::path::PathBuf;

use super::CliResult;
use super::camera_args::CameraArgs;
use super::hardware::HardwareArgs;
use super::report::report;

/// Run the whole chain on a seeded world: emulated LMS2xx laser and NMEA GPS → pseudo-
/// terminals → the firmware tasks → host link → the host's pose estimate, lock-step on a
/// virtual clock (byte-identical outputs for the same arguments).
///
/// Writes OUT/trajectory.tsv (the host's estimate per scan: `timestamp_s x_m y_m
/// theta_rad`), OUT/ground_truth.tsv (the truth at the same timestamps, same frame),
/// OUT/summary.json (every telegram accounted for, faults injected beside what was
/// counted), OUT/performance.json (the pipeline's time per scan: mean, percentiles, the first
/// and the last 1 000 scans; the peak memory; the grid method's time by part),
/// OUT/landmarks.tsv and OUT/world.tsv. Prints the summary on stdout.
///
/// With `--world outdoor --method camera` the robot computer's camera is rendered at the
/// true pose of each frame's time and the camera method estimates the robot from its
/// frames, its map put into the world frame (and given its scale) by the GPS fixes that
/// come through the board; the laser runs as ever and each scan gets the camera's pose.
/// Adds OUT/camera_trajectory.tum and OUT/camera_ground_truth.tum (`t tx ty tz qx qy qz qw`
/// per frame), once GPS has aligned the map OUT/camera_map.geojson and OUT/camera_map.kml
/// (the path and the map's points in WGS84), the `camera` part of OUT/summary.json (the
/// scale from GPS against the true one, the position error) and `camera_frames` in
/// OUT/performance.json (the time of each frame's step). Rendering and the camera method run
/// in the run's own loop, about 60 ms a frame in all.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// The kind of world: `indoor` (rooms and corridors) or `outdoor` (a park with trees
    /// and a building; GPS has a fix).
    #[arg(long, default_value = "indoor")]
    world: hil_sim::world::WorldKind,
    #[command(flatten)]
    camera: CameraArgs,
    /// Seed of the world, the route, the sensor noise and the faults.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seconds of sensor output (virtual time).
    #[arg(long, default_value_t = 20.0)]
    duration: f64,
    /// Faults to inject, comma-separated: `ber=RATE` (bit errors per bit), `drop=RATE`
    /// (bytes lost), `truncate=RATE` (laser telegrams cut short), `laser-restart=T_S`
    /// (power cycle at T seconds), `gps-outage=T_S:DUR_S` (no fix for DUR seconds),
    /// `link-replug=T_S` (host link unplugged for 0.3 s). Times may repeat.
    #[arg(long, default_value = "")]
    faults: hil_sim::faults::FaultSpec,
    /// Output directory (created if missing).
    #[arg(long, default_value = "hil-run")]
    out: PathBuf,
    /// Pace the run at the wall clock instead of running as fast as possible.
    #[arg(long)]
    realtime: bool,
    #[command(flatten)]
    hardware: HardwareArgs,
    /// Boot the firmware image for QEMU's netduinoplus2 machine (the thumbv7em build of
    /// firmware/qemu) in qemu-system-arm and drive it instead of the firmware in this
    /// process, on the wall clock as with --hardware. Writes OUT/qemu.json: the image's
    /// stack high-water mark and its worst telegram-to-frame time in emulated cycles.
    #[arg(
        long,
        value_name = "ELF",
        num_args = 0..=1,
        default_missing_value = hil_sim::qemu::DEFAULT_ELF,
        conflicts_with = "hardware"
    )]
    qemu: Option<PathBuf>,
    /// Bring the laser up as the QEMU image does (38 400 Bd instead of 500 kBd, millimetres
    /// in every world), with the firmware in this process: the reference a --qemu run of
    /// the same seed is compared with.
    #[arg(long, conflicts_with_all = ["qemu", "hardware"])]
    qemu_config: bool,
    /// Indoors, insert every scan into the map. By default a scan is inserted only once the
    /// robot moved 0.2 m or turned 1° since the last one (or after 5 s), so that the map, the
    /// pose graph and loop closure grow with the ground covered rather than with the laser's
    /// rate; every scan is tracked and has a pose either way.
    #[arg(long)]
    grid_every_scan: bool,
}

/// Runs the chain and reports its summary; with `--qemu`, also what the image measured.
pub fn run(args: RunArgs) -> CliResult {
    let camera = args.camera.options()?;
    let options = hil_sim::run::RunOptions {
        world: args.world,
        seed: args.seed,
        duration_s: args.duration,
        faults: args.faults,
        out: args.out,
        realtime: args.realtime,
        hardware: args.hardware.ports(),
        grid_every_scan: args.grid_every_scan,
        camera,
    };
    let Some(elf) = args.qemu else {
        let summary = if args.qemu_config {
            let image = Some(hil_sim::qemu::image_bring_up());
            hil_sim::run::run_with_bring_up(&options, None, image)?
        } else {
            hil_sim::run::run(&options)?
        };
        return report(&summary, &options.out);
    };
    let (summary, measured) = hil_sim::qemu::run(&options, &hil_sim::qemu::QemuOptions::new(elf))?;
    eprintln!(
        "hil-sim: QEMU image: stack {} of {} bytes used; telegram to frame at most {} cycles \
         ({:.1} µs, {} instructions) over {} scans",
        measured.measurements.stack_used_bytes,
        measured.measurements.stack_bytes,
        measured.measurements.latency_max_cycles,
        measured.latency_max_us,
        measured.latency_max_instructions,
        measured.measurements.latency_samples,
    );
    report(&summary, &options.out)
}
