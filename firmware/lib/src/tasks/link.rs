//! The host link: frames outgoing messages, sends a heartbeat and a status report every
//! second, and obeys host commands.

use embassy_futures::select::{Either3, select3};
use embassy_time::{Duration, Instant, Timer};
use protocol::{Decoder, HeartbeatMsg, Message};

use super::port::{PortError, SerialRx, SerialTx};
use super::shared::{Shared, Source};
use crate::link::{LinkWriter, handle_command};

/// Period of the heartbeat and of the status report.
pub const STATUS_PERIOD: Duration = Duration::from_secs(1);

/// Sends control messages first, then sensor data; on each [`STATUS_PERIOD`] tick (or when the
/// host asks) a heartbeat and a status report. A frame that cannot be written (link down) is
/// dropped whole and counted. Never returns.
pub async fn run_tx<T: SerialTx>(mut tx: T, shared: &Shared) -> ! {
    let mut writer = LinkWriter::new();
    let mut next_tick = Instant::now() + STATUS_PERIOD;
    loop {
        // Control messages go first; then whichever comes: data, the tick, a status request.
        let message = if let Ok(control) = shared.control.try_receive() {
            control
        } else {
            match select3(
                shared.outbox.receive(),
                Timer::at(next_tick),
                shared.status_requested.wait(),
            )
            .await
            {
                Either3::First(data) => data,
                Either3::Second(()) => {
                    next_tick += STATUS_PERIOD;
                    let uptime_us = Instant::now().as_micros();
                    send(
                        &mut tx,
                        &mut writer,
                        shared,
                        &Message::Heartbeat(HeartbeatMsg { uptime_us }),
                    )
                    .await;
                    Message::Status(shared.status(Instant::now().as_micros()))
                }
                Either3::Third(()) => Message::Status(shared.status(Instant::now().as_micros())),
            }
        };
        send(&mut tx, &mut writer, shared, &message).await;
    }
}

async fn send<T: SerialTx>(
    tx: &mut T,
    writer: &mut LinkWriter,
    shared: &Shared,
    message: &Message,
) {
    let dropped = shared.take_unsent_drops();
    let Ok(frame) = writer.frame(message, dropped) else {
        shared.update_host_counters(|c| c.dropped_frames = c.dropped_frames.wrapping_add(1));
        return;
    };
    let len = frame.len() as u32;
    match tx.write_all(frame).await {
        Ok(()) => shared.update_host_counters(|c| {
            c.telegrams = c.telegrams.wrapping_add(1);
            c.bytes = c.bytes.wrapping_add(len);
        }),
        Err(_) => {
            shared.update_host_counters(|c| c.dropped_frames = c.dropped_frames.wrapping_add(1))
        }
    }
}

/// How long to wait before reading again when the link is down.
const RECONNECT_POLL: Duration = Duration::from_millis(50);

/// Decodes host frames, acknowledges every command and hands laser requests to the laser
/// task. Never returns.
pub async fn run_rx<R: SerialRx>(mut rx: R, shared: &Shared) -> ! {
    let mut decoder = Decoder::new();
    let mut buf = [0u8; 64];
    let mut overruns = 0u32;
    loop {
        match rx.read(&mut buf).await {
            Ok(n) => {
                for &byte in buf.get(..n).unwrap_or(&[]) {
                    if let Some(Ok(received)) = decoder.push(byte) {
                        let full = shared.laser_requests.is_full();
                        let outcome = handle_command(&received, Instant::now().as_micros(), full);
                        if let Some(request) = outcome.laser {
                            // Cannot fail: `full` was checked and only this task sends.
                            let _ = shared.laser_requests.try_send(request);
                        }
                        if outcome.status_requested {
                            shared.status_requested.signal(());
                        }
                        if let Some(ack) = outcome.ack {
                            shared.post(Message::Ack(ack), Source::Board);
                        }
                    }
                }
            }
            Err(PortError::Disconnected) => {
                decoder.reset();
                Timer::after(RECONNECT_POLL).await;
            }
            Err(PortError::Overrun) => overruns = overruns.wrapping_add(1),
            Err(_) => {}
        }
        let stats = decoder.stats();
        shared.update_host_counters(|c| {
            // Errors count what arrived from the host; bytes and telegrams what went to it.
            c.crc_errors = stats.crc_errors as u32;
            c.resyncs =
                (stats.cobs_errors + stats.truncated + stats.oversize + stats.malformed) as u32;
            c.uart_overruns = overruns;
        });
    }
}
