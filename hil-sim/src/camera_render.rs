//! `hil-sim render-camera`: a camera's frames in a seeded world, written as a sequence
//! folder in the TUM RGB-D layout with its calibration and the true poses, so that
//! `replay-camera` (or any TUM tool) runs on it and is scored against the truth.
//!
//! The robot drives the scenario's route as the other subcommands drive it; the camera,
//! level on the robot ([`CameraView`]), takes a frame at each multiple of the period. The
//! folder holds `rgb/NNNNNN.png` (8-bit grey), `rgb.txt` (`time file`), `calib.txt`
//! (`fx fy cx cy k1 k2 p1 p2 k3`), `groundtruth.txt` (`t tx ty tz qx qy qz qw`, the camera
//! in the world frame: x east, y north, z up) and, when there are walkers, `walkers.tsv`
//! (each frame's walkers: `t id x_m y_m radius_m height_m`) and `movers/NNNNNN.png` (each
//! frame's mask of the pixels that see a walker, 255 there), which `replay-camera` uses to
//! count the features started on a walker and those left in its map.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::world::{CameraRigOptions, CameraView, Scenario, Walkers, WorldKind};

/// The most frames one sequence may hold (a day at 10 Hz).
pub const MAX_FRAMES: usize = 864_000;

/// The frames of a sequence of `duration_s` at `rate_hz` (both positive): one at each
/// multiple of the period, the first at 0. `Err` with the count when it is more than
/// [`MAX_FRAMES`].
pub fn frame_count(duration_s: f64, rate_hz: f64) -> Result<usize, f64> {
    let frames = (duration_s * rate_hz).floor() + 1.0;
    if frames > MAX_FRAMES as f64 {
        return Err(frames);
    }
    Ok(frames as usize)
}

/// What to render.
#[derive(Clone, Debug)]
pub struct CameraRenderOptions {
    pub world: WorldKind,
    pub seed: u64,
    /// Simulated seconds.
    pub duration_s: f64,
    /// Frames per second.
    pub rate_hz: f64,
    /// Walkers about the route.
    pub movers: usize,
    pub rig: CameraRigOptions,
    pub out: PathBuf,
    /// Draw a progress bar on stderr.
    pub progress: bool,
}

/// What was written.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CameraRenderSummary {
    pub folder: PathBuf,
    pub frames: usize,
    pub width_px: u32,
    pub height_px: u32,
    pub rate_hz: f64,
    pub movers: usize,
    /// The length of the camera's true path, m.
    pub true_path_m: f64,
    pub wall_s: f64,
}

/// Why a sequence could not be written.
#[derive(Debug, thiserror::Error)]
pub enum CameraRenderError {
    #[error("the rate must be a positive number of frames per second, not {0}")]
    Rate(f64),
    #[error("the duration must be a positive number of seconds, not {0}")]
    Duration(f64),
    #[error("{0} frames are more than the {MAX_FRAMES} a sequence may hold")]
    TooManyFrames(f64),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {source}")]
    Image {
        path: PathBuf,
        source: image::ImageError,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> CameraRenderError + '_ {
    move |source| CameraRenderError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Renders and writes the sequence. See the [module documentation](self).
///
/// # Errors
/// A rate or duration that is not positive, or a file that cannot be written.
pub fn render_camera(
    options: &CameraRenderOptions,
) -> Result<CameraRenderSummary, CameraRenderError> {
    if !(options.rate_hz.is_finite() && options.rate_hz > 0.0) {
        return Err(CameraRenderError::Rate(options.rate_hz));
    }
    if !(options.duration_s.is_finite() && options.duration_s > 0.0) {
        return Err(CameraRenderError::Duration(options.duration_s));
    }
    let frames = frame_count(options.duration_s, options.rate_hz)
        .map_err(CameraRenderError::TooManyFrames)?;
    let started = std::time::Instant::now();
    let scenario = Scenario::generate_for(options.world, options.seed, options.duration_s);
    let view = CameraView::new(&scenario, options.rig);
    let walkers = Walkers::new(&scenario, options.movers, options.seed);
    let images = options.out.join("rgb");
    std::fs::create_dir_all(&images).map_err(io(&images))?;
    let masks = options.out.join("movers");
    if options.movers > 0 {
        std::fs::create_dir_all(&masks).map_err(io(&masks))?;
    }
    let create = |name: &str| -> Result<BufWriter<File>, CameraRenderError> {
        let path = options.out.join(name);
        Ok(BufWriter::new(File::create(&path).map_err(io(&path))?))
    };
    let camera = view.camera();
    let mut calib = create("calib.txt")?;
    let calib_path = options.out.join("calib.txt");
    writeln!(
        calib,
        "# hil-sim rendered camera, {} x {} px: fx fy cx cy k1 k2 p1 p2 k3\n{} {} {} {} {} {} {} {} {}",
        camera.width_px,
        camera.height_px,
        camera.fx_px,
        camera.fy_px,
        camera.cx_px,
        camera.cy_px,
        camera.radial[0],
        camera.radial[1],
        camera.tangential[0],
        camera.tangential[1],
        camera.radial[2],
    )
    .map_err(io(&calib_path))?;
    calib.flush().map_err(io(&calib_path))?;
    let list_path = options.out.join("rgb.txt");
    let truth_path = options.out.join("groundtruth.txt");
    let walkers_path = options.out.join("walkers.tsv");
    let mut list = create("rgb.txt")?;
    let mut truth = create("groundtruth.txt")?;
    let mut walkers_file = if options.movers > 0 {
        let mut file = create("walkers.tsv")?;
        writeln!(file, "# t\tid\tx_m\ty_m\tradius_m\theight_m").map_err(io(&walkers_path))?;
        Some(file)
    } else {
        None
    };
    writeln!(
        list,
        "# timestamp filename ({} world, seed {})",
        options.world, options.seed
    )
    .map_err(io(&list_path))?;
    writeln!(
        truth,
        "# timestamp tx ty tz qx qy qz qw (world frame, z up)"
    )
    .map_err(io(&truth_path))?;
    let bar = crate::camera_replay::frames_bar(frames, options.progress);
    let mut true_path_m = 0.0;
    let mut last_position: Option<nalgebra::Vector3<f64>> = None;
    for frame in 0..frames {
        let t_s = frame as f64 / options.rate_hz;
        let state = scenario.pose_at(t_s);
        let movers = walkers.at(t_s);
        let (image, mask) = view.render_with_movers(&state, &movers, frame as u64);
        if options.movers > 0 {
            let path = masks.join(format!("{frame:06}.png"));
            mask.save(&path)
                .map_err(|source| CameraRenderError::Image {
                    path: path.clone(),
                    source,
                })?;
        }
        let name = format!("rgb/{frame:06}.png");
        let path = options.out.join(&name);
        image
            .save(&path)
            .map_err(|source| CameraRenderError::Image {
                path: path.clone(),
                source,
            })?;
        writeln!(list, "{t_s:.6} {name}").map_err(io(&list_path))?;
        let (position, orientation) = view.camera_pose(&state);
        let q = orientation.quaternion();
        writeln!(
            truth,
            "{t_s:.6} {:.6} {:.6} {:.6} {:.9} {:.9} {:.9} {:.9}",
            position.x, position.y, position.z, q.i, q.j, q.k, q.w
        )
        .map_err(io(&truth_path))?;
        if let Some(file) = walkers_file.as_mut() {
            for m in &movers {
                writeln!(
                    file,
                    "{t_s:.6}\t{}\t{:.4}\t{:.4}\t{}\t{}",
                    m.id, m.center_m[0], m.center_m[1], m.radius_m, m.height_m
                )
                .map_err(io(&walkers_path))?;
            }
        }
        if let Some(last) = last_position {
            true_path_m += (position - last).norm();
        }
        last_position = Some(position);
        bar.inc(1);
    }
    bar.finish_and_clear();
    list.flush().map_err(io(&list_path))?;
    truth.flush().map_err(io(&truth_path))?;
    if let Some(mut file) = walkers_file {
        file.flush().map_err(io(&walkers_path))?;
    }
    Ok(CameraRenderSummary {
        folder: options.out.clone(),
        frames,
        width_px: camera.width_px,
        height_px: camera.height_px,
        rate_hz: options.rate_hz,
        movers: options.movers,
        true_path_m,
        wall_s: started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(name: &str, rate_hz: f64, duration_s: f64) -> CameraRenderOptions {
        CameraRenderOptions {
            world: WorldKind::Indoor,
            seed: 1,
            duration_s,
            rate_hz,
            movers: 0,
            rig: CameraRigOptions::with_size(64, 48),
            out: std::env::temp_dir().join(format!("render-camera-{name}-{}", std::process::id())),
            progress: false,
        }
    }

    #[test]
    fn a_rate_or_duration_that_is_not_positive_is_refused_before_anything_is_written() {
        for (rate, duration) in [
            (0.0, 1.0),
            (f64::NAN, 1.0),
            (10.0, -1.0),
            (10.0, 0.0),
            (1e9, 1e9),
        ] {
            let options = options("refused", rate, duration);
            let error = render_camera(&options).expect_err("refused");
            assert!(
                matches!(
                    error,
                    CameraRenderError::Rate(_)
                        | CameraRenderError::Duration(_)
                        | CameraRenderError::TooManyFrames(_)
                ),
                "{error}"
            );
            assert!(!options.out.exists());
        }
    }

    #[test]
    fn a_second_of_frames_is_written_with_its_truth() {
        let options = options("second", 5.0, 1.0);
        let summary = render_camera(&options).expect("written");
        assert_eq!(summary.frames, 6);
        let list = std::fs::read_to_string(options.out.join("rgb.txt")).expect("rgb.txt");
        let truth =
            std::fs::read_to_string(options.out.join("groundtruth.txt")).expect("groundtruth");
        let lines = |text: &str| text.lines().filter(|l| !l.starts_with('#')).count();
        assert_eq!((lines(&list), lines(&truth)), (6, 6));
        let sequence = host::camera::CameraSequence::open(&options.out).expect("a TUM folder");
        assert_eq!(sequence.frames.len(), 6);
        assert_eq!(sequence.truth.len(), 6);
        assert_eq!(sequence.load(5).expect("frame").dimensions(), (64, 48));
        std::fs::remove_dir_all(&options.out).expect("cleaned");
    }
}
