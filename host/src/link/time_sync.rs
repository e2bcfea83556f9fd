//! Clock synchronisation over the link: sends time-sync pings, matches their
//! acknowledgements and heartbeats, and keeps a [`ClockSync`] up to date.

use std::collections::VecDeque;

use protocol::{Message, TimeSyncPingCmd};

use super::ClockSync;

/// Pings older than this are forgotten (their acknowledgement was lost), s.
const PING_MEMORY_S: f64 = 5.0;

/// Pings sent and not yet acknowledged, and the clock mapping they feed.
#[derive(Debug, Clone, Default)]
pub struct TimeSync {
    clock: ClockSync,
    pending: VecDeque<(u16, f64)>,
}

impl TimeSync {
    /// No pings yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The ping to send now, at host time `now_s`, in a frame numbered `seq` (the encoder's
    /// next sequence number).
    pub fn ping(&mut self, seq: u16, now_s: f64) -> Message {
        while self
            .pending
            .front()
            .is_some_and(|&(_, sent_s)| now_s - sent_s > PING_MEMORY_S)
        {
            self.pending.pop_front();
        }
        self.pending.push_back((seq, now_s));
        Message::TimeSyncPing(TimeSyncPingCmd {
            host_time_us: (now_s.max(0.0) * 1e6) as u64,
        })
    }

    /// Feeds a message received at host time `recv_s`: acknowledgements of our pings give
    /// round trips, heartbeats one-way samples; anything else is ignored.
    pub fn observe(&mut self, message: &Message, recv_s: f64) {
        match message {
            Message::Ack(ack) => {
                if let Some(i) = self
                    .pending
                    .iter()
                    .position(|&(seq, _)| seq == ack.command_seq)
                {
                    let (_, sent_s) = self.pending[i];
                    self.pending.remove(i);
                    self.clock.add_round_trip(sent_s, ack.board_time_us, recv_s);
                }
            }
            Message::Heartbeat(hb) => self.clock.add_one_way(hb.uptime_us, recv_s),
            _ => {}
        }
    }

    /// Pings sent and not yet acknowledged (nor forgotten).
    pub fn pending_pings(&self) -> usize {
        self.pending.len()
    }

    /// The board → host clock mapping.
    pub fn clock(&self) -> &ClockSync {
        &self.clock
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::{AckMsg, AckResult, Kind};

    fn ack(seq: u16, board_time_us: u64) -> Message {
        Message::Ack(AckMsg {
            command_seq: seq,
            command_kind: u8::from(Kind::TimeSyncPing),
            result: AckResult::Accepted,
            board_time_us,
            host_time_us: 0,
        })
    }

    #[test]
    fn acknowledged_ping_sets_the_offset() {
        let mut sync = TimeSync::new();
        sync.ping(7, 10.0);
        sync.observe(&ack(99, 0), 10.002); // not ours
        assert!(!sync.clock().is_synchronised());
        sync.observe(&ack(7, 4_000_000), 10.002);
        assert!((sync.clock().to_host_s(4_000_000) - 10.001).abs() < 1e-9);
    }

    #[test]
    fn stale_pings_are_forgotten() {
        let mut sync = TimeSync::new();
        sync.ping(1, 0.0);
        sync.ping(2, 10.0);
        sync.observe(&ack(1, 0), 10.1);
        assert!(!sync.clock().is_synchronised());
    }
}
