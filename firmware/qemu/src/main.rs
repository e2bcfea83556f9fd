//! The sensor board's firmware for QEMU's `netduinoplus2` machine (STM32F405, Cortex-M4F): the
//! `firmware` library's tasks — laser bring-up and telegram receiver, NMEA parser, host link —
//! exactly as the board runs them, on drivers that QEMU models.
//!
//! embassy-stm32 does not start under QEMU (its clock set-up waits for RCC flags QEMU does not
//! model), so this image has its own small drivers below the tasks' port traits: a SysTick
//! time driver ([`time_driver`], on the host's clock read by semihosting) and a USART driver
//! with interrupt-driven reception ([`usart`]). The core runs at QEMU's 168 MHz SYSCLK without
//! any clock set-up; the executor sleeps with `WFI` ([`idle`]). QEMU must run with
//! `-semihosting-config enable=on` (`.cargo/config.toml`'s runner and `hil-sim run --qemu` do).
//!
//! The laser streams at 38 400 Bd instead of the board's 500 kBd ([`LASER_TARGET_BAUD`]); the
//! GPS USART is set to hil-sim's receiver rate, 115 200 Bd.
//!
//! | task      | USART (QEMU serial port)    | as on the board            |
//! |-----------|-----------------------------|----------------------------|
//! | `lidar`   | USART3 (`-serial` #3)       | USART3                     |
//! | `gps`     | UART4 (`-serial` #4)        | UART4                      |
//! | `link_tx` / `link_rx` | USART2 (`-serial` #2) | USART2 (feature `uart-link`) |
//! | `report`  | USART1 (`-serial` #1), debug lines | —                   |
//!
//! There is no PPS input: QEMU models no GPIO edges. The `report` task writes the
//! measurements ([`stack`] high-water mark, [`latency`]) to the debug line every second
//! ([`debug`]).

#![no_std]
#![no_main]

mod debug;
mod idle;
mod latency;
mod ports;
mod stack;
mod time_driver;
mod usart;

use cortex_m_rt::entry;
use embassy_executor::raw::Executor;
use embassy_executor::{SpawnError, SpawnToken, Spawner};
use embassy_time::{Duration, Ticker};
use firmware::sick::{BringUpConfig, LmsBaud};
use firmware::tasks::gps::GpsOptions;
use firmware::tasks::{Shared, gps, lidar, link};
use stm32_metapac::{self as pac, interrupt};

use crate::ports::{LaserPort, LinkTx};
use crate::usart::{Usart, UsartState};

/// APB1 clock at 168 MHz SYSCLK (USART2, USART3, UART4).
const APB1_HZ: u32 = 42_000_000;
/// APB2 clock at 168 MHz SYSCLK (USART1).
const APB2_HZ: u32 = 84_000_000;

/// Laser baud rate at power-up (the LMS2xx default); the bring-up raises it.
const LASER_POWER_UP_BAUD: u32 = 9_600;
/// GPS baud rate: what hil-sim's emulated receiver sends at by default.
const GPS_BAUD: u32 = 115_200;
/// Host link baud rate, as the board's `uart-link`.
const HOST_BAUD: u32 = 921_600;

/// The rate the laser streams at. The board streams at 500 kBd; QEMU's USART hands over one
/// byte per round trip through its event loop (measured: 20–27 kB/s on a busy host), less than
/// the 27.5 kB/s of 500 kBd scans, so the image streams at 38 400 Bd (every eighth scan,
/// 3.9 kB/s). Everything else in the bring-up is the board's default.
const LASER_TARGET_BAUD: LmsBaud = LmsBaud::B38400;

/// How often the `report` task writes the measurements.
const REPORT_PERIOD: Duration = Duration::from_secs(1);

static LASER_USART: UsartState = UsartState::new();
static GPS_USART: UsartState = UsartState::new();
static HOST_USART: UsartState = UsartState::new();

/// Queues and counters shared by all tasks.
static SHARED: Shared = Shared::new();

/// The executor; lives in a static so that its tasks may borrow it for ever.
static EXECUTOR: static_cell::StaticCell<Executor> = static_cell::StaticCell::new();

#[entry]
fn main() -> ! {
    stack::paint();
    let Some(core) = cortex_m::Peripherals::take() else {
        panic!("core peripherals taken twice");
    };
    debug::init(APB2_HZ);
    time_driver::init(core.SYST);

    let (laser, gps, host) = match (
        Usart::new(
            pac::USART3,
            &LASER_USART,
            APB1_HZ,
            "laser",
            LASER_POWER_UP_BAUD,
        ),
        Usart::new(pac::UART4, &GPS_USART, APB1_HZ, "gps", GPS_BAUD),
        Usart::new(pac::USART2, &HOST_USART, APB1_HZ, "host", HOST_BAUD),
    ) {
        (Ok(laser), Ok(gps), Ok(host)) => (laser, gps, host),
        _ => panic!("a fixed baud rate the dividers cannot produce"),
    };
    for irq in [
        pac::Interrupt::USART3,
        pac::Interrupt::UART4,
        pac::Interrupt::USART2,
    ] {
        // SAFETY: the handlers below only touch their USART's registers and its state.
        unsafe { cortex_m::peripheral::NVIC::unmask(irq) };
    }

    let executor: &'static Executor = EXECUTOR.init(Executor::new(core::ptr::null_mut()));
    let spawner = executor.spawner();
    let (host_tx, host_rx) = host.split();
    spawn(spawner, lidar_task(LaserPort(laser)));
    spawn(spawner, gps_task(gps));
    spawn(spawner, link_tx_task(LinkTx(host_tx)));
    spawn(spawner, link_rx_task(host_rx));
    spawn(spawner, report_task());
    // The stack used so far is what start-up took: the tasks' futures are built on the stack
    // before they move into their pools.
    debug::line(format_args!(
        "boot stack_bytes={} stack_used_bytes={} laser_target_baud={}",
        stack::size_bytes(),
        stack::used_bytes(),
        LASER_TARGET_BAUD.baud()
    ));
    idle::run(executor)
}

/// Spawns a task from a pool of one that is spawned once: cannot fail.
fn spawn<S>(spawner: Spawner, token: Result<SpawnToken<S>, SpawnError>) {
    match token {
        Ok(token) => spawner.spawn(token),
        Err(_) => panic!("a task spawned twice"),
    }
}

#[interrupt]
fn USART3() {
    usart::on_interrupt(pac::USART3, &LASER_USART);
}

#[interrupt]
fn UART4() {
    usart::on_interrupt(pac::UART4, &GPS_USART);
}

#[interrupt]
fn USART2() {
    usart::on_interrupt(pac::USART2, &HOST_USART);
}

/// Laser USART ⇄ [`lidar::run`]: bring-up, telegrams, scans to the outbox.
#[embassy_executor::task]
async fn lidar_task(port: LaserPort) -> ! {
    // 180° at 0.5°, millimetres, streaming at [`LASER_TARGET_BAUD`]; the host may change it.
    let config = BringUpConfig {
        target_baud: LASER_TARGET_BAUD,
        ..BringUpConfig::default()
    };
    lidar::run(port, &SHARED, config).await
}

/// GPS USART → [`gps::run`]: NMEA sentences, fixes to the outbox.
#[embassy_executor::task]
async fn gps_task(rx: Usart) -> ! {
    gps::run(rx, &SHARED, GpsOptions::default()).await
}

/// Outbox → [`link::run_tx`] → host USART.
#[embassy_executor::task]
async fn link_tx_task(tx: LinkTx) -> ! {
    link::run_tx(tx, &SHARED).await
}

/// Host USART → [`link::run_rx`] → laser requests and acknowledgements.
#[embassy_executor::task]
async fn link_rx_task(rx: Usart) -> ! {
    link::run_rx(rx, &SHARED).await
}

/// Writes the measurements to the debug line every [`REPORT_PERIOD`].
#[embassy_executor::task]
async fn report_task() -> ! {
    let mut ticker = Ticker::every(REPORT_PERIOD);
    loop {
        ticker.next().await;
        let (latency_max_cycles, latency_samples) = latency::worst();
        debug::line(format_args!(
            "measure stack_used_bytes={} stack_bytes={} latency_max_cycles={} \
             latency_samples={} core_hz={}",
            stack::used_bytes(),
            stack::size_bytes(),
            latency_max_cycles,
            latency_samples,
            time_driver::CORE_HZ,
        ));
    }
}
