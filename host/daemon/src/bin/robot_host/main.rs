//! `robot-host`: the host side of the board link.
//!
//! `robot-host run --port /dev/ttyACM0` is the daemon: it reads the board, runs the SLAM
//! pipelines, records to MCAP, and serves the web view and the live Foxglove stream.
//! `robot-host replay FILE.mcap` runs a recording through the same pipelines.
//! `robot-host config` prints the configuration with every default.
//!
//! `robot-host monitor --port /dev/ttyACM0` opens the board's serial port (USB CDC-ACM, the
//! UART fallback, or a hil-sim pty), keeps the board clock synchronised with time-sync pings,
//! prints every message as one JSON line on stdout and the link accounting once a second on
//! stderr, and reopens the port after an unplug without losing its counters.

mod georef_info;

use std::io::{self, BufWriter, Read, Write};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use host::link::{ClockSync, LinkReader, TimeSync};
use protocol::{
    AngularResolution, ConfigureLaserCmd, Encoder, MAX_WIRE_LEN, Message, RangeUnit, Received,
    ScanAngle, SetStreamingCmd,
};
use serde_json::json;

/// Host software for the sensor interface board.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

mod daemon_cli;

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the daemon: read the board, map, record, serve the web view.
    Run(daemon_cli::RunArgs),
    /// Replay an MCAP recording through the pipelines and write the outputs.
    Replay(daemon_cli::ReplayArgs),
    /// Print the configuration (a file's, with flags applied, or the defaults) as TOML.
    Config(daemon_cli::ConfigArgs),
    /// Print every message from the board as JSON lines, with link accounting on stderr.
    Monitor(MonitorArgs),
    /// Print a geo-referenced image's size, CRS and WGS84 corners as JSON.
    GeorefInfo(georef_info::GeorefInfoArgs),
}

#[derive(Debug, clap::Args)]
struct MonitorArgs {
    /// Serial port of the board: /dev/ttyACM0 for USB, a UART adapter, or a hil-sim pty.
    #[arg(long)]
    port: String,
    /// Baud rate (used by the UART link; USB CDC-ACM ignores it).
    #[arg(long, default_value_t = 921_600)]
    baud: u32,
    /// Stop after this many seconds (run until interrupted if absent).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Configure the laser on start: ANGLE_DEG,RESOLUTION_DEG,UNIT, e.g. 180,0.5,mm.
    #[arg(long, value_parser = parse_laser_config)]
    configure: Option<ConfigureLaserCmd>,
    /// Ask the board to stop laser streaming on start.
    #[arg(long)]
    stop_streaming: bool,
    /// Print one line per scan with its range words (default: without them).
    #[arg(long)]
    scan_values: bool,
}

fn parse_laser_config(s: &str) -> Result<ConfigureLaserCmd, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [angle, res, unit] = parts.as_slice() else {
        return Err(format!(
            "expected ANGLE,RESOLUTION,UNIT such as 180,0.5,mm, got {s:?}"
        ));
    };
    let angle = match *angle {
        "100" => ScanAngle::Deg100,
        "180" => ScanAngle::Deg180,
        other => return Err(format!("angle must be 100 or 180, got {other:?}")),
    };
    let resolution = match *res {
        "0.25" => AngularResolution::Quarter,
        "0.5" => AngularResolution::Half,
        "1" | "1.0" => AngularResolution::One,
        other => return Err(format!("resolution must be 0.25, 0.5 or 1, got {other:?}")),
    };
    let unit = match *unit {
        "mm" => RangeUnit::Mm,
        "cm" => RangeUnit::Cm,
        other => return Err(format!("unit must be mm or cm, got {other:?}")),
    };
    let cmd = ConfigureLaserCmd {
        angle,
        resolution,
        unit,
    };
    if !cmd.is_supported() {
        return Err("0.25° resolution needs the 100° field of view".into());
    }
    Ok(cmd)
}

fn main() -> ExitCode {
    robot_host::memory_policy::settle_allocator();
    let cli = Cli::parse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(io::stderr)
        .init();
    let result = match cli.command {
        Command::GeorefInfo(args) => return georef_info::run(&args),
        Command::Run(args) => daemon_cli::run(&args),
        Command::Replay(args) => daemon_cli::replay_file(&args),
        Command::Config(args) => args.resolve().map(|c| print!("{}", c.to_toml())),
        Command::Monitor(args) => monitor(&args).map_err(|e| e.to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("robot-host: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Encodes and writes one command frame.
fn send(
    port: &mut dyn serialport::SerialPort,
    encoder: &mut Encoder,
    message: &Message,
) -> io::Result<()> {
    let mut out = [0u8; MAX_WIRE_LEN];
    let frame = encoder
        .encode(message, &mut out)
        .map_err(|e| io::Error::other(e.to_string()))?;
    port.write_all(frame)
}

fn open(args: &MonitorArgs) -> io::Result<Box<dyn serialport::SerialPort>> {
    serialport::new(&args.port, args.baud)
        .timeout(Duration::from_millis(100))
        .open()
        .map_err(|e| io::Error::other(format!("cannot open {}: {e}", args.port)))
}

fn monitor(args: &MonitorArgs) -> io::Result<()> {
    let start = Instant::now();
    let now_s = || start.elapsed().as_secs_f64();
    let mut port = open(args)?;
    let mut reader = LinkReader::new();
    let mut sync = TimeSync::new();
    let mut encoder = Encoder::new();
    let mut out = BufWriter::new(io::stdout().lock());
    let mut buf = [0u8; 4096];
    let mut next_ping_s = 0.0;
    let mut next_report_s = 1.0;
    let mut started = false;

    loop {
        if args.duration_s.is_some_and(|d| now_s() >= d) {
            break;
        }
        if !started {
            if let Some(cmd) = args.configure {
                send(port.as_mut(), &mut encoder, &Message::ConfigureLaser(cmd))?;
            }
            if args.stop_streaming {
                send(
                    port.as_mut(),
                    &mut encoder,
                    &Message::SetStreaming(SetStreamingCmd { enabled: false }),
                )?;
            }
            started = true;
        }
        if now_s() >= next_ping_s {
            next_ping_s += 1.0;
            let ping = sync.ping(encoder.next_seq(), now_s());
            send(port.as_mut(), &mut encoder, &ping)?;
        }
        match port.read(&mut buf) {
            Ok(0) => {}
            Ok(n) => {
                let recv_s = now_s();
                for r in reader.feed(&buf[..n]) {
                    sync.observe(&r.message, recv_s);
                    writeln!(out, "{}", describe(&r, sync.clock(), args.scan_values))?;
                }
            }
            Err(e) if e.kind() == io::ErrorKind::TimedOut => {}
            Err(e) => {
                eprintln!("robot-host: {} read failed ({e}); reopening", args.port);
                port = reopen(args)?;
                reader.reconnected();
            }
        }
        if now_s() >= next_report_s {
            next_report_s += 1.0;
            out.flush()?;
            report(&reader, sync.clock());
        }
    }
    out.flush()?;
    report(&reader, sync.clock());
    Ok(())
}

fn reopen(args: &MonitorArgs) -> io::Result<Box<dyn serialport::SerialPort>> {
    loop {
        std::thread::sleep(Duration::from_millis(500));
        if let Ok(port) = open(args) {
            return Ok(port);
        }
    }
}

fn report(reader: &LinkReader, clock: &ClockSync) {
    let s = reader.stats();
    eprintln!(
        "{}",
        json!({
            "bytes": s.bytes, "frames": s.frames, "lost": s.lost, "crc_errors": s.crc_errors,
            "cobs_errors": s.cobs_errors, "oversize": s.oversize, "truncated": s.truncated,
            "unsupported_version": s.unsupported_version, "unknown_kind": s.unknown_kind,
            "malformed": s.malformed, "clock_synchronised": clock.is_synchronised(),
            "clock_drift_ppm": clock.drift_ppm(),
        })
    );
}

fn describe(r: &Received, clock: &ClockSync, scan_values: bool) -> serde_json::Value {
    let seq = r.header.seq;
    match &r.message {
        Message::Scan(s) => {
            let mut v = json!({
                "kind": "scan", "seq": seq, "stamp_us": s.stamp_us, "host_time_s": clock.to_host_s(s.stamp_us),
                "scan_counter": s.scan_counter, "start_angle_cdeg": s.start_angle_cdeg,
                "step_angle_cdeg": s.step_angle_cdeg, "unit": s.unit, "count_word": s.count_word,
                "values": s.values.len(), "status": s.status, "sensor_indices": s.sensor_indices,
            });
            if scan_values {
                v["values"] = json!(s.values.as_slice());
            }
            v
        }
        Message::GpsFix(f) => json!({
            "kind": "gps_fix", "seq": seq, "host_time_s": clock.to_host_s(f.stamp_us), "fix": f,
            "lat_deg": f.position.map(|p| p.lat_deg()), "lon_deg": f.position.map(|p| p.lon_deg()),
        }),
        Message::Nmea(n) => {
            json!({"kind": "nmea", "seq": seq, "stamp_us": n.stamp_us, "sentence": n.sentence.as_str()})
        }
        Message::Status(s) => json!({"kind": "status", "seq": seq, "status": s}),
        Message::Heartbeat(h) => json!({"kind": "heartbeat", "seq": seq, "uptime_us": h.uptime_us}),
        Message::Log(l) => {
            json!({"kind": "log", "seq": seq, "stamp_us": l.stamp_us, "level": l.level, "text": l.text.as_str()})
        }
        Message::Ack(a) => json!({"kind": "ack", "seq": seq, "ack": a}),
        Message::Pps(p) => json!({
            "kind": "pps", "seq": seq, "edge_us": p.edge_us, "count": p.count,
            "host_time_s": clock.to_host_s(p.edge_us),
        }),
        other => json!({"kind": "unexpected", "seq": seq, "message_kind": u8::from(other.kind())}),
    }
}
