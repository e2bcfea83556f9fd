//! A V4L2 camera (`/dev/videoN`) as a [`FrameSource`], through the `v4l` crate: memory-mapped
//! streaming, the size and rate of the configuration, MJPEG where the camera offers it (small
//! frames over USB, recorded as they come), YUYV or grey otherwise.
//!
//! Only this file touches the device; what it hands over goes through the same code as a
//! recorded sequence ([`crate::camera_capture`]), which is what the tests drive.

use std::time::{Duration, Instant};

use v4l::buffer::{Flags, Type};
use v4l::io::traits::CaptureStream;
use v4l::prelude::{Device, MmapStream};
use v4l::video::Capture;
use v4l::video::capture::Parameters;
use v4l::{Format, FourCC};

use crate::camera_capture::{CaptureError, FrameSource, PixelFormat, RawFrame};

/// Buffers the driver fills in turn.
const BUFFERS: u32 = 4;
/// A camera that gives no frame for this long is taken as failed (and reopened), so that the
/// capture thread never waits longer than this to see the daemon stopping.
const FRAME_TIMEOUT: Duration = Duration::from_secs(1);

/// What a [`V4l2Camera`] asks of its device.
#[derive(Debug, Clone, PartialEq)]
pub struct V4l2Request {
    /// The device path.
    pub device: String,
    /// Frame width, pixels.
    pub width_px: u32,
    /// Frame height, pixels.
    pub height_px: u32,
    /// Frames per second.
    pub rate_hz: f64,
}

struct Open {
    stream: MmapStream<'static>,
    format: PixelFormat,
    width_px: u32,
    height_px: u32,
    // The stream maps the device's buffers; the device stays open beside it.
    _device: Device,
}

/// A V4L2 camera. It opens the device on the first frame asked for, and again after a
/// failure (a camera unplugged and plugged back in).
pub struct V4l2Camera {
    request: V4l2Request,
    open: Option<Open>,
}

impl std::fmt::Debug for V4l2Camera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("V4l2Camera")
            .field("request", &self.request)
            .field("open", &self.open.is_some())
            .finish()
    }
}

impl V4l2Camera {
    /// A camera that will open `request.device`.
    pub fn new(request: V4l2Request) -> Self {
        V4l2Camera {
            request,
            open: None,
        }
    }

    fn error(&self, message: impl std::fmt::Display) -> CaptureError {
        CaptureError::Device {
            device: self.request.device.clone(),
            message: message.to_string(),
        }
    }

    fn open(&self) -> Result<Open, CaptureError> {
        let device = Device::with_path(&self.request.device)
            .map_err(|e| self.error(format!("cannot open: {e}")))?;
        let mut chosen = None;
        for format in [PixelFormat::Mjpeg, PixelFormat::Yuyv, PixelFormat::Grey] {
            let asked = Format::new(
                self.request.width_px,
                self.request.height_px,
                FourCC::new(&format.fourcc()),
            );
            let given = device
                .set_format(&asked)
                .map_err(|e| self.error(format!("cannot set a format: {e}")))?;
            if PixelFormat::from_fourcc(given.fourcc.repr) == Some(format) {
                chosen = Some((format, given));
                break;
            }
        }
        let (format, given) = chosen.ok_or_else(|| {
            self.error("offers none of MJPEG, YUYV and 8-bit grey, which the daemon reads")
        })?;
        if (given.width, given.height) != (self.request.width_px, self.request.height_px) {
            // The calibration is that of the configured size: tracking frames of another
            // size with it would be wrong everywhere.
            return Err(self.error(format!(
                "gives {}×{} px, not the {}×{} px configured: configure a size it gives, with \
                 its calibration at that size",
                given.width, given.height, self.request.width_px, self.request.height_px
            )));
        }
        let fps = self.request.rate_hz.round().clamp(1.0, 1000.0) as u32;
        if let Err(e) = device.set_params(&Parameters::with_fps(fps)) {
            tracing::warn!(device = %self.request.device, error = %e, "cannot set the frame rate");
        }
        let mut stream = MmapStream::with_buffers(&device, Type::VideoCapture, BUFFERS)
            .map_err(|e| self.error(format!("cannot start streaming: {e}")))?;
        stream.set_timeout(FRAME_TIMEOUT);
        tracing::info!(
            device = %self.request.device,
            format = ?format,
            width = given.width,
            height = given.height,
            fps,
            "camera open"
        );
        Ok(Open {
            stream,
            format,
            width_px: given.width,
            height_px: given.height,
            _device: device,
        })
    }
}

/// The `Instant` of a `CLOCK_MONOTONIC` time (a V4L2 buffer's timestamp), when it lies in
/// the last second: the clock `Instant` reads on Linux, but Rust has no conversion from it.
fn instant_of_monotonic(sec: i64, usec: i64) -> Option<Instant> {
    let now = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    let now_us = i128::from(now.tv_sec) * 1_000_000 + i128::from(now.tv_nsec) / 1_000;
    let taken_us = i128::from(sec) * 1_000_000 + i128::from(usec);
    let age_us = u64::try_from(now_us - taken_us)
        .ok()
        .filter(|&a| a < 1_000_000)?;
    Instant::now().checked_sub(Duration::from_micros(age_us))
}

impl FrameSource for V4l2Camera {
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError> {
        if self.open.is_none() {
            self.open = Some(self.open()?);
        }
        let Some(open) = self.open.as_mut() else {
            return Ok(None);
        };
        match open.stream.next() {
            Ok((buffer, meta)) => {
                let used = (meta.bytesused as usize).min(buffer.len());
                let captured_at = meta
                    .flags
                    .contains(Flags::TIMESTAMP_MONOTONIC)
                    .then(|| instant_of_monotonic(meta.timestamp.sec, meta.timestamp.usec))
                    .flatten();
                Ok(Some(RawFrame {
                    captured_at,
                    format: open.format,
                    width_px: open.width_px,
                    height_px: open.height_px,
                    bytes: buffer[..used].to_vec(),
                }))
            }
            Err(e) => {
                // After a timeout the stream's buffer queue is not in a state to go on from:
                // it is opened afresh, as after any other failure.
                self.open = None;
                Err(self.error(format!("stopped giving frames: {e}")))
            }
        }
    }

    fn name(&self) -> String {
        self.request.device.clone()
    }
}
