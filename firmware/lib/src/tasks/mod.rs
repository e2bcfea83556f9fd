//! The async tasks the board runs, generic over the ports in [`port`] so that the same code
//! runs on the STM32 and on the host under embassy's std executor.
//!
//! * [`lidar::run`]: laser UART ⇄ bring-up and telegram receiver → scans to the outbox.
//! * [`gps::run`]: GPS UART → NMEA parser → fixes (and raw sentences) to the outbox.
//! * [`link::run_tx`]: outbox → frames on the host link, plus heartbeat and status.
//! * [`link::run_rx`]: host link → commands → laser requests and acknowledgements.

pub mod gps;
pub mod lidar;
pub mod link;
pub mod port;
pub mod shared;

pub use port::{BaudRate, PortError, SerialRx, SerialTx};
pub use shared::{LaserRequest, Shared, Source};
