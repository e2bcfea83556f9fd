//! The GPS task: parses NMEA from the receiver and forwards fixes to the outbox.

use super::port::SerialRx;
use super::shared::Shared;

/// Reads the GPS UART and forwards fixes; never returns.
pub async fn run<P: SerialRx>(port: P, shared: &Shared) -> ! {
    let _ = (port, shared);
    core::future::pending().await
}

/// Records a PPS edge seen at `now_us` (call from the pin's interrupt-driven task).
pub fn on_pps_edge(shared: &Shared, now_us: u64) {
    let _ = (shared, now_us);
}
