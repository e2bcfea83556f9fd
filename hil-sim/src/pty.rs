//! Pseudo-terminals standing in for the board's UARTs.
//!
//! [`PtyLink::open`] makes a pty pair. The *device* end (the master) is used by an emulator or
//! by the host software in blocking mode; the *board* end (the slave, a `/dev/pts/N` path that
//! opens like a real serial port) is given to the firmware tasks as an async [`BoardPort`].
//!
//! The baud rate a task sets on its end is stored in the pty's termios, where the device end
//! can read it back ([`PtyLink::board_baud`]): an emulated sensor uses it to garble bytes when
//! the two sides disagree, as a real UART pair would. A pty moves bytes as fast as it can;
//! emulators pace their output themselves.

use std::fs::{File, OpenOptions};
use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use async_io::Async;
use firmware::tasks::{BaudRate, PortError, SerialRx, SerialTx};
use futures_lite::{AsyncReadExt, AsyncWriteExt};
use serialport::{SerialPort, TTYPort};

/// A pty pair: the device end and the name of the board end.
pub struct PtyLink {
    /// The device (master) end, blocking.
    pub device: TTYPort,
    _board: TTYPort,
    board_path: PathBuf,
}

impl PtyLink {
    /// Opens a new pty pair.
    ///
    /// # Errors
    /// When the system has no free pty.
    pub fn open() -> io::Result<Self> {
        let (device, board) = TTYPort::pair().map_err(io::Error::other)?;
        let board_path = board
            .name()
            .map(PathBuf::from)
            .ok_or_else(|| io::Error::other("pty has no name"))?;
        // Holding the board end open keeps the device end readable (a pty master reads EIO
        // while no slave is open) until the board side has opened it.
        Ok(PtyLink {
            device,
            _board: board,
            board_path,
        })
    }

    /// The board end's path, e.g. `/dev/pts/3`.
    pub fn board_path(&self) -> &Path {
        &self.board_path
    }

    /// The baud rate the board end is set to.
    ///
    /// # Errors
    /// When the terminal settings cannot be read.
    pub fn board_baud(&self) -> io::Result<u32> {
        self.device.baud_rate().map_err(io::Error::other)
    }
}

/// What went through a [`BoardPort`] (both halves of a split port count together).
#[derive(Debug, Default)]
pub struct PortCounters {
    read: AtomicU64,
    written: AtomicU64,
    writing: AtomicBool,
}

impl PortCounters {
    /// Bytes the board has read.
    pub fn read(&self) -> u64 {
        self.read.load(Ordering::SeqCst)
    }

    /// Bytes the board has written.
    pub fn written(&self) -> u64 {
        self.written.load(Ordering::SeqCst)
    }

    /// Whether a write has not completed yet (it waits for room in the device).
    pub fn writing(&self) -> bool {
        self.writing.load(Ordering::SeqCst)
    }
}

/// The board end of a pty as the firmware tasks see a UART. It counts the bytes it moves
/// ([`PortCounters`]), so a simulation can tell when the board has read everything sent to
/// it.
pub struct BoardPort {
    io: Async<File>,
    termios: TTYPort,
    counters: Arc<PortCounters>,
}

impl BoardPort {
    /// Opens `path` (a pty slave or a real serial device) at `baud`, raw, non-blocking.
    ///
    /// # Errors
    /// When the device cannot be opened or configured.
    pub fn open(path: &Path, baud: u32) -> io::Result<Self> {
        let name = path.to_string_lossy().into_owned();
        let mut termios = serialport::new(&name, baud)
            .open_native()
            .map_err(io::Error::other)?;
        termios.set_exclusive(false).map_err(io::Error::other)?;
        let file = OpenOptions::new().read(true).write(true).open(path)?;
        Ok(BoardPort {
            io: Async::new(file)?,
            termios,
            counters: Arc::default(),
        })
    }

    /// The port's byte counters.
    pub fn counters(&self) -> Arc<PortCounters> {
        Arc::clone(&self.counters)
    }

    /// Splits into a receiving and a transmitting half sharing the device.
    ///
    /// # Errors
    /// When the file descriptor cannot be duplicated.
    pub fn split(self) -> io::Result<(BoardPort, BoardPort)> {
        let file = self.io.get_ref().try_clone()?;
        let termios = self.termios.try_clone_native().map_err(io::Error::other)?;
        Ok((
            BoardPort {
                io: Async::new(file)?,
                termios,
                counters: Arc::clone(&self.counters),
            },
            self,
        ))
    }
}

impl SerialRx for BoardPort {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError> {
        match self.io.read(buf).await {
            Ok(0) | Err(_) => Err(PortError::Disconnected),
            Ok(n) => {
                self.counters.read.fetch_add(n as u64, Ordering::SeqCst);
                Ok(n)
            }
        }
    }

    /// The device's input queue (`TIOCINQ`).
    fn queued(&self) -> usize {
        self.termios
            .bytes_to_read()
            .map_or(0, |n| usize::try_from(n).unwrap_or(usize::MAX))
    }
}

/// Marks a write in progress for as long as it lives, even if the write is abandoned.
struct Writing<'a>(&'a AtomicBool);

impl<'a> Writing<'a> {
    fn new(flag: &'a AtomicBool) -> Self {
        flag.store(true, Ordering::SeqCst);
        Writing(flag)
    }
}

impl Drop for Writing<'_> {
    fn drop(&mut self) {
        self.0.store(false, Ordering::SeqCst);
    }
}

impl SerialTx for BoardPort {
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), PortError> {
        let _writing = Writing::new(&self.counters.writing);
        let mut result = Ok(());
        let mut rest = bytes;
        while !rest.is_empty() {
            match self.io.write(rest).await {
                Ok(0) | Err(_) => {
                    result = Err(PortError::Disconnected);
                    break;
                }
                Ok(n) => {
                    self.counters.written.fetch_add(n as u64, Ordering::SeqCst);
                    rest = rest.get(n..).unwrap_or(&[]);
                }
            }
        }
        result
    }
}

impl BaudRate for BoardPort {
    async fn set_baud(&mut self, baud: u32) -> Result<(), PortError> {
        let _ = self.io.flush().await;
        self.termios
            .set_baud_rate(baud)
            .map_err(|_| PortError::UnsupportedBaud)
    }
}

/// Appends to `out` every byte `port` holds now, without waiting for more.
///
/// # Errors
/// A read error other than "nothing there" or an interruption.
pub fn read_available(port: &mut TTYPort, out: &mut Vec<u8>) -> io::Result<()> {
    use std::io::Read;
    port.set_timeout(std::time::Duration::ZERO)
        .map_err(io::Error::other)?;
    let mut buf = [0u8; 4096];
    loop {
        match port.read(&mut buf) {
            Ok(0) => return Ok(()),
            Ok(n) => out.extend_from_slice(&buf[..n]),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                ) =>
            {
                return Ok(());
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};
    use std::time::Duration;

    #[test]
    fn bytes_and_baud_cross_the_pair() {
        let mut link = PtyLink::open().unwrap();
        let mut port = BoardPort::open(link.board_path(), 9600).unwrap();
        futures_lite::future::block_on(async {
            port.set_baud(500_000).await.unwrap();
            port.write_all(b"\x02\x00").await.unwrap();
        });
        assert_eq!(link.board_baud().unwrap(), 500_000);
        link.device.set_timeout(Duration::from_secs(2)).unwrap();
        let mut got = [0u8; 2];
        link.device.read_exact(&mut got).unwrap();
        assert_eq!(got, [0x02, 0x00]);
        link.device.write_all(b"\x06").unwrap();
        let mut one = [0u8; 1];
        let n = futures_lite::future::block_on(port.read(&mut one)).unwrap();
        assert_eq!((n, one[0]), (1, 0x06));
    }

    #[test]
    fn a_backlog_is_reported_behind_a_read() {
        let mut link = PtyLink::open().unwrap();
        let mut port = BoardPort::open(link.board_path(), 500_000).unwrap();
        assert_eq!(port.queued(), 0);
        link.device.write_all(&[0x55; 1000]).unwrap();
        link.device.flush().unwrap();
        // The pty hands the bytes over asynchronously.
        let deadline = std::time::Instant::now() + Duration::from_secs(2);
        while port.queued() < 1000 && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
        let mut chunk = [0u8; 256];
        let n = futures_lite::future::block_on(port.read(&mut chunk)).unwrap();
        assert_eq!((n, port.queued()), (256, 1000 - 256));
    }
}
