//! The camera's two threads.
//!
//! ```text
//! camera ──▶ capture ──newest frame──▶ camera method ──▶ LiveState (pose, map, panel)
//!              │                          ▲
//!              └──JPEG──▶ recorder        └── fixes from the reader
//! ```
//!
//! The capture thread takes each frame as the device gives it, stamps it on the host clock
//! the link's reader also uses (so frames and fixes share one time line; at the time the
//! device says it took the frame where it says so), decodes it and hands
//! it on. It never waits for the camera method: when the method is still busy with the frame
//! before, the new frame is counted as skipped and only recorded and shown, so a slow step
//! costs frames, never latency. Without the camera method (`slam.method` other than
//! `camera`) the frames are recorded and shown only.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender, TrySendError};
use std::sync::{Arc, PoisonError};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use host::camera::{CameraPipeline, FrameReport};
use host::geoimage::GeoImage;
use host::link::SensorEvent;
use image::GrayImage;

use crate::camera_capture::{CapturedFrame, FrameSource};
use crate::publish::publish_camera;
use crate::runner::RecordItem;
use crate::state::{CameraFeatureView, CameraStatus, CameraView, SharedState};

/// After a device error, the capture waits this long before asking again.
const RETRY_AFTER: Duration = Duration::from_millis(500);
/// The camera method's pose and path are published every this many frames.
const PUBLISH_POSE_EVERY_FRAMES: u64 = 5;
/// Its map's points every this many frames (they are placed by each segment's alignment).
const PUBLISH_MAP_EVERY_FRAMES: u64 = 50;

/// A frame on its way to the camera method: host time, grey image, JPEG.
type MethodFrame = (f64, GrayImage, Arc<Vec<u8>>);

/// The running camera threads.
pub(crate) struct CameraThreads {
    capture: JoinHandle<()>,
    method: Option<JoinHandle<CameraPipeline>>,
}

/// What the camera threads are given.
pub(crate) struct CameraInputs {
    /// The camera.
    pub source: Box<dyn FrameSource>,
    /// The camera method, when it runs, with the board's events for its fixes.
    pub method: Option<(CameraPipeline, Receiver<SensorEvent>)>,
    /// The host clock's origin, shared with the link's reader.
    pub clock: Instant,
    /// JPEG quality of uncompressed frames.
    pub jpeg_quality: u8,
    /// Where frames are recorded.
    pub record_tx: Option<Sender<RecordItem>>,
    /// The geo-referenced image, for the goal's pixels.
    pub image: Option<Arc<GeoImage>>,
}

impl CameraThreads {
    /// Starts the capture thread and, with a pipeline, the camera method's thread.
    ///
    /// # Errors
    /// A thread cannot be started.
    pub(crate) fn start(
        inputs: CameraInputs,
        state: &SharedState,
        shutdown: &Arc<AtomicBool>,
    ) -> std::io::Result<CameraThreads> {
        let CameraInputs {
            source,
            method,
            clock,
            jpeg_quality,
            record_tx,
            image,
        } = inputs;
        let tracking = method.is_some();
        let (frames_tx, method) = match method {
            Some((pipeline, events)) => {
                // One frame in hand: the method takes the newest it can.
                let (tx, rx) = mpsc::sync_channel(1);
                let state = state.clone();
                let handle = thread::Builder::new()
                    .name("camera".into())
                    .spawn(move || run_method(pipeline, &rx, &events, &state, image.as_deref()))?;
                (Some(tx), Some(handle))
            }
            None => (None, None),
        };
        let capture = {
            let state = state.clone();
            let shutdown = shutdown.clone();
            thread::Builder::new()
                .name("camera-capture".into())
                .spawn(move || {
                    capture(
                        source,
                        Capture {
                            clock,
                            jpeg_quality,
                            tracking,
                            frames_tx,
                            record_tx,
                        },
                        &state,
                        &shutdown,
                    );
                })?
        };
        Ok(CameraThreads { capture, method })
    }

    /// Waits for both threads (the capture stops on the daemon's shutdown, the method once it
    /// has the last frame). Returns the camera method.
    ///
    /// # Errors
    /// The name of a thread that panicked.
    pub(crate) fn join(self) -> Result<Option<CameraPipeline>, &'static str> {
        self.capture.join().map_err(|_| "camera-capture")?;
        self.method
            .map(|h| h.join().map_err(|_| "camera"))
            .transpose()
    }
}

/// The capture thread's settings and outlets.
struct Capture {
    clock: Instant,
    jpeg_quality: u8,
    tracking: bool,
    frames_tx: Option<SyncSender<MethodFrame>>,
    record_tx: Option<Sender<RecordItem>>,
}

fn capture(
    mut source: Box<dyn FrameSource>,
    outlets: Capture,
    state: &SharedState,
    shutdown: &AtomicBool,
) {
    let name = source.name();
    let mut counts = CameraStatus {
        source: name.clone(),
        tracking: outlets.tracking,
        ..CameraStatus::default()
    };
    let mut failing = false;
    let mut outlets_failed = false;
    while !shutdown.load(Ordering::Relaxed) {
        let raw = match source.next_frame() {
            Ok(Some(raw)) => raw,
            Ok(None) => {
                tracing::info!(camera = %name, "the camera's frames have ended");
                break;
            }
            Err(e) => {
                // Said once per outage, not once per retry.
                if !failing {
                    tracing::warn!(error = %e, "camera: no frames; retrying");
                }
                failing = true;
                thread::sleep(RETRY_AFTER);
                continue;
            }
        };
        if failing {
            tracing::info!(camera = %name, "camera: frames again");
            failing = false;
        }
        // The camera's own capture time where the source knows it (an exposure and a USB
        // transfer ahead of the read), else the read's.
        let time_s = raw
            .captured_at
            .and_then(|at| at.checked_duration_since(outlets.clock))
            .unwrap_or_else(|| outlets.clock.elapsed())
            .as_secs_f64();
        let frame = match CapturedFrame::from_raw(raw, outlets.jpeg_quality) {
            Ok(frame) => frame,
            Err(e) => {
                counts.frames_refused += 1;
                tracing::warn!(error = %e, "camera: frame refused");
                write_counts(state, &counts);
                continue;
            }
        };
        counts.frames_captured += 1;
        let size_px = [frame.gray.width(), frame.gray.height()];
        let jpeg = Arc::new(frame.jpeg);
        if let Some(tx) = &outlets.record_tx {
            let _ = tx.send(RecordItem::Image(time_s, jpeg.clone()));
        }
        let mut shown_here = true;
        if let Some(tx) = outlets.frames_tx.as_ref().filter(|_| !outlets_failed) {
            match tx.try_send((time_s, frame.gray, jpeg.clone())) {
                // The method shows it once it has tracked it.
                Ok(()) => shown_here = false,
                Err(TrySendError::Full(_)) => counts.frames_skipped += 1,
                Err(TrySendError::Disconnected(_)) => {
                    // The method's thread has stopped (it panicked): frames are still
                    // recorded and shown.
                    tracing::error!("camera: the camera method has stopped; recording only");
                    outlets_failed = true;
                }
            }
        }
        let mut s = state.write().unwrap_or_else(PoisonError::into_inner);
        let view = s.camera.get_or_insert_with(CameraView::default);
        copy_counts(&mut view.status, &counts);
        if shown_here {
            view.show(jpeg, time_s, size_px);
            // Drawn over another frame, the last tracked features would mislead.
            clear_tracking(&mut view.status);
        }
    }
}

/// Copies the capture's own counts into the shown status.
fn copy_counts(status: &mut CameraStatus, counts: &CameraStatus) {
    status.source.clone_from(&counts.source);
    status.tracking = counts.tracking;
    status.frames_captured = counts.frames_captured;
    status.frames_skipped = counts.frames_skipped;
    status.frames_refused = counts.frames_refused;
}

fn write_counts(state: &SharedState, counts: &CameraStatus) {
    let mut s = state.write().unwrap_or_else(PoisonError::into_inner);
    copy_counts(
        &mut s.camera.get_or_insert_with(CameraView::default).status,
        counts,
    );
}

fn clear_tracking(status: &mut CameraStatus) {
    status.features.clear();
    status.added.clear();
    status.moving.clear();
    status.measured = 0;
}

/// The camera method's thread: each frame with the fixes that came before it.
fn run_method(
    mut pipeline: CameraPipeline,
    frames: &Receiver<MethodFrame>,
    events: &Receiver<SensorEvent>,
    state: &SharedState,
    image: Option<&GeoImage>,
) -> CameraPipeline {
    let mut tracked = 0u64;
    for (time_s, gray, jpeg) in frames {
        for event in events.try_iter() {
            pipeline.on_event(&event);
        }
        let Some(report) = pipeline.on_frame(time_s, &gray) else {
            continue;
        };
        tracked += 1;
        let mut s = state.write().unwrap_or_else(PoisonError::into_inner);
        let view = s.camera.get_or_insert_with(CameraView::default);
        view.show(jpeg, time_s, [gray.width(), gray.height()]);
        show_tracking(&mut view.status, &pipeline, &report);
        if tracked.is_multiple_of(PUBLISH_POSE_EVERY_FRAMES) {
            publish_camera(
                &mut s,
                &pipeline,
                image,
                tracked.is_multiple_of(PUBLISH_MAP_EVERY_FRAMES),
            );
        }
    }
    for event in events.try_iter() {
        pipeline.on_event(&event);
    }
    publish_camera(
        &mut state.write().unwrap_or_else(PoisonError::into_inner),
        &pipeline,
        image,
        true,
    );
    pipeline
}

/// What the camera method made of the last frame, as the panel draws it.
pub(crate) fn show_tracking(
    status: &mut CameraStatus,
    pipeline: &CameraPipeline,
    report: &FrameReport,
) {
    let slam = pipeline.slam();
    status.features = slam
        .feature_ellipses()
        .into_iter()
        .map(|(pixel, s)| CameraFeatureView {
            pixel,
            covariance_px2: [s[(0, 0)], s[(0, 1)], s[(1, 1)]],
        })
        .collect();
    status.measured = report.measured;
    status.added.clone_from(&report.added_pixels);
    status.moving = slam
        .moving_corners()
        .iter()
        .map(|&(now, before)| [now, before])
        .collect();
    let stats = slam.stats();
    status.local_maps = stats.local_maps;
    status.places_recognised = stats.places_recognised;
    status.rejected_as_moving =
        stats.features_rejected_as_moving + stats.corners_rejected_as_moving;
    status.scale_from_gps = pipeline.alignment().map(|a| a.scale);
}
