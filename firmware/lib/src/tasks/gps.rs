//! The GPS task: parses NMEA from the receiver and forwards fixes (and, optionally, every raw
//! sentence for recording) to the outbox.
//!
//! A sentence is stamped with the board time at which the UART delivered the chunk holding
//! its `$`; PPS edges, when the pin is wired, are stamped by [`on_pps_edge`] at interrupt
//! time and give the precise second boundary.

use embassy_time::{Duration, Instant, Timer, with_timeout};
use protocol::{FixQuality, GpsState, LinkCounters, Message, PpsMsg};

use super::port::{DISCONNECTED_POLL, PortError, SerialRx, UartErrors};
use super::shared::{Shared, Source};
use crate::nmea::GpsReceiver;

/// With no valid sentence for this long the GPS counts as silent.
pub const SILENCE_TIMEOUT: Duration = Duration::from_secs(3);

/// Options of the GPS task.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GpsOptions {
    /// Forward every valid sentence as a raw NMEA message (for recording).
    pub passthrough: bool,
}

/// Reads the GPS UART and forwards fixes; never returns.
pub async fn run<P: SerialRx>(mut port: P, shared: &Shared, options: GpsOptions) -> ! {
    let mut receiver = GpsReceiver::new();
    let mut buf = [0u8; 128];
    let mut uart = UartErrors::default();
    let mut last_valid = None::<Instant>;
    loop {
        match with_timeout(SILENCE_TIMEOUT, port.read(&mut buf)).await {
            Ok(Ok(n)) => {
                let now = Instant::now();
                let accepted_before = receiver.stats().accepted;
                receiver.push(buf.get(..n).unwrap_or(&[]), now.as_micros(), |s| {
                    if let Some(fix) = s.fix {
                        let state = if fix.quality == FixQuality::Invalid {
                            GpsState::NoFix
                        } else {
                            GpsState::Fix
                        };
                        shared.set_gps_state(state);
                        shared.post(Message::GpsFix(fix), Source::Gps);
                    }
                    if options.passthrough {
                        shared.post(Message::Nmea(s.to_nmea_msg()), Source::Gps);
                    }
                });
                if receiver.stats().accepted != accepted_before {
                    last_valid = Some(now);
                }
            }
            Ok(Err(e)) => {
                uart.count(e);
                if e == PortError::Disconnected {
                    Timer::after(DISCONNECTED_POLL).await;
                }
            }
            Err(_timeout) => {}
        }
        if last_valid.is_none_or(|t| t.elapsed() > SILENCE_TIMEOUT) {
            shared.set_gps_state(GpsState::Silent);
        }
        let s = receiver.stats();
        shared.set_gps_counters(LinkCounters {
            bytes: s.bytes,
            telegrams: s.accepted.wrapping_add(s.unsupported),
            crc_errors: s.bad_checksum.wrapping_add(s.missing_checksum),
            resyncs: s
                .truncated
                .wrapping_add(s.too_long)
                .wrapping_add(s.non_printable)
                .wrapping_add(s.malformed),
            uart_overruns: uart.overruns,
            dropped_frames: 0,
            missed: s
                .bad_checksum
                .wrapping_add(s.missing_checksum)
                .wrapping_add(s.truncated)
                .wrapping_add(s.too_long)
                .wrapping_add(s.non_printable),
        });
    }
}

/// Records a PPS edge seen at board time `now_us` (call from the pin's edge task).
pub fn on_pps_edge(shared: &Shared, now_us: u64) {
    shared.record_pps_edge(now_us);
    let (count, _) = shared.pps_edges();
    shared.post(
        Message::Pps(PpsMsg {
            edge_us: now_us,
            count,
        }),
        Source::Gps,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pps_edges_are_counted_and_sent_with_their_time() {
        let shared = Shared::new();
        on_pps_edge(&shared, 1_000_000);
        on_pps_edge(&shared, 2_000_013);
        assert_eq!(shared.pps_edges(), (2, 2_000_013));
        assert_eq!(shared.status(0).pps_edges, 2);
        let sent: Vec<Message> = core::iter::from_fn(|| shared.outbox.try_receive().ok()).collect();
        assert_eq!(
            sent,
            [
                Message::Pps(PpsMsg {
                    edge_us: 1_000_000,
                    count: 1
                }),
                Message::Pps(PpsMsg {
                    edge_us: 2_000_013,
                    count: 2
                }),
            ]
        );
    }
}
