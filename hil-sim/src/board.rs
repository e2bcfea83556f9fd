//! The firmware tasks running on the host, wired to serial devices (pty board ends or real
//! ports) exactly as the board wires them to its UARTs.
//!
//! The tasks run on an [`executor`](crate::executor) thread of their own; [`Board`] is the
//! view from outside: the tasks' shared state (queues, counters, states), whether the
//! executor is idle, and how many bytes each port moved, which is what a lock-step
//! simulation needs to know that the firmware has finished reacting to its input.

use std::io;
use std::path::PathBuf;
use std::sync::Arc;

use firmware::sick::BringUpConfig;
use firmware::tasks::gps::GpsOptions;
use firmware::tasks::{Shared, gps, lidar, link};

use crate::executor::{self, ExecutorHandle};
use crate::pty::{BoardPort, PortCounters};

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

/// A running firmware instance.
#[derive(Clone)]
pub struct Board {
    /// The tasks' shared state, which lives as long as the process, as the board's `static`
    /// does.
    pub shared: &'static Shared,
    /// The executor running the tasks.
    pub executor: ExecutorHandle,
    /// Bytes moved on the laser UART.
    pub laser_port: Arc<PortCounters>,
    /// Bytes moved on the GPS UART.
    pub gps_port: Arc<PortCounters>,
    /// Bytes moved on the host link.
    pub host_port: Arc<PortCounters>,
}

impl core::fmt::Debug for Board {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Board")
            .field("executor", &self.executor)
            .field("laser_port", &self.laser_port)
            .field("gps_port", &self.gps_port)
            .field("host_port", &self.host_port)
            .finish_non_exhaustive()
    }
}

impl Board {
    /// Stops the firmware: its tasks are never polled again and its ports close.
    pub fn stop(&self) {
        self.executor.stop();
    }
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

/// Opens the three devices and starts the firmware tasks on a thread of their own.
///
/// # Errors
/// When a device cannot be opened, or more firmware instances were started in this process
/// than the task pools hold (16).
pub fn spawn(config: BoardConfig) -> io::Result<Board> {
    // The laser starts at the sensor's power-on rate; bring-up changes it.
    let laser = BoardPort::open(&config.laser_path, 9_600)?;
    let gps = BoardPort::open(&config.gps_path, config.gps_baud)?;
    let host = BoardPort::open(&config.host_path, 921_600)?;
    let (laser_port, gps_port, host_port) = (laser.counters(), gps.counters(), host.counters());
    let (host_rx, host_tx) = host.split()?;
    let shared: &'static Shared = Box::leak(Box::new(Shared::new()));
    let (started, failed) = std::sync::mpsc::channel();
    let executor = executor::spawn("firmware", move |spawner| {
        let spawned = [
            lidar_task(laser, shared, config.laser).map(|t| spawner.spawn(t)),
            gps_task(gps, shared, config.gps).map(|t| spawner.spawn(t)),
            link_tx_task(host_tx, shared).map(|t| spawner.spawn(t)),
            link_rx_task(host_rx, shared).map(|t| spawner.spawn(t)),
        ];
        let _ = started.send(spawned.iter().all(Result::is_ok));
    })?;
    if failed.recv() != Ok(true) {
        executor.stop();
        return Err(io::Error::other(
            "too many firmware instances in one process: the task pools are full",
        ));
    }
    Ok(Board {
        shared,
        executor,
        laser_port,
        gps_port,
        host_port,
    })
}
