//! [`SerialRx`] over embassy-stm32's [`RingBufferedUartRx`]: the DMA writes every received
//! byte into a circular buffer in the background, so nothing is lost while the reading task
//! is busy, as long as it catches up before the buffer wraps.

use embassy_stm32::usart::{Error, RingBufferedUartRx};
use firmware::tasks::{PortError, SerialRx};

/// A UART receiver backed by a DMA ring buffer.
///
/// After a receive error the driver stops the DMA; the next [`read`](SerialRx::read) restarts
/// it with an empty buffer, so the caller resynchronises on fresh bytes.
pub struct RingRxPort<'d> {
    rx: RingBufferedUartRx<'d>,
}

impl<'d> RingRxPort<'d> {
    /// Wraps a ring-buffered receiver and starts reception at once, so that bytes arriving
    /// before the first `read` (a sensor's power-up message) wait in the ring.
    pub fn new(mut rx: RingBufferedUartRx<'d>) -> Self {
        rx.start_uart();
        RingRxPort { rx }
    }
}

impl SerialRx for RingRxPort<'_> {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError> {
        if buf.is_empty() {
            return Ok(0);
        }
        self.rx.read(buf).await.map_err(port_error)
    }
}

/// Maps a UART receive error: a hardware or DMA-ring overrun lost bytes; framing, noise and
/// parity errors are trouble on the line.
fn port_error(error: Error) -> PortError {
    match error {
        Error::Overrun => PortError::Overrun,
        Error::Framing | Error::Noise | Error::Parity => PortError::LineError,
        // `BufferTooLong` only concerns single DMA transfers, which the ring does not use;
        // variants added to this non-exhaustive enum later count as line errors.
        _ => PortError::LineError,
    }
}
