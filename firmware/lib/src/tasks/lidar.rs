//! The laser task: brings the SICK LMS2xx up and forwards every valid scan to the outbox.
//!
//! It owns the laser UART, the telegram [`Receiver`] and the [`BringUp`] state machine. Bytes
//! are stamped at their estimated arrival: a chunk returned by the UART at `now` ends with its
//! last byte, less one character time (10 bits at the current baud) for each byte the port
//! still holds behind it ([`SerialRx::queued`]), and each earlier byte arrived one character
//! time before the next. So a task that wakes late to a backlog stamps it as the line carried
//! it, without a pause that would look like a broken telegram. A scan carries the stamp of its
//! telegram's first byte.
//!
//! The task never waits for the host link: scans are posted with [`Shared::post`], which
//! drops a whole scan when the outbox is full; `scan_counter` counts every valid scan, so
//! the host sees the gaps.

use embassy_futures::select::{Either3, select3};
use embassy_time::{Duration, Instant, Timer};
use protocol::{LinkCounters, Message};

use super::port::{BaudRate, DISCONNECTED_POLL, PortError, SerialRx, SerialTx, UartErrors};
use super::shared::{LaserRequest, Shared, Source};
use crate::sick::{
    Action, Actions, BringUp, BringUpConfig, Event, Input, Receiver, ScanRepr, ScanSlots,
    StreamingSetup,
};

/// The `B0h` measured-value reply code.
const SCAN_CODE: u8 = 0xB0;

/// Reads the laser UART, runs bring-up, forwards scans; never returns.
pub async fn run<P: SerialRx + SerialTx + BaudRate>(
    port: P,
    shared: &Shared,
    config: BringUpConfig,
) -> ! {
    let mut task = Lidar {
        port,
        shared,
        receiver: Receiver::new(),
        bringup: BringUp::new(config),
        deadline: None,
        setup: None,
        baud: 9_600,
        scans: 0,
        slots: ScanSlots::new(),
        last_stamp_us: 0,
        uart: UartErrors::default(),
    };
    let start = task.bringup.handle(Input::Start);
    task.execute(start).await;
    let mut buf = [0u8; 256];
    loop {
        task.publish();
        let wake = task.next_wake();
        let timer = async {
            match wake {
                Some(at) => Timer::at(at).await,
                None => core::future::pending().await,
            }
        };
        match select3(
            task.port.read(&mut buf),
            timer,
            shared.laser_requests.receive(),
        )
        .await
        {
            Either3::First(Ok(n)) => task.on_bytes(buf.get(..n).unwrap_or(&[])).await,
            Either3::First(Err(e)) => {
                task.uart.count(e);
                if e == PortError::Disconnected {
                    Timer::after(DISCONNECTED_POLL).await;
                }
            }
            Either3::Second(()) => task.on_timer().await,
            Either3::Third(request) => {
                let input = match request {
                    LaserRequest::Configure(cmd) => Input::Configure(cmd),
                    LaserRequest::SetStreaming(on) => Input::SetStreaming(on),
                };
                let actions = task.bringup.handle(input);
                task.execute(actions).await;
            }
        }
    }
}

struct Lidar<'s, P> {
    port: P,
    shared: &'s Shared,
    receiver: Receiver,
    bringup: BringUp,
    /// When the bring-up's one timer expires.
    deadline: Option<Instant>,
    /// How to read scans while streaming.
    setup: Option<StreamingSetup>,
    /// The rate the UART runs at.
    baud: u32,
    /// Valid scans received since boot.
    scans: u32,
    /// Scans the sensor sent that did not arrive intact.
    slots: ScanSlots,
    /// Estimated arrival of the last byte read, µs.
    last_stamp_us: u64,
    uart: UartErrors,
}

impl<P: SerialRx + SerialTx + BaudRate> Lidar<'_, P> {
    /// The earliest of the bring-up timer and, with a partial telegram buffered, the
    /// receiver's inter-byte timeout.
    fn next_wake(&self) -> Option<Instant> {
        let idle = (self.receiver.pending_bytes() > 0)
            .then(|| Instant::now() + Duration::from_micros(self.receiver.timeout_us() + 1));
        match (self.deadline, idle) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    async fn on_bytes(&mut self, bytes: &[u8]) {
        // The backlog first, then the clock: bytes arriving in between count in both.
        let behind = self.port.queued() as u64;
        let now_us = Instant::now().as_micros();
        let char_us = 10_000_000 / u64::from(self.baud.max(1));
        let last = bytes.len().saturating_sub(1) as u64 + behind;
        for (i, &byte) in bytes.iter().enumerate() {
            // Never before the previous byte: chunks may come faster than the estimate.
            let stamp_us = now_us
                .saturating_sub((last - i as u64) * char_us)
                .max(self.last_stamp_us);
            self.last_stamp_us = stamp_us;
            self.slots.on_byte(stamp_us);
            let actions = match self.receiver.push(byte, stamp_us) {
                Some(event) => handle_event(
                    &mut self.bringup,
                    self.shared,
                    self.setup,
                    &mut self.scans,
                    &mut self.slots,
                    event,
                ),
                None => continue,
            };
            let baud_before = self.baud;
            self.execute(actions).await;
            self.drain(stamp_us).await;
            if self.baud != baud_before {
                // The rest of the chunk was read at the old rate.
                return;
            }
        }
        // With bytes still queued the line is not quiet, whatever the clock says: the receiver
        // judges a pause only once it has read everything that arrived.
        self.drain(if behind > 0 {
            self.last_stamp_us
        } else {
            now_us
        })
        .await;
    }

    async fn on_timer(&mut self) {
        let now = Instant::now();
        self.drain(now.as_micros()).await;
        if self.deadline.is_some_and(|d| d <= now) {
            self.deadline = None;
            let actions = self.bringup.handle(Input::Timeout);
            self.execute(actions).await;
        }
    }

    /// Hands on every event the receiver still holds (after a timeout or a resync).
    async fn drain(&mut self, now_us: u64) {
        loop {
            let actions = match self.receiver.poll(now_us) {
                Some(event) => handle_event(
                    &mut self.bringup,
                    self.shared,
                    self.setup,
                    &mut self.scans,
                    &mut self.slots,
                    event,
                ),
                None => return,
            };
            self.execute(actions).await;
        }
    }

    async fn execute(&mut self, actions: Actions) {
        for action in actions {
            match action {
                Action::Send(request) => {
                    if let Err(e) = self.port.write_all(request.as_bytes()).await {
                        self.uart.count(e);
                    }
                }
                Action::SetBaud(baud) => {
                    if self.port.set_baud(baud).await.is_ok() {
                        self.baud = baud;
                    }
                    self.receiver.clear();
                }
                Action::StartTimer { duration_ms } => {
                    self.deadline =
                        Some(Instant::now() + Duration::from_millis(u64::from(duration_ms)));
                }
                Action::Streaming(setup) => {
                    self.slots
                        .start(setup.values_per_scan, setup.step_angle_cdeg, self.baud);
                    self.setup = Some(setup);
                }
                Action::StreamingStopped | Action::Failed => {
                    self.slots.end();
                    self.setup = None;
                }
                Action::Rejected(_) => {}
            }
        }
        self.shared.set_laser_state(self.bringup.state(), self.baud);
    }

    fn publish(&self) {
        let s = self.receiver.stats();
        self.shared.set_laser_counters(LinkCounters {
            bytes: s.bytes,
            telegrams: s.telegrams_ok,
            crc_errors: s.crc_errors,
            resyncs: s.resyncs,
            uart_overruns: self.uart.overruns,
            dropped_frames: 0,
            missed: self.slots.missed(),
        });
    }
}

/// Forwards a scan (when streaming) and lets the bring-up see every event.
fn handle_event(
    bringup: &mut BringUp,
    shared: &Shared,
    setup: Option<StreamingSetup>,
    scans: &mut u32,
    slots: &mut ScanSlots,
    event: Event<'_>,
) -> Actions {
    if let Event::Telegram {
        telegram,
        stamp_us,
        end_us,
    } = &event
        && telegram.command() == SCAN_CODE
        && let Some(setup) = setup
        && let Ok(scan) = ScanRepr::parse(telegram)
    {
        *scans = scans.wrapping_add(1);
        slots.on_scan(*end_us);
        let msg = scan.to_msg(
            *stamp_us,
            *scans,
            setup.start_angle_cdeg,
            setup.step_angle_cdeg,
        );
        shared.post(Message::Scan(msg), Source::Laser);
    }
    bringup.handle(Input::from(event))
}
