//! Sensor interface board on an STM32F407G-DISC1: binds the `firmware` library's tasks to
//! pins, DMA streams and interrupts. Everything else lives in the library.
//!
//! # Tasks
//!
//! | task         | executor                 | reads                                | sends to                                     |
//! |--------------|--------------------------|--------------------------------------|----------------------------------------------|
//! | `lidar`      | thread                   | laser UART (USART3), `laser_requests`| scans → `outbox`; commands and baud → laser  |
//! | `gps`        | thread                   | GPS UART (UART4, receive only)       | fixes → `outbox`                             |
//! | `pps`        | interrupt (UART5 vector) | PPS rising edges (EXTI10)            | edge time in board µs → `gps::on_pps_edge`   |
//! | `link_tx`    | thread                   | `outbox`                             | frames → host link                           |
//! | `link_rx`    | thread                   | host link                            | commands → `laser_requests`, acks → `outbox` |
//! | `usb_device` | thread (feature `usb`)   | USB bus                              | enumeration and control requests             |
//!
//! ```text
//! LMS2xx ⇄ RS-422 ⇄ USART3 ⇄ lidar ──scans──┐
//! GPS ── NMEA ──> UART4 ──> gps ──fixes─────┼──> SHARED.outbox ──> link_tx ──> USB CDC-ACM ──> host
//! GPS PPS ──> EXTI10 ──> pps ──> gps state  │                                  (or USART2)
//! host ──> link_rx ──acks───────────────────┘
//!          link_rx ──> SHARED.laser_requests ──> lidar
//! ```
//!
//! `pps` runs on an interrupt-driven executor so that an edge is stamped a few microseconds
//! after it happens, whatever the thread-mode tasks are doing.
//!
//! # Pin-out
//!
//! | signal                      | pin         | peripheral             | DMA                       |
//! |-----------------------------|-------------|------------------------|---------------------------|
//! | laser TX (to RS-422 DI)     | PD8         | USART3_TX              | DMA1 stream 3             |
//! | laser RX (from RS-422 RO)   | PD9         | USART3_RX              | DMA1 stream 1, 2 KiB ring |
//! | GPS TX → board RX           | PA1         | UART4_RX               | DMA1 stream 2, 1 KiB ring |
//! | GPS PPS                     | PD10        | EXTI10, pull-down      | —                         |
//! | USB D− / D+                 | PA11 / PA12 | OTG_FS (micro-USB CN5) | —                         |
//! | USB VBUS sense              | PA9         | OTG_FS VBUS            | —                         |
//! | host TX / RX (`uart-link`)  | PA2 / PA3   | USART2                 | DMA1 streams 6 / 5        |
//!
//! The UART and PPS pins are free on the Discovery board (the audio DAC, accelerometer,
//! microphone and LEDs use others); PA9, PA11 and PA12 are its own OTG connector. Baud rates:
//! laser [`LASER_POWER_UP_BAUD`] (the bring-up switches it), GPS [`GPS_BAUD`], host UART
//! 921 600 Bd.

#![no_std]
#![no_main]

mod clocks;
mod ports;

// The code below builds the USB link with `usb` and the UART link without it, so a wrong
// feature set stops at one of these messages only.
#[cfg(all(feature = "usb", feature = "uart-link"))]
compile_error!("features `usb` and `uart-link` both select the host link: enable exactly one");
#[cfg(not(any(feature = "usb", feature = "uart-link")))]
compile_error!("no host link: enable feature `usb` (default) or `uart-link`");

use defmt::{info, unwrap};
use embassy_executor::{InterruptExecutor, Spawner};
use embassy_stm32::exti::{self, ExtiInput};
use embassy_stm32::gpio::Pull;
use embassy_stm32::interrupt::{self, InterruptExt, Priority};
use embassy_stm32::mode::Async;
use embassy_stm32::peripherals::{
    DMA1_CH1, DMA1_CH2, DMA1_CH3, EXTI10, PA1, PD8, PD9, PD10, UART4, USART3,
};
use embassy_stm32::usart::{self, Uart, UartRx};
use embassy_stm32::{Peri, bind_interrupts, dma, peripherals};
use embassy_time::Instant;
use firmware::sick::BringUpConfig;
use firmware::tasks::gps::GpsOptions;
use firmware::tasks::{Shared, gps, lidar, link};
use static_cell::ConstStaticCell;
use {defmt_rtt as _, panic_probe as _};

use crate::ports::{LaserPort, LinkRx, LinkTx, RingRxPort};

/// Laser baud rate at power-up (the LMS2xx default); the bring-up raises it.
const LASER_POWER_UP_BAUD: u32 = 9_600;
/// GPS baud rate: 9600 Bd is the NMEA 0183 default. A receiver configured faster (e.g. a
/// u-blox at 115 200 Bd) needs only this constant changed.
const GPS_BAUD: u32 = 9_600;
/// Host link baud rate with feature `uart-link`.
#[cfg(not(feature = "usb"))]
const HOST_UART_BAUD: u32 = 921_600;
/// The host link, as logged at start-up.
#[cfg(feature = "usb")]
const HOST_LINK: &str = "USB CDC-ACM";
/// The host link, as logged at start-up.
#[cfg(not(feature = "usb"))]
const HOST_LINK: &str = "USART2";

/// The laser's receive ring: 40 ms of a continuous 500 kBd stream.
static LASER_RX_RING: ConstStaticCell<[u8; 2048]> = ConstStaticCell::new([0; 2048]);
/// The GPS receive ring: a second of NMEA at 9600 Bd.
static GPS_RX_RING: ConstStaticCell<[u8; 1024]> = ConstStaticCell::new([0; 1024]);

/// Queues and counters shared by all tasks.
static SHARED: Shared = Shared::new();

/// Runs the `pps` task from the UART5 interrupt vector (UART5 itself is unused).
static PPS_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

bind_interrupts!(struct Irqs {
    USART3 => usart::InterruptHandler<USART3>;
    DMA1_STREAM1 => dma::InterruptHandler<DMA1_CH1>;
    DMA1_STREAM3 => dma::InterruptHandler<DMA1_CH3>;
    UART4 => usart::InterruptHandler<UART4>;
    DMA1_STREAM2 => dma::InterruptHandler<DMA1_CH2>;
    EXTI15_10 => exti::InterruptHandler<interrupt::typelevel::EXTI15_10>;
    #[cfg(feature = "usb")]
    OTG_FS => embassy_stm32::usb::InterruptHandler<peripherals::USB_OTG_FS>;
    #[cfg(not(feature = "usb"))]
    USART2 => usart::InterruptHandler<peripherals::USART2>;
    #[cfg(not(feature = "usb"))]
    DMA1_STREAM5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
    #[cfg(not(feature = "usb"))]
    DMA1_STREAM6 => dma::InterruptHandler<peripherals::DMA1_CH6>;
});

/// The laser's UART, through the RS-422 transceiver.
struct LaserUart {
    usart: Peri<'static, USART3>,
    tx: Peri<'static, PD8>,
    rx: Peri<'static, PD9>,
    tx_dma: Peri<'static, DMA1_CH3>,
    rx_dma: Peri<'static, DMA1_CH1>,
}

/// The GPS receiver's NMEA output.
struct GpsUart {
    uart: Peri<'static, UART4>,
    rx: Peri<'static, PA1>,
    rx_dma: Peri<'static, DMA1_CH2>,
}

/// The GPS receiver's pulse-per-second output.
struct PpsInput {
    pin: Peri<'static, PD10>,
    exti: Peri<'static, EXTI10>,
}

/// The host link: the OTG FS port.
#[cfg(feature = "usb")]
struct HostLink {
    otg: Peri<'static, peripherals::USB_OTG_FS>,
    dp: Peri<'static, peripherals::PA12>,
    dm: Peri<'static, peripherals::PA11>,
}

/// The host link: USART2 to a USB-serial adapter.
#[cfg(not(feature = "usb"))]
struct HostLink {
    usart: Peri<'static, peripherals::USART2>,
    tx: Peri<'static, peripherals::PA2>,
    rx: Peri<'static, peripherals::PA3>,
    tx_dma: Peri<'static, peripherals::DMA1_CH6>,
    rx_dma: Peri<'static, peripherals::DMA1_CH5>,
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(clocks::config());
    info!("sensor board: SYSCLK 168 MHz, host link over {}", HOST_LINK);

    let laser = LaserUart {
        usart: p.USART3,
        tx: p.PD8,
        rx: p.PD9,
        tx_dma: p.DMA1_CH3,
        rx_dma: p.DMA1_CH1,
    };
    let gps = GpsUart {
        uart: p.UART4,
        rx: p.PA1,
        rx_dma: p.DMA1_CH2,
    };
    let pps = PpsInput {
        pin: p.PD10,
        exti: p.EXTI10,
    };
    #[cfg(feature = "usb")]
    let host = HostLink {
        otg: p.USB_OTG_FS,
        dp: p.PA12,
        dm: p.PA11,
    };
    #[cfg(not(feature = "usb"))]
    let host = HostLink {
        usart: p.USART2,
        tx: p.PA2,
        rx: p.PA3,
        tx_dma: p.DMA1_CH6,
        rx_dma: p.DMA1_CH5,
    };

    // Below every peripheral interrupt (priority 0), above thread mode.
    interrupt::UART5.set_priority(Priority::P6);
    let pps_spawner = PPS_EXECUTOR.start(interrupt::UART5);

    // Each task has a pool of one and is spawned once: spawning cannot fail.
    pps_spawner.spawn(unwrap!(pps_task(pps)));
    spawner.spawn(unwrap!(lidar_task(laser)));
    spawner.spawn(unwrap!(gps_task(gps)));
    start_host_link(spawner, host);
}

#[embassy_stm32::pac::interrupt]
unsafe fn UART5() {
    // SAFETY: this is the interrupt handler of the vector the executor was started on.
    unsafe { PPS_EXECUTOR.on_interrupt() }
}

/// 8 data bits, no parity, 1 stop bit at `baud`.
fn uart_config(baud: u32) -> usart::Config {
    let mut config = usart::Config::default();
    config.baudrate = baud;
    config
}

/// Laser UART ⇄ [`lidar::run`]: bring-up, telegrams, scans to the outbox.
#[embassy_executor::task]
async fn lidar_task(r: LaserUart) -> ! {
    let config = uart_config(LASER_POWER_UP_BAUD);
    // A fixed, valid configuration: construction cannot fail.
    let uart = unwrap!(Uart::new(
        r.usart, r.rx, r.tx, r.tx_dma, r.rx_dma, Irqs, config
    ));
    let (tx, rx) = uart.split();
    let rx = RingRxPort::new(rx.into_ring_buffered(LASER_RX_RING.take()));
    // Default target: 180° at 0.5°, millimetres, streaming at 500 kBd; the host may change it.
    let port = LaserPort::new(tx, rx, LASER_POWER_UP_BAUD);
    lidar::run(port, &SHARED, BringUpConfig::default()).await
}

/// GPS UART → [`gps::run`]: NMEA sentences, fixes to the outbox.
#[embassy_executor::task]
async fn gps_task(r: GpsUart) -> ! {
    // A fixed, valid configuration: construction cannot fail.
    let rx: UartRx<'static, Async> = unwrap!(UartRx::new(
        r.uart,
        r.rx,
        r.rx_dma,
        Irqs,
        uart_config(GPS_BAUD)
    ));
    let rx = RingRxPort::new(rx.into_ring_buffered(GPS_RX_RING.take()));
    gps::run(rx, &SHARED, GpsOptions::default()).await
}

/// PPS rising edges → [`gps::on_pps_edge`] with the board time of the edge.
#[embassy_executor::task]
async fn pps_task(r: PpsInput) -> ! {
    let mut pps = ExtiInput::new(r.pin, r.exti, Pull::Down, Irqs);
    loop {
        pps.wait_for_rising_edge().await;
        gps::on_pps_edge(&SHARED, Instant::now().as_micros());
    }
}

/// Outbox → [`link::run_tx`] → host link.
#[embassy_executor::task]
async fn link_tx_task(tx: LinkTx) -> ! {
    link::run_tx(tx, &SHARED).await
}

/// Host link → [`link::run_rx`] → laser requests and acknowledgements.
#[embassy_executor::task]
async fn link_rx_task(rx: LinkRx) -> ! {
    link::run_rx(rx, &SHARED).await
}

/// Runs the USB device: enumeration, control requests, suspend and resume.
#[cfg(feature = "usb")]
#[embassy_executor::task]
async fn usb_device_task(
    mut device: embassy_usb::UsbDevice<'static, ports::usb_link::UsbDriver>,
) -> ! {
    device.run().await
}

/// Buffer for packets received on the OTG FS OUT endpoints.
#[cfg(feature = "usb")]
static USB_EP_OUT_BUF: ConstStaticCell<[u8; 256]> = ConstStaticCell::new([0; 256]);

/// Starts the USB device and the two halves of the link over CDC-ACM.
#[cfg(feature = "usb")]
fn start_host_link(spawner: Spawner, r: HostLink) {
    use embassy_stm32::usb;

    let mut config = usb::Config::default();
    // PA9 is wired to the OTG connector's VBUS on the Discovery board, and the board is
    // powered from elsewhere: VBUS tells whether a host is plugged in.
    config.vbus_detection = true;
    let driver = usb::Driver::new_fs(r.otg, Irqs, r.dp, r.dm, USB_EP_OUT_BUF.take(), config);
    let (device, tx, rx) = ports::usb_link::build(driver);
    spawner.spawn(unwrap!(usb_device_task(device)));
    spawner.spawn(unwrap!(link_tx_task(tx)));
    spawner.spawn(unwrap!(link_rx_task(rx)));
}

/// The host link's receive ring: 22 ms at 921 600 Bd.
#[cfg(not(feature = "usb"))]
static HOST_RX_RING: ConstStaticCell<[u8; 2048]> = ConstStaticCell::new([0; 2048]);

/// Starts the two halves of the link over USART2.
#[cfg(not(feature = "usb"))]
fn start_host_link(spawner: Spawner, r: HostLink) {
    let config = uart_config(HOST_UART_BAUD);
    // A fixed, valid configuration: construction cannot fail.
    let uart = unwrap!(Uart::new(
        r.usart, r.rx, r.tx, r.tx_dma, r.rx_dma, Irqs, config
    ));
    let (tx, rx) = uart.split();
    let rx = RingRxPort::new(rx.into_ring_buffered(HOST_RX_RING.take()));
    spawner.spawn(unwrap!(link_tx_task(ports::UartLinkTx::new(tx))));
    spawner.spawn(unwrap!(link_rx_task(rx)));
}
