//! The host link over USB CDC-ACM on the OTG FS port (feature `usb`): the device descriptor,
//! the CDC-ACM class split into a sender and a receiver, and their port adapters.
//!
//! The host sees a virtual serial port (`/dev/ttyACM*` on Linux). Its line coding (baud rate,
//! parity) is ignored: data moves at USB full speed. Opening the port on the host raises DTR;
//! the board sends only while DTR is up.

use embassy_stm32::peripherals::USB_OTG_FS;
use embassy_stm32::usb::Driver;
use embassy_usb::class::cdc_acm::{CdcAcmClass, Receiver, Sender, State};
use embassy_usb::driver::EndpointError;
use embassy_usb::{Builder, UsbDevice};
use firmware::tasks::{PortError, SerialRx, SerialTx};
use static_cell::{ConstStaticCell, StaticCell};

/// The OTG FS driver the link runs on.
pub type UsbDriver = Driver<'static, USB_OTG_FS>;

/// USB vendor id. 0xc0de/0xcafe are test ids, not allocated to anyone: fine on the lab
/// bench, to be replaced by an allocated pair before the board leaves it.
pub const VENDOR_ID: u16 = 0xc0de;
/// USB product id (a test id, see [`VENDOR_ID`]).
pub const PRODUCT_ID: u16 = 0xcafe;
/// The product string the host shows.
pub const PRODUCT: &str = "Sensor interface board";

/// Max packet size of the bulk endpoints (the largest a full-speed bulk endpoint allows).
pub const MAX_PACKET: usize = 64;

static CONFIG_DESCRIPTOR: ConstStaticCell<[u8; 256]> = ConstStaticCell::new([0; 256]);
static BOS_DESCRIPTOR: ConstStaticCell<[u8; 256]> = ConstStaticCell::new([0; 256]);
static CONTROL_BUF: ConstStaticCell<[u8; 64]> = ConstStaticCell::new([0; 64]);
static CDC_STATE: StaticCell<State<'static>> = StaticCell::new();

/// Builds the USB device with one CDC-ACM function on `driver` and returns the device (to be
/// run by its own task) and the two halves of the link.
///
/// # Panics
/// If called twice (its descriptor buffers are single-use statics).
pub fn build(driver: UsbDriver) -> (UsbDevice<'static, UsbDriver>, UsbLinkTx, UsbLinkRx) {
    let mut config = embassy_usb::Config::new(VENDOR_ID, PRODUCT_ID);
    config.product = Some(PRODUCT);
    // The chip's unique id gives each board a stable /dev/serial/by-id name.
    config.serial_number = Some(embassy_stm32::uid::uid_hex());
    // The Discovery board is powered through its ST-LINK connector, not the OTG port.
    config.self_powered = true;

    let mut builder = Builder::new(
        driver,
        config,
        CONFIG_DESCRIPTOR.take(),
        BOS_DESCRIPTOR.take(),
        &mut [], // no Microsoft OS descriptors
        CONTROL_BUF.take(),
    );
    let class = CdcAcmClass::new(
        &mut builder,
        CDC_STATE.init(State::new()),
        MAX_PACKET as u16,
    );
    let (sender, receiver) = class.split();
    let device = builder.build();
    (
        device,
        UsbLinkTx { sender },
        UsbLinkRx {
            receiver,
            packet: [0; MAX_PACKET],
            start: 0,
            end: 0,
        },
    )
}

/// The sending half of the CDC-ACM link.
pub struct UsbLinkTx {
    sender: Sender<'static, UsbDriver>,
}

impl SerialTx for UsbLinkTx {
    /// Sends `bytes` in packets of [`MAX_PACKET`] bytes, then a zero-length packet when the
    /// last one was full, so that the host's read returns at the end of the write.
    ///
    /// # Errors
    /// [`PortError::Disconnected`] at once while the host has not opened the port (USB not
    /// configured, or DTR low), and when the device is reset during the write.
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), PortError> {
        if !self.sender.dtr() {
            return Err(PortError::Disconnected);
        }
        for packet in bytes.chunks(MAX_PACKET) {
            self.sender.write_packet(packet).await.map_err(link_error)?;
        }
        if !bytes.is_empty() && bytes.len() % MAX_PACKET == 0 {
            self.sender.write_packet(&[]).await.map_err(link_error)?;
        }
        Ok(())
    }
}

/// The receiving half of the CDC-ACM link. USB delivers whole packets; the adapter keeps the
/// rest of a packet for the next read when the caller's buffer is smaller.
pub struct UsbLinkRx {
    receiver: Receiver<'static, UsbDriver>,
    packet: [u8; MAX_PACKET],
    start: usize,
    end: usize,
}

impl SerialRx for UsbLinkRx {
    /// Waits until the host has configured the device, then for a packet with data.
    ///
    /// # Errors
    /// [`PortError::Disconnected`] when the device is reset or unplugged while waiting; the
    /// next call waits for the host again rather than failing at once.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError> {
        if buf.is_empty() {
            return Ok(0);
        }
        while self.start == self.end {
            self.receiver.wait_connection().await;
            let len = self
                .receiver
                .read_packet(&mut self.packet)
                .await
                .map_err(link_error)?;
            self.start = 0;
            self.end = len;
        }
        let pending = &self.packet[self.start..self.end];
        let len = pending.len().min(buf.len());
        buf[..len].copy_from_slice(&pending[..len]);
        self.start += len;
        Ok(len)
    }
}

/// Maps an endpoint error. `Disabled` means the host reset or deconfigured the device;
/// `BufferOverflow` cannot happen with packets of at most [`MAX_PACKET`] bytes and buffers
/// of [`MAX_PACKET`] bytes, and would mean data was lost.
fn link_error(error: EndpointError) -> PortError {
    match error {
        EndpointError::Disabled => PortError::Disconnected,
        EndpointError::BufferOverflow => PortError::Overrun,
    }
}
