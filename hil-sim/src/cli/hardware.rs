//! The hardware-in-the-loop flags `run` and `replay` share: a flashed board on real serial
//! ports instead of the firmware in this process.

use std::path::PathBuf;

/// Hardware in the loop: a flashed board on real serial ports.
#[derive(Debug, clap::Args)]
pub struct HardwareArgs {
    /// Drive a flashed board on real serial ports instead of the firmware in this process:
    /// the emulated laser writes to --laser-port at its own current baud rate (following its
    /// baud switches), the GPS to --gps-port, and the host reads --host-port. Runs on the wall
    /// clock (no lock-step); the board's counters come from its status report.
    #[arg(long, requires_all = ["laser_port", "gps_port", "host_port"])]
    hardware: bool,
    /// With --hardware: the serial port wired to the board's laser UART (RS-422 side).
    #[arg(long, requires = "hardware")]
    laser_port: Option<PathBuf>,
    /// With --hardware: the serial port wired to the board's GPS UART.
    #[arg(long, requires = "hardware")]
    gps_port: Option<PathBuf>,
    /// With --hardware: the board's host link, e.g. /dev/ttyACM0.
    #[arg(long, requires = "hardware")]
    host_port: Option<PathBuf>,
    /// With --hardware: the rate the board's GPS UART listens at (the GPS epoch rate is
    /// lowered to what fits).
    #[arg(long, default_value_t = 9_600)]
    gps_baud: u32,
}

impl HardwareArgs {
    /// The board's ports with --hardware, `None` without.
    pub fn ports(self) -> Option<hil_sim::run::HardwarePorts> {
        if !self.hardware {
            return None;
        }
        Some(hil_sim::run::HardwarePorts {
            laser: self.laser_port?,
            gps: self.gps_port?,
            host: self.host_port?,
            gps_baud: self.gps_baud,
        })
    }
}
