//! The robot-host daemon with a camera, end to end.
//!
//! * `the_daemon_tracks_records_and_shows_a_recorded_camera`: the first frames of TUM
//!   fr1/rpy (a real hand-held camera) go in as a camera gives them (MJPEG) through the
//!   daemon's capture code, below where a V4L2 device would be read. The daemon runs the
//!   camera method on them, shows the newest with its features at `/api/camera.jpg` and in
//!   `/api/state`, and records every frame as it came; the recording's frames replay through
//!   the camera method again.
//! * `demo_camera_hands_every_frame_to_the_daemon`: `hil-sim demo --method camera`: the
//!   rendered camera of the outdoor world → the daemon's capture (8-bit grey frames) → the
//!   camera method with the board's GPS; every frame rendered is captured and recorded.

use std::fs;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::time::Duration;

use hil_sim::demo::{self, DemoOptions};
use hil_sim::run::CameraRunOptions;
use hil_sim::world::WorldKind;
use host::recording::read_recording_with_camera;
use robot_host::camera_capture::{FrameSource, SequenceSource};
use robot_host::config::{DaemonConfig, SlamMethod};
use robot_host::replay::replay;
use robot_host::runner::{Daemon, SerialPortOpener};
use system_tests::{fast_demo, wait_for};

/// Frames of the recorded sequence the daemon is given.
const FRAMES: usize = 12;
/// The JPEG quality the recorded frames are handed over at.
const QUALITY: u8 = 90;

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = fs::remove_dir_all(&dir);
    let _ = fs::create_dir_all(&dir);
    dir
}

/// A GET; returns the status code, the content type and the body.
fn get(addr: SocketAddr, path: &str) -> (u16, String, Vec<u8>) {
    let mut stream = TcpStream::connect(addr).expect("the web view accepts connections");
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .expect("timeout");
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .expect("request sent");
    let mut raw = Vec::new();
    let _ = stream.read_to_end(&mut raw);
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a header");
    let head = String::from_utf8_lossy(&raw[..split]).to_string();
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let content_type = head
        .lines()
        .find_map(|l| {
            l.to_ascii_lowercase()
                .strip_prefix("content-type:")
                .map(|v| v.trim().to_string())
        })
        .unwrap_or_default();
    (status, content_type, raw[split + 4..].to_vec())
}

#[test]
fn the_daemon_tracks_records_and_shows_a_recorded_camera() {
    let test = "the_daemon_tracks_records_and_shows_a_recorded_camera";
    let Some(sequence) = datasets::require("camera/tum-fr1-rpy-0000-0199", test) else {
        return;
    };
    let out = out_dir("daemon-camera-recorded");
    let source = SequenceSource::open(&sequence, false, QUALITY)
        .expect("the sequence opens")
        .first_frames(FRAMES);
    let camera = source.camera();
    let mut config = DaemonConfig::default();
    // No board: the reader keeps looking for its port while the camera runs.
    config.link.port = out.join("no-board").display().to_string();
    config.slam.method = SlamMethod::Camera;
    config.camera.device = Some("recorded".into());
    config.camera.set_model(&camera);
    config.record.path = Some(out.join("run.mcap"));
    config.web.listen = "127.0.0.1:0".parse().expect("address");
    config.web.foxglove_listen = None;
    config.validate().expect("a valid configuration");
    let opener = SerialPortOpener {
        path: config.link.port.clone(),
        baud: config.link.baud,
    };
    let daemon = Daemon::start_with_camera(&config, Box::new(opener), Some(Box::new(source)))
        .expect("the daemon starts");
    let addr = daemon.web_addr().expect("the web view runs");
    let state = daemon.state();

    // Every frame is shown, tracked or (while the method was busy) skipped.
    wait_for("every frame", Duration::from_secs(600), || {
        state
            .read()
            .ok()
            .and_then(|s| s.camera.as_ref().map(|c| c.status.frame))
            == Some(FRAMES as u64)
    });
    let (status, body_type, body) = get(addr, "/api/state");
    assert_eq!(status, 200);
    assert!(body_type.starts_with("application/json"), "{body_type}");
    let json: serde_json::Value = serde_json::from_slice(&body).expect("JSON");
    let shown = &json["camera"];
    assert_eq!(shown["frame"], FRAMES, "{shown}");
    assert_eq!(shown["frames_captured"], FRAMES, "{shown}");
    assert_eq!(shown["frames_refused"], 0, "{shown}");
    assert_eq!(shown["tracking"], true, "{shown}");
    assert_eq!(shown["size_px"], serde_json::json!([640, 480]), "{shown}");
    let (status, content_type, jpeg) = get(addr, "/api/camera.jpg");
    assert_eq!(status, 200);
    assert_eq!(content_type, "image/jpeg");
    let frame = image::load_from_memory(&jpeg).expect("a JPEG");
    assert_eq!((frame.width(), frame.height()), (640, 480));

    let outcome = daemon.stop().expect("the daemon stops");
    let pipeline = outcome.camera.expect("the camera method ran");
    let status = outcome.state.camera.expect("the camera was shown").status;
    let tracked = pipeline.poses().len();
    assert_eq!(
        tracked as u64 + status.frames_skipped,
        FRAMES as u64,
        "{status:?}"
    );
    assert!(tracked >= 2, "{status:?}");
    // The method's features after the last frame it tracked, with their search ellipses.
    if status.frames_skipped == 0 {
        assert!(status.features.len() >= 8, "{status:?}");
    }
    assert!(
        status
            .features
            .iter()
            .all(|f| f.covariance_px2[0] > 0.0 && f.covariance_px2[2] > 0.0),
        "{status:?}"
    );

    // Every frame is recorded as the camera gave it, in order.
    let recording = read_recording_with_camera(&out.join("run.mcap")).expect("the recording reads");
    assert_eq!(recording.camera_images.len(), FRAMES);
    assert_eq!(recording.camera_images_refused, 0);
    let mut again = SequenceSource::open(&sequence, false, QUALITY)
        .expect("the sequence opens")
        .first_frames(FRAMES);
    for (i, recorded) in recording.camera_images.iter().enumerate() {
        let raw = again
            .next_frame()
            .expect("a frame")
            .expect("not at the end");
        assert_eq!(recorded.data, raw.bytes, "frame {i} recorded as it came");
        assert_eq!(recorded.format, "jpeg");
    }
    assert!(
        recording
            .camera_images
            .windows(2)
            .all(|w| w[0].time_s < w[1].time_s)
    );

    // The recording replays through the camera method: every recorded frame is tracked.
    let (replayed, truncated) =
        replay(&out.join("run.mcap"), &config, None, false).expect("the recording replays");
    assert!(!truncated);
    let replayed = replayed.camera.expect("the camera method ran");
    assert_eq!(replayed.poses().len(), FRAMES);
    assert_eq!(replayed.slam_stats().frames, FRAMES);
}

#[test]
fn demo_camera_hands_every_frame_to_the_daemon() {
    let out = out_dir("daemon-demo-camera");
    let options = DemoOptions {
        camera: Some(CameraRunOptions {
            rate_hz: 5.0,
            ..CameraRunOptions::default()
        }),
        ..fast_demo(WorldKind::Outdoor, 5, 6.0, out.clone())
    };
    let mut web = None;
    let report = demo::run(&options, |ready| web = ready.web).expect("the demo runs");
    assert!(web.is_some());
    let camera = report.camera.clone().expect("the camera method ran");
    // Frames at 0, 0.2, …, 6.0 s, every one taken by the daemon's capture.
    assert_eq!(camera.frames_due, 31, "{report:#?}");
    assert_eq!(camera.frames_captured, camera.frames_due, "{report:#?}");
    assert_eq!(
        camera.frames_tracked as u64 + camera.frames_skipped,
        camera.frames_captured,
        "{report:#?}"
    );
    assert!(camera.frames_tracked >= 2, "{report:#?}");
    assert!(report.daemon_counters.gps_fixes > 0, "{report:#?}");
    let recording = read_recording_with_camera(&out.join("run.mcap")).expect("the recording reads");
    assert_eq!(recording.camera_images.len() as u64, camera.frames_captured);

    // The demo's camera is refused indoors.
    let indoor = DemoOptions {
        world: WorldKind::Indoor,
        out: out.join("indoor"),
        ..options
    };
    let error = demo::run(&indoor, |_| {}).expect_err("refused");
    assert!(error.to_string().contains("outdoors"), "{error}");
}
