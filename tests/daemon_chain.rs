//! The robot-host daemon end to end.
//!
//! * `demo_outdoor_maps_geo_references_and_replays_identically`: `hil-sim demo` on the
//!   outdoor world: emulated sensors → firmware tasks → pty → daemon. The daemon must account
//!   for every frame, align its map to GPS, answer `GET /api/state` and `POST /api/goal` while
//!   it runs, and write every output; replaying its MCAP recording through the same pipelines
//!   must give the same trajectory, byte for byte.
//! * `demo_indoor_builds_an_occupancy_grid`: the indoor world gives an occupancy grid and the
//!   ROS map files.
//! * `the_daemon_reopens_its_port_and_keeps_its_state`: the port vanishes under the daemon
//!   (as a USB cable pulled out) and comes back; the daemon reopens it, counts the reconnect,
//!   and its counters and map carry on.

use std::fs;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

use hil_sim::demo;
use hil_sim::pty::PtyLink;
use hil_sim::world::WorldKind;
use host::link::LinkSession;
use host::recording::{LinkDirection, part_path, read_recording};
use host::slam::{GridPipeline, GridPipelineOptions, SlamOptions};
use protocol::{Encoder, HeartbeatMsg, MAX_WIRE_LEN, MeasuringMode, Message, RangeUnit, ScanMsg};
use robot_host::config::{DaemonConfig, SlamMethod};
use robot_host::replay::replay;
use robot_host::runner::{Daemon, SerialPortOpener};
use system_tests::{fast_demo, wait_for};

/// The demos run the whole chain in real time on pseudo-terminals. Two at once on a two-core
/// machine compete for the cores the firmware's timing depends on, so they take turns.
static REAL_TIME: Mutex<()> = Mutex::new(());

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = fs::remove_dir_all(&dir);
    dir
}

/// A minimal HTTP/1.1 exchange; returns the status code and the body.
fn http(addr: SocketAddr, method: &str, path: &str, body: &str) -> (u16, String) {
    let mut stream = TcpStream::connect(addr).expect("the web view accepts connections");
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .expect("timeout");
    write!(
        stream,
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
    .expect("request sent");
    let mut raw = Vec::new();
    let _ = stream.read_to_end(&mut raw);
    let response = String::from_utf8_lossy(&raw);
    let status = response
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let body = response
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (status, body)
}

#[test]
fn demo_outdoor_maps_geo_references_and_replays_identically() {
    let _turn = REAL_TIME
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let out = out_dir("daemon-demo-outdoor");
    let mut api_checks = None;
    let options = fast_demo(WorldKind::Outdoor, 3, 25.0, out.clone());
    let report = demo::run(&options, |ready| {
        let addr = ready.web.expect("the web view runs");
        let (status, page) = http(addr, "GET", "/", "");
        assert_eq!(status, 200);
        assert!(page.contains("<canvas"), "{page}");
        let (status, _) = http(addr, "GET", "/api/image.png", "");
        assert_eq!(status, 200, "the aerial image is served");
        // Before the map is aligned to GPS, a goal is refused with a reason.
        let (status, body) = http(
            addr,
            "POST",
            "/api/goal",
            r#"{"pixel_x": 10, "pixel_y": 10}"#,
        );
        assert_eq!(status, 422, "{body}");
        let (status, body) = http(addr, "POST", "/api/goal", r#"{"pixel_x": "ten"}"#);
        assert_eq!(status, 400, "{body}");
        api_checks = Some(addr);
    })
    .expect("the demo runs");
    assert!(api_checks.is_some());

    let counters = report.daemon_counters;
    let sim = &report.simulation.counted;
    // The daemon saw exactly what the simulation's side of the link saw: every frame, and
    // the same gaps (a loaded machine can make the firmware drop a frame; both count it).
    assert_eq!(counters.frames, sim.host_frames, "{report:#?}");
    assert_eq!(
        counters.frames_lost, report.simulation.frames_lost_on_link,
        "{report:#?}"
    );
    assert!(counters.crc_errors <= sim.host_bad_frames, "{report:#?}");
    assert!(
        counters.telegrams > 500 && counters.gps_fixes > 200,
        "{counters:?}"
    );
    assert!(counters.clock_synchronised);
    assert!(
        report.geo_referenced,
        "the map is aligned to GPS: {report:#?}"
    );
    assert!(report.landmarks > 20, "{report:#?}");
    for name in [
        "trajectory.tsv",
        "map.png",
        "map_over_image.png",
        "map.geojson",
        "map.kml",
        "summary.json",
        "run.mcap",
        "aerial.tif",
    ] {
        let path = out.join(name);
        let size = fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        assert!(size > 100, "{} is missing or empty", path.display());
    }
    let geojson = fs::read_to_string(out.join("map.geojson")).expect("GeoJSON");
    assert!(geojson.contains("LineString") && geojson.contains("Point"));

    // The estimate follows the truth: the last pose lies near the route's end, in the
    // world frame (the local frame at the world's datum).
    let trajectory = fs::read_to_string(out.join("trajectory.tsv")).expect("trajectory");
    let last: Vec<f64> = trajectory
        .lines()
        .last()
        .expect("poses")
        .split('\t')
        .map(|v| v.parse().expect("number"))
        .collect();
    let truth = hil_sim::world::Scenario::generate_for(WorldKind::Outdoor, 3, 26.0);
    let end = truth.pose_at(25.0);
    let error_m = (last[1] - end.x_m).hypot(last[2] - end.y_m);
    assert!(
        error_m < 3.0,
        "final position {error_m:.2} m from the truth"
    );

    // The recording replays to the same trajectory, byte for byte.
    let mut config = DaemonConfig::default();
    config.slam.method = SlamMethod::Ekf;
    let datum = truth.datum();
    config.georef.datum_lat_lon_deg = Some([datum.lat_deg, datum.lon_deg]);
    let (outcome, truncated) =
        replay(&out.join("run.mcap"), &config, None, false).expect("the recording replays");
    assert!(!truncated);
    let replayed = out.join("replayed");
    robot_host::outputs::write_outputs(&replayed, &outcome, None).expect("outputs");
    let again = fs::read_to_string(replayed.join("trajectory.tsv")).expect("trajectory");
    assert_eq!(
        again, trajectory,
        "the replay gives the live run's trajectory"
    );
    assert_eq!(outcome.state.counters.frames, counters.frames);

    // The grid method is geo-referenced too: its trajectory aligned to the same fixes puts
    // the map in the local frame at the datum, where the goal API resolves goals.
    config.slam.method = SlamMethod::Grid;
    let (outcome, _) =
        replay(&out.join("run.mcap"), &config, None, false).expect("the recording replays");
    let state = &outcome.state;
    let enu_from_map = state.enu_from_map.expect("the grid map is aligned to GPS");
    assert_eq!(
        state.datum_lat_lon_deg,
        Some([datum.lat_deg, datum.lon_deg])
    );
    let alignment = outcome
        .grid_georef
        .as_ref()
        .and_then(|g| g.alignment())
        .expect("an alignment");
    assert!(alignment.pairs_used > 100, "{alignment:?}");
    let pose = &state.pose;
    let [east_m, north_m] = enu_from_map.transform_point([pose.x_m, pose.y_m]);
    let error_m = (east_m - end.x_m).hypot(north_m - end.y_m);
    assert!(
        error_m < 3.0,
        "the grid method's final position {error_m:.2} m from the truth ({alignment:?})"
    );
    assert!(pose.lat_deg.is_some() && !state.trajectory_wgs84.is_empty());
}

#[test]
fn demo_indoor_builds_an_occupancy_grid() {
    let _turn = REAL_TIME
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let out = out_dir("daemon-demo-indoor");
    let options = fast_demo(WorldKind::Indoor, 7, 12.0, out.clone());
    let report = demo::run(&options, |_| {}).expect("the demo runs");
    assert!(report.daemon_scans > 300, "{report:#?}");
    assert!(!report.geo_referenced);
    for name in [
        "map.png",
        "map.pgm",
        "map.yaml",
        "trajectory.tsv",
        "run.mcap",
    ] {
        assert!(out.join(name).exists(), "{name} is missing");
    }
    let yaml = fs::read_to_string(out.join("map.yaml")).expect("yaml");
    assert!(yaml.contains("resolution: 0.05"), "{yaml}");

    // The library's method 2 pipeline, fed the recorded link without the daemon, gives the
    // daemon's trajectory: the daemon adds nothing to the method.
    let recording = read_recording(&out.join("run.mcap")).expect("the recording reads");
    let mut session = LinkSession::new(MeasuringMode::DEFAULT);
    let mut pipeline = GridPipeline::new(GridPipelineOptions {
        slam: SlamOptions {
            // As the demo configures the daemon indoors.
            max_range_m: 8.0,
            ..SlamOptions::default()
        },
        map_resolution_m: 0.05,
        ..GridPipelineOptions::default()
    })
    .expect("valid options");
    for record in &recording.link {
        match record.direction {
            LinkDirection::FromBoard => {
                for event in session.feed(&record.bytes, record.time_s).events {
                    pipeline.on_event(&event);
                }
            }
            LinkDirection::ToBoard => session.replay_sent(&record.bytes, record.time_s),
            LinkDirection::Reconnect => session.reconnected(),
        }
    }
    pipeline.finish();
    let mut library = String::from("# host_time_s\tx_m\ty_m\ttheta_rad\tlost\n");
    for ((t, p), lost) in pipeline.trajectory().into_iter().zip(pipeline.lost()) {
        library.push_str(&format!(
            "{t:.6}\t{:.4}\t{:.4}\t{:.5}\t{}\n",
            p.x_m,
            p.y_m,
            p.theta_rad,
            u8::from(*lost)
        ));
    }
    let daemon = fs::read_to_string(out.join("trajectory.tsv")).expect("trajectory");
    assert_eq!(
        library, daemon,
        "the library pipeline gives the daemon's trajectory"
    );
}

/// Frames as the board sends them.
fn board_frames(encoder: &mut Encoder, messages: &[Message]) -> Vec<u8> {
    let mut bytes = Vec::new();
    for m in messages {
        let mut out = [0u8; MAX_WIRE_LEN];
        bytes.extend_from_slice(encoder.encode(m, &mut out).expect("encodes"));
    }
    bytes
}

fn scan(stamp_us: u64, counter: u32) -> Message {
    Message::Scan(ScanMsg {
        stamp_us,
        scan_counter: counter,
        start_angle_cdeg: 0,
        step_angle_cdeg: 100,
        unit: RangeUnit::Mm,
        count_word: 181,
        values: (0..181).map(|i| 2000 + (i % 7) as u16).collect(),
        status: 0,
        sensor_indices: None,
    })
}

#[test]
fn the_daemon_reopens_its_port_and_keeps_its_state() {
    let dir = out_dir("daemon-reconnect");
    fs::create_dir_all(&dir).expect("dir");
    // The daemon opens the port by a name that, as a udev symlink does, follows the device.
    let port_path = dir.join("ttyBOARD");
    let mut board = PtyLink::open().expect("pty");
    std::os::unix::fs::symlink(board.board_path(), &port_path).expect("symlink");

    let mut config = DaemonConfig::default();
    config.link.port = port_path.display().to_string();
    config.link.reopen_interval_ms = 50;
    config.slam.method = SlamMethod::Grid;
    config.web.enabled = false;
    config.web.foxglove_listen = None;
    config.record.path = Some(dir.join("run.mcap"));
    // Parts of a fifth of a second: the recording goes on in further files, which the
    // replay below reads as one.
    config.record.flush_interval_s = 0.1;
    config.record.part_length_s = 0.2;
    let opener = SerialPortOpener {
        path: config.link.port.clone(),
        baud: config.link.baud,
    };
    let daemon = Daemon::start(&config, Box::new(opener)).expect("daemon starts");
    let state = daemon.state();
    let counters = || state.read().expect("state").counters;

    let mut encoder = Encoder::new();
    let mut t_us = 0;
    let mut counter = 0;
    let mut send = |board: &mut PtyLink, n: usize| {
        for _ in 0..n {
            t_us += 26_667;
            counter += 1;
            let mut frames = board_frames(&mut encoder, &[scan(t_us, counter)]);
            if counter % 10 == 0 {
                frames.extend(board_frames(
                    &mut encoder,
                    &[Message::Heartbeat(HeartbeatMsg { uptime_us: t_us })],
                ));
            }
            board.device.write_all(&frames).expect("written");
        }
    };
    // The daemon opens the port on its own; frames sent before that are not read.
    wait_for("the port to open", Duration::from_secs(5), || {
        send(&mut board, 1);
        counters().telegrams > 0
    });
    send(&mut board, 40);
    wait_for("40 scans", Duration::from_secs(10), || {
        counters().telegrams >= 41
    });
    let before = counters();

    // Unplugged: the device goes away; a new one appears under the same name.
    drop(board);
    fs::remove_file(&port_path).expect("symlink removed");
    std::thread::sleep(Duration::from_millis(300));
    let mut board = PtyLink::open().expect("pty");
    std::os::unix::fs::symlink(board.board_path(), &port_path).expect("symlink");
    wait_for("the reconnect", Duration::from_secs(10), || {
        send(&mut board, 1);
        counters().reconnects >= 1 && counters().telegrams > before.telegrams
    });
    send(&mut board, 30);
    wait_for(
        "the scans after the reconnect",
        Duration::from_secs(10),
        || counters().telegrams >= before.telegrams + 30,
    );
    let outcome = daemon.stop().expect("stops");
    let after = outcome.state.counters;
    assert_eq!(after.reconnects, 1, "{after:?}");
    assert!(after.frames > before.frames, "{before:?} → {after:?}");
    let grid = outcome.grid.expect("the grid pipeline ran");
    assert_eq!(
        grid.trajectory().len() as u64,
        after.telegrams,
        "every scan before and after the reconnect reached the map"
    );
    // The recording holds the reconnect, so a replay counts it too.
    assert!(
        part_path(&dir.join("run.mcap"), 1).exists(),
        "the recording went on in further parts"
    );
    let (replayed, _) = replay(&dir.join("run.mcap"), &config, None, false).expect("replays");
    assert_eq!(replayed.state.counters.reconnects, 1);
    assert_eq!(replayed.state.counters.telegrams, after.telegrams);
}
