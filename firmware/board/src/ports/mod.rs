//! Adapters from the embassy drivers to the firmware's port traits
//! ([`firmware::tasks::SerialRx`], [`SerialTx`](firmware::tasks::SerialTx),
//! [`BaudRate`](firmware::tasks::BaudRate)), one driver concept per file:
//!
//! * [`RingRxPort`]: a DMA ring-buffered UART receiver (GPS, and the host link over a UART).
//! * [`LaserPort`]: the laser's UART: ring-buffered receiver, paced transmitter, baud switching.
//! * [`UsbLinkTx`] / [`UsbLinkRx`]: the host link over USB CDC-ACM (feature `usb`).
//! * [`UartLinkTx`]: the transmitting half of the host link over a UART (feature `uart-link`).
//!
//! [`LinkTx`] and [`LinkRx`] name the host link's halves for the enabled feature; the UART
//! link is compiled whenever `usb` is off (`main.rs` rejects builds without `uart-link`).

mod laser;
mod ring_rx;
#[cfg(not(feature = "usb"))]
mod uart_link;
#[cfg(feature = "usb")]
pub mod usb_link;

pub use laser::LaserPort;
pub use ring_rx::RingRxPort;
#[cfg(not(feature = "usb"))]
pub use uart_link::UartLinkTx;
#[cfg(feature = "usb")]
pub use usb_link::{UsbLinkRx, UsbLinkTx};

/// The transmitting half of the host link.
#[cfg(feature = "usb")]
pub type LinkTx = UsbLinkTx;
/// The receiving half of the host link.
#[cfg(feature = "usb")]
pub type LinkRx = UsbLinkRx;

/// The transmitting half of the host link.
#[cfg(not(feature = "usb"))]
pub type LinkTx = UartLinkTx<'static>;
/// The receiving half of the host link.
#[cfg(not(feature = "usb"))]
pub type LinkRx = RingRxPort<'static>;
