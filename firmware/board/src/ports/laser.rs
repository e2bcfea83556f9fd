//! The SICK LMS2xx's UART (through an RS-422 transceiver): a ring-buffered DMA receiver, a DMA
//! transmitter that paces bytes at high baud rates, and run-time baud switching.
//!
//! At 500 kBd the LMS2xx needs a gap of at least 55 µs between the bytes of a telegram sent to
//! it. From [`PACED_FROM_BAUD`] on, [`write_all`](SerialTx::write_all) therefore sends one
//! byte at a time, waits until it has left the shift register, then idles for
//! [`INTER_BYTE_GAP`]. Commands are a few bytes long, so the cost is negligible.

use embassy_stm32::mode::Async;
use embassy_stm32::usart::UartTx;
use embassy_time::{Duration, Timer};
use firmware::tasks::{BaudRate, PortError, SerialRx, SerialTx};

use super::RingRxPort;

/// Baud rate from which bytes sent to the laser are paced.
pub const PACED_FROM_BAUD: u32 = 500_000;

/// Idle time on the line between two paced bytes (the sensor needs at least 55 µs).
pub const INTER_BYTE_GAP: Duration = Duration::from_micros(60);

/// Both directions of the laser's UART.
pub struct LaserPort<'d> {
    rx: RingRxPort<'d>,
    tx: UartTx<'d, Async>,
    baud: u32,
}

impl<'d> LaserPort<'d> {
    /// Joins the two halves of one UART that currently runs at `baud`.
    pub fn new(tx: UartTx<'d, Async>, rx: RingRxPort<'d>, baud: u32) -> Self {
        LaserPort { rx, tx, baud }
    }
}

impl SerialRx for LaserPort<'_> {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError> {
        self.rx.read(buf).await
    }
}

impl SerialTx for LaserPort<'_> {
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), PortError> {
        if self.baud < PACED_FROM_BAUD {
            return self.tx.write(bytes).await.map_err(|_| PortError::LineError);
        }
        for byte in bytes {
            self.tx
                .write(core::slice::from_ref(byte))
                .await
                .map_err(|_| PortError::LineError)?;
            self.tx.flush().await.map_err(|_| PortError::LineError)?;
            Timer::after(INTER_BYTE_GAP).await;
        }
        Ok(())
    }
}

impl BaudRate for LaserPort<'_> {
    /// Waits until the last written byte has left the shift register, then reprograms the
    /// divider. Transmitter and receiver are halves of one USART and share its baud-rate
    /// register (BRR), so setting it through one half switches both directions. Bytes arriving
    /// during the switch may be garbled; the laser task resynchronises on the next telegram.
    async fn set_baud(&mut self, baud: u32) -> Result<(), PortError> {
        self.tx.flush().await.map_err(|_| PortError::LineError)?;
        self.tx
            .set_baudrate(baud)
            .map_err(|_| PortError::UnsupportedBaud)?;
        self.baud = baud;
        Ok(())
    }
}
