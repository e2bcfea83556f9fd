//! The camera method on real image sequences: `replay-camera` over the start of TUM
//! fr1/rpy (hand-held, turning about every axis, strong lens distortion), scored on its
//! motion-capture truth, and over the start of KITTI 07 (a car in a street) for what it
//! writes. The figures over whole sequences are `docs/camera.md`'s.

use hil_sim::camera_replay::{CameraReplayOptions, replay_camera};
use host::camera::MonoSlamOptions;

fn options(sequence: std::path::PathBuf, name: &str, first_frames: usize) -> CameraReplayOptions {
    CameraReplayOptions {
        sequence,
        out: std::env::temp_dir().join(format!("camera-{name}-{}", std::process::id())),
        first_frames: Some(first_frames),
        slam: MonoSlamOptions::default(),
        progress: false,
    }
}

#[test]
fn tum_rpy_rotation_is_tracked_against_motion_capture() {
    let test = "tum_rpy_rotation_is_tracked_against_motion_capture";
    let Some(sequence) = datasets::require("camera/tum-fr1-rpy-0000-0199", test) else {
        return;
    };
    let options = options(sequence, "tum", 100);
    let summary = replay_camera(&options).expect("replay");
    assert_eq!(summary.frames, 100);
    let error = summary.error.expect("the folder has ground truth");
    assert_eq!(error.poses, 100);
    // The camera turns by up to 90° from its first pose in these frames.
    assert!(error.rotation_error_deg < 8.0, "{error:?}");
    assert!(summary.features_measured_per_frame > 8.0, "{summary:?}");
    let trajectory =
        std::fs::read_to_string(options.out.join("trajectory.tum")).expect("trajectory");
    assert_eq!(trajectory.lines().count(), 100);
    assert!(
        trajectory
            .lines()
            .all(|l| l.split_whitespace().count() == 8)
    );
    let ply = std::fs::read_to_string(options.out.join("map.ply")).expect("map");
    assert!(ply.starts_with("ply\n"));
    assert_eq!(
        ply.lines()
            .skip_while(|l| *l != "end_header")
            .skip(1)
            .count(),
        summary.map_points
    );
    assert!(options.out.join("tracks.png").is_file());
}

#[test]
fn kitti_frames_calibration_and_truth_are_read() {
    let test = "kitti_frames_calibration_and_truth_are_read";
    let Some(sequence) = datasets::require("camera/kitti-07-0000-0159", test) else {
        return;
    };
    let read = host::camera::CameraSequence::open(&sequence).expect("KITTI layout");
    assert_eq!(read.frames.len(), 160);
    assert_eq!(read.truth.len(), 160);
    assert_eq!((read.camera.width_px, read.camera.height_px), (1226, 370));
    assert!((read.camera.fx_px - 707.0912).abs() < 1e-9);
    let options = options(sequence, "kitti", 20);
    let summary = replay_camera(&options).expect("replay");
    assert_eq!(summary.frames, 20);
    assert!(summary.error.is_some_and(|e| e.poses == 20), "{summary:?}");
}
