//! Arbitrary bytes as a camera's frame, into the daemon's capture code below the device read
//! (`robot_host::camera_capture::CapturedFrame::from_raw`): the first byte picks the pixel
//! format (MJPEG, YUYV, grey), the next four the claimed width and height (up to 1023 px),
//! the rest are the frame. Nothing may panic; a refused frame's message names its format and
//! claimed size; an accepted one is a grey image of exactly the claimed size with a JPEG
//! beside it that decodes to that size.

#![no_main]

use libfuzzer_sys::fuzz_target;
use robot_host::camera_capture::{CaptureError, CapturedFrame, PixelFormat, RawFrame};

fuzz_target!(|data: &[u8]| {
    let Some((&[format, w0, w1, h0, h1], bytes)) = data.split_first_chunk::<5>() else {
        return;
    };
    let format = match format % 3 {
        0 => PixelFormat::Mjpeg,
        1 => PixelFormat::Yuyv,
        _ => PixelFormat::Grey,
    };
    let width_px = u32::from(u16::from_le_bytes([w0, w1]) % 1024);
    let height_px = u32::from(u16::from_le_bytes([h0, h1]) % 1024);
    let raw = RawFrame {
        captured_at: None,
        format,
        width_px,
        height_px,
        bytes: bytes.to_vec(),
    };
    match CapturedFrame::from_raw(raw, 75) {
        Ok(frame) => {
            assert_eq!(frame.gray.dimensions(), (width_px, height_px));
            let decoded = image::load_from_memory(&frame.jpeg).expect("the JPEG decodes");
            assert_eq!((decoded.width(), decoded.height()), (width_px, height_px));
        }
        Err(error @ CaptureError::BadFrame { .. }) => {
            let message = error.to_string();
            assert!(
                message.contains(&format!("{format:?}"))
                    && message.contains(&format!("{width_px}×{height_px}")),
                "{message}"
            );
        }
        Err(error) => panic!("a frame refused as something else: {error}"),
    }
});
