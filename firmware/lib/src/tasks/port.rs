//! The serial ports the tasks talk through. The board implements them over embassy-stm32
//! UARTs and USB; hil-sim implements them over pseudo-terminals; tests over byte buffers.

use embassy_time::Duration;

/// How long a task waits before reading again from a disconnected port.
pub(crate) const DISCONNECTED_POLL: Duration = Duration::from_millis(50);

/// Why a port operation failed. Receive errors are counted by the tasks and never stop them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PortError {
    /// The receiver lost bytes (hardware overrun or a full DMA ring).
    Overrun,
    /// A framing, parity or noise error on the line.
    LineError,
    /// The link is down (USB not configured, pty closed).
    Disconnected,
    /// The requested baud rate cannot be set.
    UnsupportedBaud,
}

/// A receiving serial port.
#[allow(async_fn_in_trait)] // Used with concrete types on one executor; no Send bound needed.
pub trait SerialRx {
    /// Waits for at least one byte and returns how many were written into `buf`.
    ///
    /// # Errors
    /// A [`PortError`] describing what the hardware saw; the port stays usable.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError>;

    /// How many received bytes the port still holds after the last [`read`](Self::read) (a
    /// DMA ring's fill level, a pty's input queue), or 0 when it cannot tell.
    ///
    /// A task that wakes late finds a backlog and reads it in several chunks; the first chunk
    /// then ended this many character times before now, not now. Stamping it as if it ended
    /// now would open a gap before it that the line never had.
    fn queued(&self) -> usize {
        0
    }
}

/// A transmitting serial port.
#[allow(async_fn_in_trait)]
pub trait SerialTx {
    /// Sends all of `bytes`.
    ///
    /// # Errors
    /// [`PortError::Disconnected`] if the link is down.
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), PortError>;
}

/// A serial port whose baud rate can change at run time (the laser's RS-422 link).
#[allow(async_fn_in_trait)]
pub trait BaudRate {
    /// Switches both directions to `baud` after everything written so far has left.
    ///
    /// # Errors
    /// [`PortError::UnsupportedBaud`] if the UART cannot produce the rate.
    async fn set_baud(&mut self, baud: u32) -> Result<(), PortError>;
}

/// Receive errors reported by a port.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct UartErrors {
    /// Overruns.
    pub overruns: u32,
    /// Framing, noise and parity errors.
    pub line_errors: u32,
    /// Reads on a disconnected port.
    pub disconnected: u32,
}

impl UartErrors {
    /// Counts one error.
    pub fn count(&mut self, error: PortError) {
        let counter = match error {
            PortError::Overrun => &mut self.overruns,
            PortError::LineError => &mut self.line_errors,
            PortError::Disconnected | PortError::UnsupportedBaud => &mut self.disconnected,
        };
        *counter = counter.wrapping_add(1);
    }
}
