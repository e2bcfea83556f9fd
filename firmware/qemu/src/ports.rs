//! The ports the tasks get: the USART driver ([`crate::usart`]) with the measurement hooks of
//! [`crate::latency`] on the laser's receiver and the host link's transmitter.

use firmware::tasks::{BaudRate, PortError, SerialRx, SerialTx};

use crate::latency;
use crate::usart::{Usart, read_stamped};

/// The laser's USART: every read notes the arrival of its newest byte.
pub struct LaserPort(pub Usart);

impl SerialRx for LaserPort {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError> {
        let (n, stamp) = read_stamped(&self.0, buf).await?;
        if n > 0 {
            latency::laser_bytes_read(stamp);
        }
        Ok(n)
    }
}

impl SerialTx for LaserPort {
    /// Sends `bytes` without pacing: QEMU's USART sends a byte the moment it is written, so
    /// the gaps the board leaves between bytes at 500 kBd would not reach the line.
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), PortError> {
        self.0.write_all(bytes).await
    }
}

impl BaudRate for LaserPort {
    async fn set_baud(&mut self, baud: u32) -> Result<(), PortError> {
        self.0.set_baud(baud).await
    }
}

/// The transmitting half of the host link: notes when a scan frame starts.
pub struct LinkTx(pub Usart);

impl SerialTx for LinkTx {
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), PortError> {
        latency::frame_started(bytes);
        self.0.write_all(bytes).await
    }
}
