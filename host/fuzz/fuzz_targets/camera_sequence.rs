//! Arbitrary bytes into the camera sequences' readers: the KITTI calibration, times and
//! poses, the TUM calibration, frame list and ground truth, and an image file decoded as
//! grey. Nothing may panic; a refusal must name the file; what is accepted must be finite.

#![no_main]

use std::path::Path;

use host::camera::sequence::{
    decode_gray, parse_frame_list, parse_kitti_calibration, parse_kitti_poses, parse_times,
    parse_tum_calibration, parse_tum_truth,
};
use libfuzzer_sys::fuzz_target;

/// A refusal names the file it refused.
fn names<T, E: std::fmt::Display>(result: &Result<T, E>, name: &str) {
    if let Err(error) = result {
        assert!(error.to_string().contains(name), "{error}");
    }
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let path = Path::new("fuzzed.txt");
    let name = "fuzzed.txt";

    let kitti = parse_kitti_calibration(&text, path);
    names(&kitti, name);
    if let Ok(intrinsics) = kitti {
        assert!(intrinsics.iter().all(|v| v.is_finite()));
    }
    let times = parse_times(&text, path);
    names(&times, name);
    if let Ok(times) = times {
        assert!(times.iter().all(|t| t.is_finite()));
    }
    let poses = parse_kitti_poses(&text, path);
    names(&poses, name);
    if let Ok(poses) = poses {
        for (position, orientation) in poses {
            assert!(position.iter().all(|v| v.is_finite()));
            assert!(orientation.coords.iter().all(|v| v.is_finite()));
        }
    }
    let tum = parse_tum_calibration(&text, path);
    names(&tum, name);
    if let Ok(calibration) = tum {
        assert!(calibration.iter().all(|v| v.is_finite()));
    }
    let frames = parse_frame_list(&text, path);
    names(&frames, name);
    if let Ok(frames) = frames {
        assert!(
            frames
                .iter()
                .all(|(t, file)| t.is_finite() && !file.is_empty())
        );
    }
    let truth = parse_tum_truth(&text, path);
    names(&truth, name);
    if let Ok(truth) = truth {
        for pose in truth {
            assert!(pose.time_s.is_finite() && pose.position_m.iter().all(|v| v.is_finite()));
            assert!((pose.orientation.norm() - 1.0).abs() < 1e-9);
        }
    }

    let image = decode_gray(data, Path::new("fuzzed.png"));
    names(&image, "fuzzed.png");
    if let Ok(image) = image {
        assert_eq!(
            image.as_raw().len(),
            image.width() as usize * image.height() as usize
        );
    }
});
