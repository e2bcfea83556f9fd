//! Replaying a recording: the bytes the daemon read, in order, through the same link session
//! and pipelines, one after the other on this thread. The pipelines take their time steps
//! from the board's stamps, so the estimates are those of the live run, and the same file
//! always gives the same bytes out.
//!
//! With `slam.method = "camera"` the recorded camera frames go to the camera method too,
//! each at its host time between the link's records. Every recorded frame that decodes is
//! given to it, where a live run whose camera method fell behind skipped some
//! (`frames_skipped` in its web view), so its estimate and the replay's may differ there.

use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};
use protocol::MeasuringMode;

use crate::config::{DaemonConfig, SlamMethod};
use crate::publish::{publish_camera, publish_ekf, publish_grid};
use crate::runner::DaemonError;
use crate::runner::{RunOutcome, camera_pipeline, on_grid_event};
use crate::state::LiveState;
use host::camera::CameraPipeline;
use host::camera::sequence::decode_gray;
use host::ekf_slam::EkfPipeline;
use host::geoimage::GeoImage;
use host::link::LinkSession;
use host::recording::{LinkDirection, read_recording, read_recording_with_camera};
use host::slam::GridPipeline;

/// Replays `path` with the pipelines `config` selects; `progress` shows a progress bar on
/// stderr.
///
/// # Errors
/// The file is not a readable recording.
pub fn replay(
    path: &Path,
    config: &DaemonConfig,
    image: Option<&GeoImage>,
    progress: bool,
) -> Result<(RunOutcome, bool), DaemonError> {
    let recording = if config.slam.method == SlamMethod::Camera {
        read_recording_with_camera(path)?
    } else {
        read_recording(path)?
    };
    let mut session = LinkSession::new(MeasuringMode(config.link.measuring_mode));
    let mut ekf = config.slam.method.runs_ekf().then(|| {
        EkfPipeline::new(
            &config
                .slam
                .ekf_pipeline_options(config.georef.datum_lat_lon_deg),
        )
    });
    let mut grid = config
        .slam
        .method
        .runs_grid()
        .then(|| GridPipeline::new(config.slam.grid_pipeline_options()))
        .transpose()?;
    let mut grid_georef = (grid.is_some() && ekf.is_none())
        .then(|| config.slam.geo_referencer(config.georef.datum_lat_lon_deg));
    let mut camera = (config.slam.method == SlamMethod::Camera)
        .then(|| camera_pipeline(config))
        .transpose()?;
    if camera.is_some() && recording.camera_images.is_empty() {
        return Err(DaemonError::Camera(format!(
            "{}: slam.method = \"camera\" but the recording holds no camera frames",
            path.display()
        )));
    }
    let mut images = recording.camera_images.iter().peekable();
    let mut frames_refused = 0usize;
    // Each frame goes in before the first link record after it, as it reached the camera
    // method live after the fixes read before it.
    let mut frames_up_to = |time_s: f64, camera: &mut Option<CameraPipeline>| {
        let Some(camera) = camera.as_mut() else {
            return;
        };
        while let Some(image) = images.next_if(|image| image.time_s <= time_s) {
            match decode_gray(&image.data, path) {
                Ok(gray) => {
                    camera.on_frame(image.time_s, &gray);
                }
                Err(_) => frames_refused += 1,
            }
        }
    };
    let bar = if progress {
        let bar = ProgressBar::new(recording.link.len() as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} replay {bar:40} {pos}/{len} reads, {elapsed} (eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    for record in &recording.link {
        frames_up_to(record.time_s, &mut camera);
        match record.direction {
            LinkDirection::FromBoard => {
                let decoded = session.feed(&record.bytes, record.time_s);
                for event in &decoded.events {
                    if let Some(camera) = camera.as_mut() {
                        camera.on_event(event);
                    }
                    if let Some(ekf) = ekf.as_mut() {
                        ekf.on_event(event);
                    }
                    if let Some(grid) = grid.as_mut() {
                        on_grid_event(grid, grid_georef.as_mut(), event);
                    }
                }
            }
            LinkDirection::ToBoard => session.replay_sent(&record.bytes, record.time_s),
            LinkDirection::Reconnect => session.reconnected(),
        }
        bar.inc(1);
    }
    frames_up_to(f64::INFINITY, &mut camera);
    bar.finish_and_clear();
    if frames_refused > 0 {
        tracing::warn!(
            frames_refused,
            "camera frames of the recording could not be decoded and were left out"
        );
    }
    let mut state = LiveState {
        counters: session.counters(),
        ..LiveState::default()
    };
    if let Some(grid) = grid.as_mut() {
        grid.finish();
        if let Some(georef) = grid_georef.as_mut() {
            georef.align(&grid.trajectory());
        }
        publish_grid(&mut state, grid, ekf.is_none(), grid_georef.as_ref(), image);
    }
    if let Some(ekf) = ekf.as_mut() {
        ekf.finish();
        publish_ekf(&mut state, ekf, image);
    }
    if let Some(camera) = &camera {
        publish_camera(&mut state, camera, image, true);
    }
    Ok((
        RunOutcome {
            ekf,
            grid,
            grid_georef,
            camera,
            state,
            recording: None,
        },
        recording.truncated,
    ))
}
