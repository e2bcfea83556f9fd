//! State shared by the tasks: the outgoing message queue, the laser request queue and the
//! counters. One `static` of [`Shared`] lives on the board; hil-sim makes one per run.

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use protocol::{ConfigureLaserCmd, Message};

/// Messages waiting for the host link. Producers never wait: when full, the frame is dropped
/// whole and counted.
pub const OUTBOX_DEPTH: usize = 6;

/// A request for the laser task from the host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LaserRequest {
    /// Reconfigure variant and units.
    Configure(ConfigureLaserCmd),
    /// Start or stop streaming.
    SetStreaming(bool),
}

/// Everything the tasks share.
pub struct Shared {
    /// Messages for the host.
    pub outbox: Channel<CriticalSectionRawMutex, Message, OUTBOX_DEPTH>,
    /// Requests for the laser task.
    pub laser_requests: Channel<CriticalSectionRawMutex, LaserRequest, 2>,
}

impl Shared {
    /// Empty queues and zero counters.
    pub const fn new() -> Self {
        Shared { outbox: Channel::new(), laser_requests: Channel::new() }
    }
}

impl Default for Shared {
    fn default() -> Self {
        Self::new()
    }
}
