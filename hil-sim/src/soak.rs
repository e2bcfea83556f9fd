//! The daemon's soak test: `robot-host run`, as its own process exactly as on the robot, fed
//! by the whole emulated chain (laser and GPS emulators → the firmware tasks → a pty) for a
//! long simulated time with every kind of fault; its memory and threads sampled from
//! `/proc`, every frame accounted for, and its recording read back after a `kill -9`.
//!
//! * Memory and threads: the daemon's resident memory (`VmRSS`) and thread count are sampled
//!   every half second of wall-clock time with the frames its web view reports, and the
//!   kernel's high-water mark of the resident memory (`VmHWM`) is read and reset at each
//!   sample, so that each reading covers the half second before it. A peak is the largest
//!   `VmHWM` or `VmRSS` of the readings it spans (the kernel updates the mark lazily). The
//!   peak from the first simulated minute on, when the map, the web view and the recorder
//!   have started, is compared with the peak over the simulated minute that follows it
//!   ([`reference_window_s`]): the memory after the first minute, taken the way the peak is,
//!   since the resident memory swings by a few hundred kilobytes from one half second to the
//!   next as working sets come and go. It must stay within [`MEMORY_GROWTH_LIMIT`]. The
//!   comparison with the single sample after the first minute is reported beside it, and so
//!   is the peak of the start (the aerial image decoded for the web view), which comes before.
//! * Accounting: the simulation's own (every telegram the laser sent delivered intact or
//!   counted as rejected), and the daemon's frame count equal to what the board sent up.
//! * The kill: once the daemon has taken in the last frame it is sent `SIGKILL` after a
//!   delay drawn from the seed (somewhere in its recorder's flush cycle, which runs on the
//!   wall clock). Its recording must read, holding every frame up to its last flush: no
//!   more may be missing than the daemon took in over the last flush interval (and a
//!   second) before the kill.
//! * The web view under abuse: from the second sample on, every tenth sends a goal request
//!   with a 10 MiB body; each must be answered `413`, and the memory check above covers what
//!   they cost.

use std::fs;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::RecvTimeoutError;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use host::link::LinkReader;
use host::recording::read_recording;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robot_host::LinkCounters;
use serde::Serialize;

use crate::demo::DaemonSetup;
use crate::faults::{FaultSpec, GpsOutage};
use crate::memory_map::ResidentByKind;
use crate::proc_status::status_field;
use crate::run::{RunOptions, RunSummary, run_relayed};
use crate::world::WorldKind;

/// The peak memory may exceed the memory after the first simulated minute by this factor.
pub const MEMORY_GROWTH_LIMIT: f64 = 1.10;
/// Simulated time after which the memory and thread counts are taken as the reference, s.
pub const SETTLED_AFTER_S: f64 = 60.0;
/// Simulated time over which the memory's reference peak is taken, from [`SETTLED_AFTER_S`]
/// on, s (a quarter of what follows that on a shorter soak).
pub const REFERENCE_WINDOW_S: f64 = 60.0;
/// After the sensors stop, the daemon gets up to this long to take in the last frames.
const DRAIN: Duration = Duration::from_secs(30);
/// Every this many samples, a goal request with an [`OVERSIZED_BODY_BYTES`] body is sent.
const OVERSIZED_EVERY_SAMPLES: usize = 10;
/// The body of the oversized goal requests: 10 MiB, far over the web view's limit.
pub const OVERSIZED_BODY_BYTES: usize = 10 * 1024 * 1024;
/// How long the daemon may take to start serving its web view.
const STARTUP: Duration = Duration::from_secs(20);

/// The simulated times over which the memory's reference peak is taken, s: the minute after
/// the first, or the first quarter of what follows the first minute on a soak of less than
/// five minutes, so that the peak after it is compared with a stretch of the run.
pub fn reference_window_s(duration_s: f64) -> [f64; 2] {
    let window_s = REFERENCE_WINDOW_S.min(0.25 * (duration_s - SETTLED_AFTER_S).max(0.0));
    [SETTLED_AFTER_S, SETTLED_AFTER_S + window_s]
}

/// What to run.
#[derive(Debug, Clone)]
pub struct SoakOptions {
    /// The world: outdoors (EKF with GPS and the aerial image) exercises every fault kind.
    pub world: WorldKind,
    /// Seed of the world, the route, the noise, the faults and the moment of the kill.
    pub seed: u64,
    /// Seconds of simulated time.
    pub duration_s: f64,
    /// The faults; [`every_fault_kind`] of the duration when absent.
    pub faults: Option<FaultSpec>,
    /// The `robot-host` binary.
    pub daemon: PathBuf,
    /// Where the outputs go.
    pub out: PathBuf,
    /// Wall-clock time between two samples of the daemon's memory (the chain runs many
    /// times faster than the wall clock).
    pub sample_interval: Duration,
    /// The daemon's `[record] part_length_s` (seconds of the host's clock per part of its
    /// recording); its default when absent. The soak's simulated hour passes in minutes of
    /// the host's clock, so at the default it stays in one part; a shorter one has the
    /// read-back after the kill go through several.
    pub part_length_s: Option<f64>,
}

/// Every kind of fault `hil-sim run --faults` knows, spread over `duration_s`: bit errors,
/// lost bytes and cut telegrams all along, and in each of six equal periods a laser power
/// cycle, a GPS outage of a tenth of the period and a host-link unplug.
pub fn every_fault_kind(duration_s: f64) -> FaultSpec {
    let period_s = duration_s / 6.0;
    let starts = || (0..6).map(move |k| k as f64 * period_s);
    FaultSpec {
        ber: 1e-6,
        drop: 1e-6,
        truncate: 0.002,
        laser_restarts_s: starts().map(|t| t + 0.3 * period_s).collect(),
        gps_outages: starts()
            .map(|t| GpsOutage {
                start_s: t + 0.5 * period_s,
                duration_s: 0.1 * period_s,
            })
            .collect(),
        link_replugs_s: starts().map(|t| t + 0.8 * period_s).collect(),
    }
}

/// One sample of the daemon.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SoakSample {
    /// Wall-clock time since the daemon started serving, s.
    pub wall_s: f64,
    /// Simulated time the daemon has taken in, s: its frames over those of the whole run,
    /// times the run's duration (filled in at the end; the board's clock, which the frames
    /// carry, runs many times faster than the wall clock here).
    pub sim_s: f64,
    /// Frames the daemon has decoded, as its web view reports them.
    pub frames: u64,
    /// Resident memory, KiB.
    pub rss_kib: u64,
    /// The kernel's high-water mark of the resident memory since the previous sample (the
    /// mark is reset after each reading; since the last reset the kernel took, or over the
    /// daemon's life, where it refuses), KiB.
    pub peak_rss_kib: u64,
    /// Threads.
    pub threads: u64,
    /// Where the resident memory lies (`/proc/PID/smaps`, read just after `VmRSS`).
    pub resident: ResidentByKind,
    /// Whether the high-water mark was reset after this reading.
    pub mark_reset: bool,
}

/// The recording read back after the kill.
#[derive(Debug, Clone, Serialize)]
pub struct RecordingCheck {
    /// The reader's refusal, if it refused.
    pub error: Option<String>,
    /// Whether it ends before its footer (as a killed daemon leaves it).
    pub truncated: bool,
    /// Files it was read from (`run.mcap`, `run_1.mcap`, …; none when refused).
    pub parts: u32,
    /// Frames decoded from its raw reads.
    pub frames: u64,
    /// Frames the daemon had counted but the recording does not hold.
    pub frames_missing: u64,
    /// The most that may be missing: the frames the daemon took in over the last flush
    /// interval (and one second) of wall-clock time before the kill.
    pub frames_missing_allowed: u64,
}

/// What the soak found.
#[derive(Debug, Clone, Serialize)]
pub struct SoakReport {
    /// The world.
    pub world: String,
    /// Its seed.
    pub seed: u64,
    /// Simulated seconds.
    pub duration_s: f64,
    /// The faults, in `--faults` form.
    pub faults: String,
    /// Wall-clock seconds of the whole soak.
    pub wall_s: f64,
    /// Samples taken.
    pub samples: usize,
    /// Resident memory after the first simulated minute, KiB: one sample.
    pub rss_after_first_minute_kib: u64,
    /// The simulated times over which the reference peak is taken, s
    /// ([`reference_window_s`]).
    pub reference_window_s: [f64; 2],
    /// The daemon's peak resident memory over those times, KiB: the reference.
    pub reference_peak_rss_kib: u64,
    /// The daemon's peak resident memory from the first minute on, KiB: the largest `VmHWM`
    /// or `VmRSS` of the samples that follow it.
    pub peak_rss_kib: u64,
    /// The daemon's peak resident memory over its whole life, its start included, KiB.
    pub peak_rss_since_start_kib: u64,
    /// Whether the kernel took every reset of the high-water mark (where it did not, a
    /// reading covers more than the time since the sample before, and the peak from the
    /// first minute on may include the start).
    pub high_water_mark_resets: bool,
    /// The peak from the first minute on over the reference peak: what must stay within
    /// [`MEMORY_GROWTH_LIMIT`].
    pub peak_over_first_minute: f64,
    /// The peak from the first minute on over the single sample after the first minute.
    pub peak_over_sample_after_first_minute: f64,
    /// Where the resident memory lay after the first minute.
    pub resident_after_first_minute: ResidentByKind,
    /// Where it lay once the daemon had the last frame.
    pub resident_at_end: ResidentByKind,
    /// The median resident memory over each quarter of the simulated time from the first
    /// minute on, KiB: what stays, without the passing peaks of single samples.
    pub rss_median_by_quarter_kib: [u64; 4],
    /// Goal requests with a 10 MiB body sent.
    pub oversized_requests: u64,
    /// How many of them were answered `413 Payload Too Large`.
    pub oversized_requests_413: u64,
    /// Threads after the first simulated minute.
    pub threads_after_first_minute: u64,
    /// The most threads seen after that.
    pub threads_max: u64,
    /// The daemon's counters when it had taken in the last frame.
    pub daemon_counters: LinkCounters,
    /// Frames the board sent up, as the simulation counted them.
    pub frames_sent: u64,
    /// The simulation's accounting.
    pub simulation: RunSummary,
    /// When the daemon was killed, s after its last frame.
    pub killed_after_last_frame_s: f64,
    /// The recording read back.
    pub recording: RecordingCheck,
    /// Which checks failed (empty: the soak passed).
    pub failures: Vec<String>,
}

impl SoakReport {
    /// Whether every check passed.
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
}

/// Runs the soak; `progress` is called after every sample.
///
/// # Errors
/// The daemon or the chain could not be set up, or the daemon died or stopped answering.
/// Checks that fail are not errors: they are listed in [`SoakReport::failures`].
pub fn run(options: &SoakOptions, mut progress: impl FnMut(&SoakSample)) -> io::Result<SoakReport> {
    if !(options.duration_s.is_finite() && options.duration_s > SETTLED_AFTER_S) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("the duration must be more than {SETTLED_AFTER_S} s of simulated time"),
        ));
    }
    if !options.daemon.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::NotFound,
            format!(
                "no robot-host binary at {} (build it with `cargo build --release -p \
                 robot-host`, or name it with --daemon)",
                options.daemon.display()
            ),
        ));
    }
    fs::create_dir_all(&options.out)?;
    let faults = options
        .faults
        .clone()
        .unwrap_or_else(|| every_fault_kind(options.duration_s));
    let loopback_any_port = SocketAddr::from(([127, 0, 0, 1], 0));
    let DaemonSetup { relay, config, .. } = DaemonSetup::prepare(
        options.world,
        options.seed,
        options.duration_s,
        &options.out,
        loopback_any_port,
        Some(loopback_any_port),
    )?;
    let mut config = config;
    if let Some(part_length_s) = options.part_length_s {
        config.record.part_length_s = part_length_s;
    }
    let flush_interval_s = config.record.flush_interval_s;
    let recording_path = options.out.join("run.mcap");
    let config_path = options.out.join("robot-host.toml");
    fs::write(&config_path, config.to_toml())?;

    let mut daemon = DaemonProcess::start(&options.daemon, &config_path, &options.out)?;
    let started = Instant::now();
    let samples = Arc::new(Mutex::new(Vec::new()));
    let stop_sampling = Arc::new(AtomicBool::new(false));
    let sampler = {
        let (samples, stop) = (samples.clone(), stop_sampling.clone());
        let (pid, web, interval) = (daemon.child.id(), daemon.web, options.sample_interval);
        std::thread::spawn(move || {
            let (mut sent, mut refused) = (0u64, 0u64);
            let mut taken = 0usize;
            // Until told, or until the daemon is gone (killed on an error path).
            while !stop.load(Ordering::Relaxed) && Path::new(&format!("/proc/{pid}")).exists() {
                if let Ok(sample) = take_sample(pid, web, started) {
                    samples
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .push(sample);
                }
                if taken % OVERSIZED_EVERY_SAMPLES == 1 {
                    sent += 1;
                    refused += u64::from(post_oversized_goal(web).ok() == Some(413));
                }
                taken += 1;
                std::thread::sleep(interval);
            }
            (sent, refused)
        })
    };

    let run_options = RunOptions {
        world: options.world,
        seed: options.seed,
        duration_s: options.duration_s,
        faults: faults.clone(),
        out: options.out.join("simulation"),
        realtime: false,
        hardware: None,
        grid_every_scan: false,
        camera: None,
    };
    // The device end stays open until the daemon has read everything (see `demo`).
    let device_end = relay.device.try_clone_native().map_err(io::Error::other)?;
    let simulation = std::thread::scope(|scope| {
        let chain = scope.spawn(|| run_relayed(&run_options, relay, None));
        let mut shown = 0;
        while !chain.is_finished() {
            std::thread::sleep(Duration::from_millis(200));
            let samples = samples.lock().unwrap_or_else(|p| p.into_inner());
            for sample in &samples[shown..] {
                progress(sample);
            }
            shown = samples.len();
        }
        chain
            .join()
            .unwrap_or_else(|_| Err(io::Error::other("the simulation panicked")))
    });
    // On an error the daemon is killed when dropped, and the sampler stops with it.
    let simulation = simulation?;
    let frames_sent = simulation.counted.host_frames;
    let deadline = Instant::now() + DRAIN;
    let mut counters = daemon_counters(daemon.web)?;
    while counters.frames < frames_sent && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(100));
        counters = daemon_counters(daemon.web)?;
    }
    let last_frame_at = Instant::now();
    stop_sampling.store(true, Ordering::Relaxed);
    let (oversized_requests, oversized_requests_413) = sampler
        .join()
        .map_err(|_| io::Error::other("the sampling thread panicked"))?;
    // One last sample: the memory once the daemon has the last frame, and its peak since
    // the sampler's last sample.
    let last = take_sample(daemon.child.id(), daemon.web, started)?;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed ^ 0x50AC);
    let delay_s = rng.random_range(0.0..=flush_interval_s + 1.0);
    std::thread::sleep(Duration::from_secs_f64(delay_s).saturating_sub(last_frame_at.elapsed()));
    let killed_at_s = started.elapsed().as_secs_f64();
    daemon.kill();
    let killed_after_last_frame_s = last_frame_at.elapsed().as_secs_f64();
    drop(device_end);

    let mut samples = std::mem::take(&mut *samples.lock().unwrap_or_else(|p| p.into_inner()));
    samples.push(last);
    let frames_per_s = frames_sent as f64 / options.duration_s;
    for sample in &mut samples {
        sample.sim_s = sample.frames as f64 / frames_per_s.max(f64::MIN_POSITIVE);
    }
    write_samples(&options.out.join("soak.tsv"), &samples)?;

    // The recorder flushes on the wall clock: what it may not have flushed is what came in
    // over the last flush interval (and a second) before the kill.
    let flushed_by_s = killed_at_s - flush_interval_s - 1.0;
    let frames_surely_flushed = samples
        .iter()
        .filter(|s| s.wall_s <= flushed_by_s)
        .map(|s| s.frames)
        .max()
        .unwrap_or(0);
    let recording = check_recording(
        &recording_path,
        counters.frames,
        counters.frames.saturating_sub(frames_surely_flushed),
    );
    let settled = samples
        .iter()
        .find(|s| s.sim_s >= SETTLED_AFTER_S)
        .copied()
        .unwrap_or(last);
    let threads_max = samples
        .iter()
        .filter(|s| s.wall_s >= settled.wall_s)
        .map(|s| s.threads)
        .max()
        .unwrap_or(settled.threads);
    // `VmHWM` is kept lazily by the kernel (a reading is the larger of the last recorded
    // mark and the current resident memory), so a peak is the largest of the readings. Each
    // sample's mark covers the time since the one before: from the first minute on is what
    // the samples after the reference saw, and the reference itself.
    let peak_rss_kib =
        highest_rss_kib(samples.iter().filter(|s| s.wall_s > settled.wall_s)).max(settled.rss_kib);
    let peak_rss_since_start_kib = highest_rss_kib(&samples);
    let reference_window_s = reference_window_s(options.duration_s);
    let reference_peak_rss_kib = highest_rss_kib(
        samples
            .iter()
            .filter(|s| s.wall_s > settled.wall_s && s.sim_s <= reference_window_s[1]),
    )
    .max(settled.rss_kib);
    let peak_over_first_minute = peak_rss_kib as f64 / reference_peak_rss_kib.max(1) as f64;
    let peak_over_sample_after_first_minute = peak_rss_kib as f64 / settled.rss_kib.max(1) as f64;
    let rss_median_by_quarter_kib =
        median_rss_by_quarter_kib(&samples, settled.sim_s, options.duration_s);

    let mut failures = Vec::new();
    if !simulation.accounting_balanced {
        failures.push("the simulation's accounting does not balance".to_string());
    }
    if simulation.panics > 0 {
        failures.push(format!("{} firmware task panics", simulation.panics));
    }
    if counters.frames != frames_sent {
        failures.push(format!(
            "the daemon counted {} frames of the {frames_sent} sent",
            counters.frames
        ));
    }
    if peak_over_first_minute > MEMORY_GROWTH_LIMIT {
        failures.push(format!(
            "peak memory {} KiB is {peak_over_first_minute:.3}× that after the first minute \
             ({} KiB, the peak over simulated {:.0}–{:.0} s)",
            peak_rss_kib, reference_peak_rss_kib, reference_window_s[0], reference_window_s[1]
        ));
    }
    if threads_max > settled.threads {
        failures.push(format!(
            "threads grew from {} to {threads_max}",
            settled.threads
        ));
    }
    if oversized_requests_413 != oversized_requests {
        failures.push(format!(
            "{} of {oversized_requests} goal requests with a 10 MiB body were not answered 413",
            oversized_requests - oversized_requests_413
        ));
    }
    if let Some(error) = &recording.error {
        failures.push(format!("the recording does not read: {error}"));
    } else if recording.frames_missing > recording.frames_missing_allowed {
        failures.push(format!(
            "the recording misses {} frames (at most {} may be)",
            recording.frames_missing, recording.frames_missing_allowed
        ));
    }

    let report = SoakReport {
        world: options.world.to_string(),
        seed: options.seed,
        duration_s: options.duration_s,
        faults: faults.to_string(),
        wall_s: started.elapsed().as_secs_f64(),
        samples: samples.len(),
        rss_after_first_minute_kib: settled.rss_kib,
        reference_window_s,
        reference_peak_rss_kib,
        peak_rss_kib,
        peak_rss_since_start_kib,
        high_water_mark_resets: samples.iter().all(|s| s.mark_reset),
        peak_over_first_minute,
        peak_over_sample_after_first_minute,
        resident_after_first_minute: settled.resident,
        resident_at_end: last.resident,
        rss_median_by_quarter_kib,
        oversized_requests,
        oversized_requests_413,
        threads_after_first_minute: settled.threads,
        threads_max,
        daemon_counters: counters,
        frames_sent,
        simulation,
        killed_after_last_frame_s,
        recording,
        failures,
    };
    fs::write(
        options.out.join("soak.json"),
        serde_json::to_string_pretty(&report).map_err(io::Error::other)?,
    )?;
    Ok(report)
}

/// `robot-host run` as a child process.
struct DaemonProcess {
    child: Child,
    web: SocketAddr,
}

impl DaemonProcess {
    /// Starts the daemon with `config` (its log in `out/robot-host.log`) and waits until it
    /// prints its web view's address.
    fn start(binary: &Path, config: &Path, out: &Path) -> io::Result<Self> {
        let log = fs::File::create(out.join("robot-host.log"))?;
        let mut child = Command::new(binary)
            .args(["run", "--config"])
            .arg(config)
            .stdout(Stdio::piped())
            .stderr(log)
            .spawn()
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", binary.display())))?;
        let stdout = child
            .stdout
            .take()
            .ok_or_else(|| io::Error::other("no stdout"))?;
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if let Some(addr) = line
                    .strip_prefix("web view: http://")
                    .and_then(|rest| rest.trim_end_matches('/').parse::<SocketAddr>().ok())
                {
                    let _ = tx.send(addr);
                }
            }
        });
        let log = out.join("robot-host.log");
        match rx.recv_timeout(STARTUP) {
            Ok(web) => Ok(DaemonProcess { child, web }),
            Err(RecvTimeoutError::Timeout) => {
                let _ = child.kill();
                let _ = child.wait();
                Err(io::Error::other(format!(
                    "robot-host did not start serving within {} s (see {})",
                    STARTUP.as_secs(),
                    log.display()
                )))
            }
            Err(RecvTimeoutError::Disconnected) => {
                let status = child.wait()?;
                Err(io::Error::other(format!(
                    "robot-host stopped before serving ({status}; see {})",
                    log.display()
                )))
            }
        }
    }

    /// `SIGKILL`, then reaps it.
    fn kill(&mut self) {
        // `Child::kill` sends SIGKILL on Unix.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for DaemonProcess {
    /// A daemon left behind by an error is killed too.
    fn drop(&mut self) {
        self.kill();
    }
}

/// The daemon's memory, threads and progress now. The web view is asked first, so that what
/// answering costs falls in this sample; then the high-water mark is reset, so that the next
/// sample's covers only the time from here on (`5` resets it to the current resident memory;
/// see proc(5)). `mark_reset` says whether the kernel took the reset.
fn take_sample(pid: u32, web: SocketAddr, started: Instant) -> io::Result<SoakSample> {
    let state = api_state(web)?;
    let status = fs::read_to_string(format!("/proc/{pid}/status"))?;
    let resident = ResidentByKind::of_process(pid)?;
    let mark_reset = fs::write(format!("/proc/{pid}/clear_refs"), "5").is_ok();
    let field = |name: &str| {
        status_field(&status, name)
            .ok_or_else(|| io::Error::other(format!("/proc/{pid}/status has no {name}")))
    };
    Ok(SoakSample {
        wall_s: started.elapsed().as_secs_f64(),
        sim_s: 0.0,
        frames: state["counters"]["frames"].as_u64().unwrap_or(0),
        rss_kib: field("VmRSS:")?,
        peak_rss_kib: field("VmHWM:")?,
        threads: field("Threads:")?,
        resident,
        mark_reset,
    })
}

/// The largest reading of the high-water mark or the resident memory of `samples`, KiB.
fn highest_rss_kib<'a>(samples: impl IntoIterator<Item = &'a SoakSample>) -> u64 {
    samples
        .into_iter()
        .map(|s| s.peak_rss_kib.max(s.rss_kib))
        .max()
        .unwrap_or(0)
}

/// The daemon's link counters, from its web view.
fn daemon_counters(web: SocketAddr) -> io::Result<LinkCounters> {
    let mut state = api_state(web)?;
    serde_json::from_value(state["counters"].take()).map_err(io::Error::other)
}

/// `GET /api/state` of the daemon's web view.
fn api_state(web: SocketAddr) -> io::Result<serde_json::Value> {
    let mut stream = TcpStream::connect_timeout(&web, Duration::from_secs(5))?;
    stream.set_read_timeout(Some(Duration::from_secs(10)))?;
    write!(
        stream,
        "GET /api/state HTTP/1.1\r\nHost: {web}\r\nConnection: close\r\n\r\n"
    )?;
    let mut response = Vec::new();
    stream.read_to_end(&mut response)?;
    let response = String::from_utf8_lossy(&response);
    let (head, body) = response
        .split_once("\r\n\r\n")
        .ok_or_else(|| io::Error::other("the web view's answer has no body"))?;
    if !head.starts_with("HTTP/1.1 200") {
        return Err(io::Error::other(format!(
            "GET /api/state: {}",
            head.lines().next().unwrap_or_default()
        )));
    }
    serde_json::from_str(body).map_err(io::Error::other)
}

/// Sends `POST /api/goal` with a body of [`OVERSIZED_BODY_BYTES`] and returns the status of
/// the answer. The server may answer and close before the body is all sent: a write that
/// fails stops sending, and the answer is read all the same.
fn post_oversized_goal(web: SocketAddr) -> io::Result<u16> {
    let mut stream = TcpStream::connect_timeout(&web, Duration::from_secs(5))?;
    stream.set_read_timeout(Some(Duration::from_secs(10)))?;
    stream.set_write_timeout(Some(Duration::from_secs(10)))?;
    write!(
        stream,
        "POST /api/goal HTTP/1.1\r\nHost: {web}\r\nContent-Type: application/json\r\n\
         Content-Length: {OVERSIZED_BODY_BYTES}\r\nConnection: close\r\n\r\n"
    )?;
    let chunk = [b' '; 64 * 1024];
    for _ in 0..OVERSIZED_BODY_BYTES / chunk.len() {
        if stream.write_all(&chunk).is_err() {
            break;
        }
    }
    let mut response = Vec::new();
    let _ = stream.read_to_end(&mut response);
    let response = String::from_utf8_lossy(&response);
    response
        .split_whitespace()
        .nth(1)
        .and_then(|code| code.parse().ok())
        .ok_or_else(|| io::Error::other("no answer to the oversized goal request"))
}

/// Reads the recording a killed daemon left and counts the frames its raw reads hold.
fn check_recording(path: &Path, daemon_frames: u64, allowed: u64) -> RecordingCheck {
    match read_recording(path) {
        Ok(recording) => {
            let mut link = LinkReader::new();
            let frames: u64 = recording
                .raw_reads
                .iter()
                .map(|read| link.feed(&read.bytes).len() as u64)
                .sum();
            RecordingCheck {
                error: None,
                truncated: recording.truncated,
                parts: recording.parts,
                frames,
                frames_missing: daemon_frames.saturating_sub(frames),
                frames_missing_allowed: allowed,
            }
        }
        Err(e) => RecordingCheck {
            error: Some(e.to_string()),
            truncated: false,
            parts: 0,
            frames: 0,
            frames_missing: daemon_frames,
            frames_missing_allowed: allowed,
        },
    }
}

/// The median resident memory of the samples in each quarter of the simulated time from
/// `from_s` to `to_s`, KiB (0 for a quarter without samples).
fn median_rss_by_quarter_kib(samples: &[SoakSample], from_s: f64, to_s: f64) -> [u64; 4] {
    let quarter_s = (to_s - from_s) / 4.0;
    std::array::from_fn(|quarter| {
        let start_s = from_s + quarter as f64 * quarter_s;
        let mut rss: Vec<u64> = samples
            .iter()
            .filter(|s| s.sim_s >= start_s && s.sim_s < start_s + quarter_s)
            .map(|s| s.rss_kib)
            .collect();
        rss.sort_unstable();
        rss.get(rss.len() / 2).copied().unwrap_or(0)
    })
}

/// Writes the samples as a table: one line per sample.
fn write_samples(path: &Path, samples: &[SoakSample]) -> io::Result<()> {
    let mut out = io::BufWriter::new(fs::File::create(path)?);
    writeln!(
        out,
        "wall_s\tsim_s\tframes\trss_kib\tpeak_rss_kib\tthreads\texecutable_kib\tlibraries_kib\t\
         heap_kib\tother_anonymous_kib"
    )?;
    for s in samples {
        let r = &s.resident;
        writeln!(
            out,
            "{:.1}\t{:.1}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
            s.wall_s,
            s.sim_s,
            s.frames,
            s.rss_kib,
            s.peak_rss_kib,
            s.threads,
            r.executable_kib,
            r.libraries_kib,
            r.heap_kib,
            r.other_anonymous_kib
        )?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fault_kind_holds_each_kind_and_parses_back() {
        let faults = every_fault_kind(3600.0);
        assert!(faults.ber > 0.0 && faults.drop > 0.0 && faults.truncate > 0.0);
        assert_eq!(faults.laser_restarts_s.len(), 6);
        assert_eq!(faults.gps_outages.len(), 6);
        assert_eq!(faults.link_replugs_s.len(), 6);
        assert!(faults.link_replugs_s.iter().all(|&t| t < 3600.0));
        let parsed: FaultSpec = faults.to_string().parse().unwrap();
        assert_eq!(parsed, faults);
    }

    #[test]
    fn the_reference_is_the_minute_after_the_first_or_a_quarter_of_a_short_soak() {
        assert_eq!(reference_window_s(3600.0), [60.0, 120.0]);
        assert_eq!(reference_window_s(300.0), [60.0, 120.0]);
        assert_eq!(reference_window_s(90.0), [60.0, 67.5]);
        assert_eq!(reference_window_s(30.0), [60.0, 60.0]);
    }

    fn sample(sim_s: f64, rss_kib: u64) -> SoakSample {
        SoakSample {
            wall_s: 0.0,
            sim_s,
            frames: 0,
            rss_kib,
            peak_rss_kib: rss_kib,
            threads: 1,
            resident: ResidentByKind::default(),
            mark_reset: true,
        }
    }

    #[test]
    fn medians_are_taken_per_quarter_after_the_first_minute() {
        // Before the first minute, and one passing peak in the second quarter.
        let samples: Vec<SoakSample> = [
            (10.0, 99_000),
            (60.0, 100),
            (70.0, 102),
            (80.0, 101),
            (110.0, 200),
            (120.0, 9_000),
            (130.0, 201),
            (160.0, 300),
            (210.0, 400),
        ]
        .iter()
        .map(|&(t, rss)| sample(t, rss))
        .collect();
        assert_eq!(
            median_rss_by_quarter_kib(&samples, 60.0, 260.0),
            [101, 201, 300, 400]
        );
        assert_eq!(median_rss_by_quarter_kib(&samples, 1000.0, 2000.0), [0; 4]);
    }
}
