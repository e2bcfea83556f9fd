//! `hil-sim render-camera`: a rendered camera's frames in a seeded world, as a sequence
//! folder with its truth.

use std::path::PathBuf;

use hil_sim::world::{CameraRigOptions, WorldKind};

use super::CliResult;

/// Renders what a camera on the robot sees as it drives a seeded world, and writes it as a
/// TUM-layout sequence folder that `replay-camera` reads and scores.
///
/// The camera is level on the robot, 1.2 m above the ground, 640 × 480 px with a 65°
/// field of view and mild barrel distortion; each frame gets an exposure gain and pixel
/// noise from the seed. OUT gets rgb/NNNNNN.png, rgb.txt, calib.txt (`fx fy cx cy k1 k2 p1
/// p2 k3`), groundtruth.txt (`t tx ty tz qx qy qz qw`, the camera in the world frame, z up)
/// and, with walkers, walkers.tsv (where each walker was in each frame) and
/// movers/NNNNNN.png (each frame's mask of the pixels that see a walker, which
/// `replay-camera` uses to count the features started on walkers).
#[derive(Debug, clap::Args)]
pub struct RenderCameraArgs {
    /// The world: `outdoor` (a park: trees, a building, garden walls, benches) or `indoor`
    /// (an office floor).
    #[arg(long, default_value = "outdoor")]
    world: WorldKind,
    /// Seed of the world, the route, the walkers and the exposure noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seconds of simulated driving.
    #[arg(long, default_value_t = 30.0)]
    duration: f64,
    /// Frames per second.
    #[arg(long, default_value_t = 10.0)]
    rate: f64,
    /// People walking about near the route, each pacing a straight line at 1–1.6 m/s.
    #[arg(long, default_value_t = 0)]
    movers: usize,
    /// Image size, `WIDTHxHEIGHT` pixels (the field of view stays 65° across).
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
    /// Output folder (created if missing).
    #[arg(long, default_value = "camera-sequence")]
    out: PathBuf,
}

/// Renders the sequence; prints what was written as JSON on stdout.
pub fn run(args: RenderCameraArgs) -> CliResult {
    let options = hil_sim::camera_render::CameraRenderOptions {
        world: args.world,
        seed: args.seed,
        duration_s: args.duration,
        rate_hz: args.rate,
        movers: args.movers,
        rig: CameraRigOptions::with_size(args.size.0, args.size.1),
        out: args.out,
        progress: true,
    };
    let summary = hil_sim::camera_render::render_camera(&options)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}

/// `WIDTHxHEIGHT`, each from 16 to 8192 pixels.
fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (width, height) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{text}` is not WIDTHxHEIGHT (for example 640x480)"))?;
    let parse = |what: &str, value: &str| -> Result<u32, String> {
        let n: u32 = value
            .trim()
            .parse()
            .map_err(|_| format!("the {what} `{value}` is not a whole number of pixels"))?;
        if (16..=8192).contains(&n) {
            Ok(n)
        } else {
            Err(format!("the {what} must be 16 to 8192 pixels, not {n}"))
        }
    };
    Ok((parse("width", width)?, parse("height", height)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_size_is_width_by_height() {
        assert_eq!(parse_size("640x480"), Ok((640, 480)));
        assert_eq!(parse_size("320X240"), Ok((320, 240)));
        assert!(parse_size("640").is_err());
        assert!(parse_size("640x0").unwrap_err().contains("16 to 8192"));
        assert!(parse_size("axb").unwrap_err().contains("width"));
    }
}
