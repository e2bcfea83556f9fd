//! State shared by the tasks: the outgoing queues, the laser request queue, the counters and
//! the sensor states. One `static` of [`Shared`] lives on the board; hil-sim makes one per run.
//!
//! Producers never wait for the host link: [`Shared::post`] drops a message whole when the
//! queue is full, counts it against the producing link, and makes the link task skip a
//! sequence number for it so the host sees the gap.

use core::cell::Cell;

use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use protocol::{ConfigureLaserCmd, GpsState, LaserState, LinkCounters, Message, StatusMsg};

/// Sensor data waiting for the host link (scans, fixes, sentences).
pub const OUTBOX_DEPTH: usize = 4;

/// Control messages waiting for the host link (acknowledgements, logs); sent before data.
pub const CONTROL_DEPTH: usize = 2;

/// A request for the laser task from the host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LaserRequest {
    /// Reconfigure variant and units.
    Configure(ConfigureLaserCmd),
    /// Start or stop streaming.
    SetStreaming(bool),
}

/// Which link produced a message, for the drop counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Source {
    /// The laser task.
    Laser,
    /// The GPS task.
    Gps,
    /// The link task itself (acknowledgements, logs).
    Board,
}

type Shared_<T> = Mutex<CriticalSectionRawMutex, Cell<T>>;

/// Everything the tasks share.
pub struct Shared {
    /// Sensor data for the host.
    pub outbox: Channel<CriticalSectionRawMutex, Message, OUTBOX_DEPTH>,
    /// Control messages for the host, sent first.
    pub control: Channel<CriticalSectionRawMutex, Message, CONTROL_DEPTH>,
    /// Requests for the laser task.
    pub laser_requests: Channel<CriticalSectionRawMutex, LaserRequest, 2>,
    /// Raised when the host asks for a status message.
    pub status_requested: Signal<CriticalSectionRawMutex, ()>,
    laser: Shared_<LinkCounters>,
    gps: Shared_<LinkCounters>,
    host: Shared_<LinkCounters>,
    laser_state: Shared_<(LaserState, u32)>,
    gps_state: Shared_<GpsState>,
    pps_edges: Shared_<(u32, u64)>,
    unsent_drops: Shared_<u16>,
}

const fn cell<T>(value: T) -> Shared_<T> {
    Mutex::new(Cell::new(value))
}

const ZERO: LinkCounters = LinkCounters {
    bytes: 0,
    telegrams: 0,
    crc_errors: 0,
    resyncs: 0,
    uart_overruns: 0,
    dropped_frames: 0,
    missed: 0,
};

impl Shared {
    /// Empty queues, zero counters, laser searching its baud rate (0: not known yet), GPS
    /// silent. Everything starts at zero so that a `static` of it costs no flash.
    pub const fn new() -> Self {
        Shared {
            outbox: Channel::new(),
            control: Channel::new(),
            laser_requests: Channel::new(),
            status_requested: Signal::new(),
            laser: cell(ZERO),
            gps: cell(ZERO),
            host: cell(ZERO),
            laser_state: cell((LaserState::DetectingBaud, 0)),
            gps_state: cell(GpsState::Silent),
            pps_edges: cell((0, 0)),
            unsent_drops: cell(0),
        }
    }

    /// Queues `message` for the host without waiting. Returns `false` if the queue was full:
    /// the message is dropped whole and counted against `source`.
    pub fn post(&self, message: Message, source: Source) -> bool {
        let sent = match source {
            Source::Board => self.control.try_send(message).is_ok(),
            Source::Laser | Source::Gps => self.outbox.try_send(message).is_ok(),
        };
        if sent {
            return true;
        }
        let counters = match source {
            Source::Laser => &self.laser,
            Source::Gps => &self.gps,
            Source::Board => &self.host,
        };
        update(counters, |c| {
            c.dropped_frames = c.dropped_frames.wrapping_add(1)
        });
        self.unsent_drops.lock(|d| d.set(d.get().wrapping_add(1)));
        false
    }

    /// Frames dropped before encoding since the last call; the link task skips that many
    /// sequence numbers.
    pub fn take_unsent_drops(&self) -> u16 {
        self.unsent_drops.lock(|d| d.replace(0))
    }

    /// Stores the laser link counters.
    pub fn set_laser_counters(&self, counters: LinkCounters) {
        store_receive_counters(&self.laser, counters);
    }

    /// Stores the GPS link counters.
    pub fn set_gps_counters(&self, counters: LinkCounters) {
        store_receive_counters(&self.gps, counters);
    }

    /// Changes the host link counters.
    pub fn update_host_counters(&self, f: impl FnOnce(&mut LinkCounters)) {
        update(&self.host, f);
    }

    /// Records the laser bring-up state and the baud rate its UART runs at.
    pub fn set_laser_state(&self, state: LaserState, baud: u32) {
        self.laser_state.lock(|s| s.set((state, baud)));
    }

    /// The laser bring-up state and baud rate.
    pub fn laser_state(&self) -> (LaserState, u32) {
        self.laser_state.lock(Cell::get)
    }

    /// Records the GPS state.
    pub fn set_gps_state(&self, state: GpsState) {
        self.gps_state.lock(|s| s.set(state));
    }

    /// Counts a PPS edge at board time `now_us`.
    pub fn record_pps_edge(&self, now_us: u64) {
        self.pps_edges.lock(|p| {
            let (count, _) = p.get();
            p.set((count.wrapping_add(1), now_us));
        });
    }

    /// PPS edges so far and the board time of the last one.
    pub fn pps_edges(&self) -> (u32, u64) {
        self.pps_edges.lock(Cell::get)
    }

    /// A status report as of board time `now_us`.
    pub fn status(&self, now_us: u64) -> StatusMsg {
        let (laser_state, laser_baud) = self.laser_state();
        StatusMsg {
            uptime_us: now_us,
            laser: self.laser.lock(Cell::get),
            gps: self.gps.lock(Cell::get),
            host: self.host.lock(Cell::get),
            laser_state,
            laser_baud,
            gps_state: self.gps_state.lock(Cell::get),
            pps_edges: self.pps_edges().0,
        }
    }
}

/// Stores a receiving task's counters, keeping the drop count that [`Shared::post`] keeps.
fn store_receive_counters(cell: &Shared_<LinkCounters>, counters: LinkCounters) {
    update(cell, |c| {
        *c = LinkCounters {
            dropped_frames: c.dropped_frames,
            ..counters
        }
    });
}

fn update(counters: &Shared_<LinkCounters>, f: impl FnOnce(&mut LinkCounters)) {
    counters.lock(|c| {
        let mut value = c.get();
        f(&mut value);
        c.set(value);
    });
}

impl Default for Shared {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::HeartbeatMsg;

    fn heartbeat() -> Message {
        Message::Heartbeat(HeartbeatMsg { uptime_us: 1 })
    }

    #[test]
    fn full_outbox_drops_whole_messages_and_counts_them() {
        let shared = Shared::new();
        for _ in 0..OUTBOX_DEPTH {
            assert!(shared.post(heartbeat(), Source::Laser));
        }
        assert!(!shared.post(heartbeat(), Source::Laser));
        assert!(!shared.post(heartbeat(), Source::Gps));
        let status = shared.status(0);
        assert_eq!(status.laser.dropped_frames, 1);
        assert_eq!(status.gps.dropped_frames, 1);
        assert_eq!(shared.take_unsent_drops(), 2);
        assert_eq!(shared.take_unsent_drops(), 0);
        // Control messages have their own queue.
        assert!(shared.post(heartbeat(), Source::Board));
    }

    #[test]
    fn counter_snapshots_keep_the_drop_count() {
        let shared = Shared::new();
        for _ in 0..=OUTBOX_DEPTH {
            shared.post(heartbeat(), Source::Laser);
        }
        shared.set_laser_counters(LinkCounters {
            bytes: 10,
            telegrams: 1,
            ..ZERO
        });
        let laser = shared.status(0).laser;
        assert_eq!(
            (laser.bytes, laser.telegrams, laser.dropped_frames),
            (10, 1, 1)
        );
    }
}
