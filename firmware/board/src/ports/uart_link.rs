//! The transmitting half of the host link over a UART (feature `uart-link`); the receiving
//! half is a [`RingRxPort`](super::RingRxPort).

use embassy_stm32::mode::Async;
use embassy_stm32::usart::UartTx;
use firmware::tasks::{PortError, SerialTx};

/// Longest single DMA transfer (the stream's item counter is 16 bits wide).
const MAX_DMA_LEN: usize = u16::MAX as usize;

/// A DMA UART transmitter towards the host. A UART cannot tell whether anyone listens, so
/// writes never report [`PortError::Disconnected`].
pub struct UartLinkTx<'d> {
    tx: UartTx<'d, Async>,
}

impl<'d> UartLinkTx<'d> {
    /// Wraps a DMA transmitter.
    pub fn new(tx: UartTx<'d, Async>) -> Self {
        UartLinkTx { tx }
    }
}

impl SerialTx for UartLinkTx<'_> {
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), PortError> {
        for chunk in bytes.chunks(MAX_DMA_LEN) {
            self.tx
                .write(chunk)
                .await
                .map_err(|_| PortError::LineError)?;
        }
        Ok(())
    }
}
