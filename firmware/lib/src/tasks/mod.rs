//! The async tasks the board runs, generic over the ports in [`port`] so that the same code
//! runs on the STM32 and on the host under embassy's std executor.

pub mod port;

pub use port::{BaudRate, PortError, SerialRx, SerialTx};
