//! End-to-end: `hil-sim run --method camera`. The robot computer's camera is rendered in the
//! seeded park while the laser and the GPS go through the firmware as ever; the camera
//! method estimates the robot from the frames, and the GPS fixes from the board put its map
//! into the world frame and give it its scale. Scored against the truth.

use std::fs;
use std::path::PathBuf;

use hil_sim::faults::FaultSpec;
use hil_sim::run::{CameraRunOptions, RunOptions, run};
use hil_sim::world::WorldKind;

fn options(world: WorldKind, name: &str) -> RunOptions {
    let out: PathBuf =
        std::env::temp_dir().join(format!("camera-run-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&out);
    RunOptions {
        world,
        seed: 5,
        duration_s: 20.0,
        faults: FaultSpec::default(),
        out,
        realtime: false,
        hardware: None,
        grid_every_scan: false,
        camera: Some(CameraRunOptions {
            rate_hz: 5.0,
            ..CameraRunOptions::default()
        }),
    }
}

/// The `t tx ty tz qx qy qz qw` lines of a TUM file.
fn tum_lines(path: &PathBuf) -> Vec<Vec<f64>> {
    fs::read_to_string(path)
        .expect("written")
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            l.split_whitespace()
                .map(|v| v.parse().expect("number"))
                .collect()
        })
        .collect()
}

#[test]
fn gps_gives_the_camera_map_its_place_and_scale() {
    let options = options(WorldKind::Outdoor, "park");
    let summary = run(&options).expect("run");
    assert!(summary.accounting_balanced, "{summary:#?}");
    let camera = summary.camera.as_ref().expect("the camera method ran");
    // A frame every 0.2 s from 0 to 20 s.
    assert_eq!(camera.frames, 101, "{camera:?}");
    assert!(camera.geo_referenced, "{camera:?}");
    // One fix per GPS epoch (10 Hz) from the first frame on, not one per NMEA sentence.
    assert!((150..=200).contains(&camera.fixes_paired), "{camera:?}");
    let scale_error = camera.scale_error.expect("both scales");
    assert!(scale_error.abs() < 0.01, "{camera:?}");
    assert!(camera.rms_position_m.expect("aligned") < 1.0, "{camera:?}");
    assert!(
        camera.mean_rotation_error_deg.expect("aligned") < 3.0,
        "{camera:?}"
    );
    // Every scan gets the camera's pose at its time, in the world frame.
    assert!(summary.estimate.rms_position_m < 1.0, "{summary:#?}");
    let estimate = tum_lines(&options.out.join("camera_trajectory.tum"));
    let truth = tum_lines(&options.out.join("camera_ground_truth.tum"));
    assert_eq!(estimate.len(), 101);
    assert_eq!(truth.len(), 101);
    assert!(estimate.iter().all(|l| l.len() == 8));
    let last = (estimate[100][1] - truth[100][1]).hypot(estimate[100][2] - truth[100][2]);
    assert!(last < 2.0, "{last} m at the last frame");
    // The path and the map's points in WGS84, about the world's datum.
    let geojson: serde_json::Value = serde_json::from_str(
        &fs::read_to_string(options.out.join("camera_map.geojson")).expect("written"),
    )
    .expect("GeoJSON");
    let features = geojson["features"].as_array().expect("features");
    assert!(features.len() > 20, "the path and the map's points");
    assert_eq!(features[0]["geometry"]["type"], "LineString");
    let kml = fs::read_to_string(options.out.join("camera_map.kml")).expect("written");
    assert!(kml.contains("<LineString>"));
    let _ = fs::remove_dir_all(&options.out);
}

#[test]
fn the_camera_method_is_refused_indoors() {
    let options = options(WorldKind::Indoor, "indoor");
    let error = run(&options).expect_err("no texture indoors");
    assert!(error.to_string().contains("outdoors"), "{error}");
    assert!(!options.out.exists());
}

#[test]
fn fused_fixes_correct_the_camera_method_and_keep_its_scale() {
    let mut options = options(WorldKind::Outdoor, "fused");
    if let Some(camera) = options.camera.as_mut() {
        camera.fuse_gps = true;
    }
    let summary = run(&options).expect("run");
    assert!(summary.accounting_balanced, "{summary:#?}");
    let camera = summary.camera.as_ref().expect("the camera method ran");
    // Fixes are fused once the map is aligned (the fixes span 20 m), and most of them then.
    assert!(camera.fixes_fused > 40, "{camera:?}");
    assert!(
        camera.fixes_fused + camera.fixes_gated <= camera.fixes_paired,
        "{camera:?}"
    );
    assert!(
        camera.scale_error.expect("both scales").abs() < 0.01,
        "{camera:?}"
    );
    assert!(camera.rms_position_m.expect("aligned") < 1.0, "{camera:?}");
    let _ = fs::remove_dir_all(&options.out);
}
