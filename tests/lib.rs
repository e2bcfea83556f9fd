//! Helpers for the end-to-end tests: reading what the board sends to the host.

use std::io::Read;
use std::time::{Duration, Instant};

use host::link::LinkReader;
use protocol::Received;
use serialport::TTYPort;

/// Reads frames from the device end of the host-link pty until `done` says so or `timeout`
/// passes; returns everything received.
pub fn read_until(
    port: &mut TTYPort,
    reader: &mut LinkReader,
    timeout: Duration,
    mut done: impl FnMut(&[Received]) -> bool,
) -> Vec<Received> {
    let deadline = Instant::now() + timeout;
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    let _ = serialport::SerialPort::set_timeout(port, Duration::from_millis(50));
    while Instant::now() < deadline && !done(&got) {
        if let Ok(n) = port.read(&mut buf) {
            got.extend(reader.feed(&buf[..n]));
        }
    }
    got
}

/// Waits until `done` says so, polling every 20 ms; panics naming `what` after `timeout`.
pub fn wait_for(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + timeout;
    while !done() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `hil-sim demo` on `world` as the tests run it: as fast as the machine goes, the web view on
/// a free port of 127.0.0.1, no Foxglove stream, the laser method, outputs in `out`.
pub fn fast_demo(
    world: hil_sim::world::WorldKind,
    seed: u64,
    duration_s: f64,
    out: std::path::PathBuf,
) -> hil_sim::demo::DemoOptions {
    hil_sim::demo::DemoOptions {
        world,
        seed,
        duration_s,
        serve: std::net::SocketAddr::from(([127, 0, 0, 1], 0)),
        foxglove: None,
        out,
        realtime: false,
        linger_s: 0.0,
        camera: None,
    }
}
