//! The firmware tasks running on the host under embassy's std executor, wired to serial
//! devices (pty board ends or real ports) exactly as the board wires them to its UARTs.

use std::io;
use std::path::PathBuf;

use embassy_executor::Executor;
use firmware::sick::BringUpConfig;
use firmware::tasks::gps::GpsOptions;
use firmware::tasks::{Shared, gps, lidar, link};

use crate::pty::BoardPort;

/// Where the board's UARTs are, and how the tasks are configured.
#[derive(Debug, Clone)]
pub struct BoardConfig {
    /// The laser UART (RS-422 side).
    pub laser_path: PathBuf,
    /// The GPS UART.
    pub gps_path: PathBuf,
    /// The host link.
    pub host_path: PathBuf,
    /// The GPS baud rate.
    pub gps_baud: u32,
    /// Laser bring-up targets.
    pub laser: BringUpConfig,
    /// GPS task options.
    pub gps: GpsOptions,
}

#[embassy_executor::task(pool_size = 16)]
async fn lidar_task(port: BoardPort, shared: &'static Shared, config: BringUpConfig) -> ! {
    lidar::run(port, shared, config).await
}

#[embassy_executor::task(pool_size = 16)]
async fn gps_task(port: BoardPort, shared: &'static Shared, options: GpsOptions) -> ! {
    gps::run(port, shared, options).await
}

#[embassy_executor::task(pool_size = 16)]
async fn link_tx_task(port: BoardPort, shared: &'static Shared) -> ! {
    link::run_tx(port, shared).await
}

#[embassy_executor::task(pool_size = 16)]
async fn link_rx_task(port: BoardPort, shared: &'static Shared) -> ! {
    link::run_rx(port, shared).await
}

/// Opens the three devices and starts the firmware tasks on a thread of their own. Returns
/// the tasks' shared state (queues, counters, states), which lives as long as the process,
/// as the board's `static` does.
///
/// # Errors
/// When a device cannot be opened.
pub fn spawn(config: BoardConfig) -> io::Result<&'static Shared> {
    // The laser starts at the sensor's power-on rate; bring-up changes it.
    let laser = BoardPort::open(&config.laser_path, 9_600)?;
    let gps = BoardPort::open(&config.gps_path, config.gps_baud)?;
    let (host_rx, host_tx) = BoardPort::open(&config.host_path, 921_600)?.split()?;
    let shared: &'static Shared = Box::leak(Box::new(Shared::new()));
    std::thread::Builder::new().name("firmware".into()).spawn(move || {
        let executor: &'static mut Executor = Box::leak(Box::new(Executor::new()));
        executor.run(move |spawner| {
            let spawned = [
                lidar_task(laser, shared, config.laser).map(|t| spawner.spawn(t)),
                gps_task(gps, shared, config.gps).map(|t| spawner.spawn(t)),
                link_tx_task(host_tx, shared).map(|t| spawner.spawn(t)),
                link_rx_task(host_rx, shared).map(|t| spawner.spawn(t)),
            ];
            if spawned.iter().any(Result::is_err) {
                eprintln!("hil-sim: too many firmware instances in one process; some tasks did not start");
            }
        })
    })?;
    Ok(shared)
}
