//! Frames from the robot computer's camera, as the camera method takes them.
//!
//! A [`FrameSource`] gives the device's frames in the device's own pixel format
//! ([`RawFrame`]): a V4L2 camera ([`crate::camera_v4l2`]), or a recorded sequence replayed at
//! its own rate ([`SequenceSource`]). Everything below the device read is shared by both:
//! [`CapturedFrame::from_raw`] turns a raw frame into the 8-bit grey image the camera method
//! tracks and the JPEG that the recording and the web view keep (a camera's MJPEG frame is
//! kept as it came, an uncompressed one is compressed once). The method tracks the frame as
//! the JPEG holds it, so that a replay of the recording sees what the live run saw. A frame that cannot be decoded
//! is refused with the reason, and the capture goes on with the next.

use std::io::Cursor;
use std::path::Path;
use std::time::{Duration, Instant};

use host::camera::CameraSequence;
use image::codecs::jpeg::JpegEncoder;
use image::{GrayImage, ImageFormat};

/// A device's pixel format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelFormat {
    /// Motion JPEG: each frame a JPEG file.
    Mjpeg,
    /// YUV 4:2:2, two pixels in four bytes `Y0 U Y1 V`.
    Yuyv,
    /// 8-bit grey, a byte a pixel.
    Grey,
}

impl PixelFormat {
    /// The format's V4L2 code.
    pub fn fourcc(self) -> [u8; 4] {
        match self {
            PixelFormat::Mjpeg => *b"MJPG",
            PixelFormat::Yuyv => *b"YUYV",
            PixelFormat::Grey => *b"GREY",
        }
    }

    /// The format of a V4L2 code, when the daemon reads it.
    pub fn from_fourcc(code: [u8; 4]) -> Option<PixelFormat> {
        [PixelFormat::Mjpeg, PixelFormat::Yuyv, PixelFormat::Grey]
            .into_iter()
            .find(|f| f.fourcc() == code)
    }
}

/// One frame as the device gave it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawFrame {
    /// When the camera took it, where the source knows (a V4L2 driver's timestamp, a
    /// simulation's clock); `None`: the frame is stamped as the read returns.
    pub captured_at: Option<Instant>,
    /// How `bytes` code the pixels.
    pub format: PixelFormat,
    /// Width, pixels.
    pub width_px: u32,
    /// Height, pixels.
    pub height_px: u32,
    /// The frame's bytes.
    pub bytes: Vec<u8>,
}

/// Why a frame or a camera cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The device cannot be opened or set up, or stopped giving frames.
    #[error("camera {device}: {message}")]
    Device {
        /// The device.
        device: String,
        /// What went wrong.
        message: String,
    },
    /// A frame whose bytes do not hold the pixels its format and size say.
    #[error("a {format:?} frame of {width_px}×{height_px} px: {message}")]
    BadFrame {
        /// Its format.
        format: PixelFormat,
        /// Its width.
        width_px: u32,
        /// Its height.
        height_px: u32,
        /// What is wrong.
        message: String,
    },
    /// A recorded sequence cannot be read.
    #[error("{0}")]
    Sequence(#[from] host::camera::SequenceError),
}

/// Where frames come from: a camera or a recorded sequence.
pub trait FrameSource: Send {
    /// Waits for the next frame. `Ok(None)`: the source has ended (a recorded sequence).
    ///
    /// # Errors
    /// The device failed; the caller logs it and asks again, so a source that can recover
    /// (a camera plugged back in) reopens itself on the next call.
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError>;

    /// The source's name, for messages.
    fn name(&self) -> String;
}

/// A frame ready for the camera method, the recording and the web view.
#[derive(Debug, Clone)]
pub struct CapturedFrame {
    /// The frame in 8-bit grey.
    pub gray: GrayImage,
    /// The frame as JPEG.
    pub jpeg: Vec<u8>,
}

impl CapturedFrame {
    /// Decodes `raw`; an uncompressed frame is compressed at `jpeg_quality` (1–100).
    ///
    /// # Errors
    /// The bytes do not hold a frame of the format and size given.
    pub fn from_raw(raw: RawFrame, jpeg_quality: u8) -> Result<CapturedFrame, CaptureError> {
        let bad = |message: String| CaptureError::BadFrame {
            format: raw.format,
            width_px: raw.width_px,
            height_px: raw.height_px,
            message,
        };
        let pixels = (raw.width_px as usize)
            .checked_mul(raw.height_px as usize)
            .filter(|&n| n > 0)
            .ok_or_else(|| bad("no pixels, or more than this computer can address".into()))?;
        match raw.format {
            PixelFormat::Mjpeg => {
                let decoded = image::load_from_memory_with_format(&raw.bytes, ImageFormat::Jpeg)
                    .map_err(|e| bad(format!("not a JPEG: {e}")))?;
                let gray = decoded.into_luma8();
                if gray.dimensions() != (raw.width_px, raw.height_px) {
                    return Err(bad(format!(
                        "the JPEG holds {}×{} px",
                        gray.width(),
                        gray.height()
                    )));
                }
                Ok(CapturedFrame {
                    gray,
                    jpeg: raw.bytes,
                })
            }
            PixelFormat::Yuyv | PixelFormat::Grey => {
                let bytes_per_pixel = if raw.format == PixelFormat::Yuyv {
                    2
                } else {
                    1
                };
                let expected = pixels
                    .checked_mul(bytes_per_pixel)
                    .ok_or_else(|| bad("more bytes than this computer can address".into()))?;
                // Drivers may pad a buffer beyond the image; fewer bytes are a cut frame.
                if raw.bytes.len() < expected {
                    return Err(bad(format!("{} bytes, {expected} needed", raw.bytes.len())));
                }
                let luma: Vec<u8> = raw.bytes[..expected]
                    .iter()
                    .step_by(bytes_per_pixel)
                    .copied()
                    .collect();
                let luma = GrayImage::from_raw(raw.width_px, raw.height_px, luma)
                    .ok_or_else(|| bad("size mismatch".into()))?;
                let jpeg = encode_jpeg(&luma, jpeg_quality).map_err(bad)?;
                // The camera method tracks what the recording keeps, so that a replay sees
                // the frames the live run saw.
                let gray = image::load_from_memory_with_format(&jpeg, ImageFormat::Jpeg)
                    .map_err(|e| bad(format!("cannot decode its JPEG: {e}")))?
                    .into_luma8();
                Ok(CapturedFrame { gray, jpeg })
            }
        }
    }
}

/// `gray` as a JPEG at `quality` (1–100).
///
/// # Errors
/// The encoder's message.
pub fn encode_jpeg(gray: &GrayImage, quality: u8) -> Result<Vec<u8>, String> {
    let mut jpeg = Vec::new();
    JpegEncoder::new_with_quality(Cursor::new(&mut jpeg), quality.clamp(1, 100))
        .encode_image(gray)
        .map_err(|e| format!("cannot compress it: {e}"))?;
    Ok(jpeg)
}

/// A recorded sequence (a KITTI- or TUM-layout folder) played as a camera would give it: each
/// frame handed over as MJPEG at its own time after the first, or as fast as asked for.
#[derive(Debug)]
pub struct SequenceSource {
    sequence: CameraSequence,
    next: usize,
    /// `None`: as fast as the caller takes them.
    started: Option<Instant>,
    paced: bool,
    jpeg_quality: u8,
}

impl SequenceSource {
    /// Opens the folder `dir`; `paced`: at the sequence's own rate (as a camera), else as fast
    /// as the frames are taken.
    ///
    /// # Errors
    /// The folder is not a sequence.
    pub fn open(dir: &Path, paced: bool, jpeg_quality: u8) -> Result<Self, CaptureError> {
        Ok(SequenceSource {
            sequence: CameraSequence::open(dir)?,
            next: 0,
            started: None,
            paced,
            jpeg_quality,
        })
    }

    /// Only the first `frames` frames.
    #[must_use]
    pub fn first_frames(mut self, frames: usize) -> Self {
        self.sequence.frames.truncate(frames);
        self
    }

    /// The sequence's camera model.
    pub fn camera(&self) -> host::camera::PinholeCamera {
        self.sequence.camera
    }

    /// Frames in the sequence.
    pub fn len(&self) -> usize {
        self.sequence.frames.len()
    }

    /// Whether it has no frames.
    pub fn is_empty(&self) -> bool {
        self.sequence.frames.is_empty()
    }
}

impl FrameSource for SequenceSource {
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError> {
        let Some(frame) = self.sequence.frames.get(self.next) else {
            return Ok(None);
        };
        if self.paced {
            let first_s = self.sequence.frames[0].time_s;
            let started = *self.started.get_or_insert_with(Instant::now);
            let due = Duration::from_secs_f64((frame.time_s - first_s).max(0.0));
            if let Some(wait) = due.checked_sub(started.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        // A frame that cannot be read is passed over, not asked for again.
        let index = self.next;
        self.next += 1;
        let gray = self.sequence.load(index)?;
        let bytes =
            encode_jpeg(&gray, self.jpeg_quality).map_err(|message| CaptureError::BadFrame {
                format: PixelFormat::Grey,
                width_px: gray.width(),
                height_px: gray.height(),
                message,
            })?;
        Ok(Some(RawFrame {
            captured_at: None,
            format: PixelFormat::Mjpeg,
            width_px: gray.width(),
            height_px: gray.height(),
            bytes,
        }))
    }

    fn name(&self) -> String {
        format!("recorded sequence ({} frames)", self.sequence.frames.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(format: PixelFormat, width_px: u32, height_px: u32, bytes: Vec<u8>) -> RawFrame {
        RawFrame {
            captured_at: None,
            format,
            width_px,
            height_px,
            bytes,
        }
    }

    /// The largest difference between two images' grey levels, pixel by pixel.
    fn largest_difference(a: &GrayImage, b: &GrayImage) -> u8 {
        a.pixels()
            .zip(b.pixels())
            .map(|(a, b)| a.0[0].abs_diff(b.0[0]))
            .max()
            .unwrap_or(0)
    }

    fn gradient(width: u32, height: u32) -> GrayImage {
        GrayImage::from_fn(width, height, |x, y| {
            image::Luma([((x * 7 + y * 3) % 251) as u8])
        })
    }

    #[test]
    fn yuyv_keeps_the_luma_as_its_jpeg_holds_it() {
        let gray = gradient(8, 4);
        let mut bytes = Vec::new();
        for (i, p) in gray.pixels().enumerate() {
            bytes.push(p.0[0]);
            bytes.push(if i % 2 == 0 { 90 } else { 240 });
        }
        bytes.extend_from_slice(&[0; 16]); // a driver's padding
        let frame =
            CapturedFrame::from_raw(raw(PixelFormat::Yuyv, 8, 4, bytes), 90).expect("decodes");
        assert_eq!(&frame.jpeg[..2], &[0xFF, 0xD8], "a JPEG");
        let decoded = image::load_from_memory(&frame.jpeg)
            .expect("decodes")
            .into_luma8();
        assert_eq!(frame.gray, decoded, "what is tracked is what is recorded");
        let worst = largest_difference(&frame.gray, &gray);
        assert!(worst <= 8, "{worst}");
    }

    #[test]
    fn mjpeg_is_decoded_and_kept_as_it_came() {
        let gray = gradient(32, 16);
        let jpeg = encode_jpeg(&gray, 95).expect("encodes");
        let frame = CapturedFrame::from_raw(raw(PixelFormat::Mjpeg, 32, 16, jpeg.clone()), 50)
            .expect("decodes");
        assert_eq!(frame.jpeg, jpeg);
        let worst = largest_difference(&frame.gray, &gray);
        assert!(worst <= 8, "{worst}");
    }

    #[test]
    fn cut_and_foreign_frames_are_refused_with_the_reason() {
        let cut = CapturedFrame::from_raw(raw(PixelFormat::Yuyv, 640, 480, vec![0; 1000]), 90)
            .expect_err("cut");
        assert!(cut.to_string().contains("614400 needed"), "{cut}");
        let foreign = CapturedFrame::from_raw(
            raw(PixelFormat::Mjpeg, 640, 480, b"not a jpeg".to_vec()),
            90,
        )
        .expect_err("foreign");
        assert!(foreign.to_string().contains("not a JPEG"), "{foreign}");
        let wrong_size = CapturedFrame::from_raw(
            raw(
                PixelFormat::Mjpeg,
                640,
                480,
                encode_jpeg(&gradient(32, 16), 90).expect("encodes"),
            ),
            90,
        )
        .expect_err("wrong size");
        assert!(wrong_size.to_string().contains("32×16"), "{wrong_size}");
    }

    #[test]
    fn fourcc_codes_round_trip() {
        for format in [PixelFormat::Mjpeg, PixelFormat::Yuyv, PixelFormat::Grey] {
            assert_eq!(PixelFormat::from_fourcc(format.fourcc()), Some(format));
        }
        assert_eq!(PixelFormat::from_fourcc(*b"NV12"), None);
    }
}
