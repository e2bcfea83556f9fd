//! A USART driver with interrupt-driven reception, behind the firmware's port traits
//! ([`SerialRx`], [`SerialTx`], [`BaudRate`]).
//!
//! QEMU's STM32 USART has no FIFO and no DMA: it hands over the next byte only once the last
//! one was read from the data register. So the receive interrupt takes every byte as it comes
//! into a ring ([`RX_CAPACITY`]), with the core cycle count at which it arrived, and the
//! reading task empties the ring at its own pace.
//!
//! Transmission is not interrupt-driven: QEMU 7.2's USART raises its interrupt for received
//! bytes only (never for TXE or TC), and sends a byte the moment it is written to the data
//! register. A write puts each byte into the data register once it is empty, yielding to the
//! other tasks while it is not (on a real STM32F4 that would be one byte time).
//!
//! The arrival stamps serve the measurement in [`crate::latency`]: a read reports the stamp of
//! the newest byte it returns.

use core::cell::RefCell;
use core::future::poll_fn;
use core::sync::atomic::{AtomicU8, Ordering};
use core::task::Poll;

use critical_section::Mutex;
use embassy_futures::yield_now;
use embassy_sync::waitqueue::AtomicWaker;
use firmware::tasks::{BaudRate, PortError, SerialRx, SerialTx};
use heapless::Deque;
use stm32_metapac::usart::Usart as Regs;

use crate::{debug, time_driver};

/// Bytes the receive ring holds: 40 ms of a continuous 500 kBd stream.
pub const RX_CAPACITY: usize = 2048;

/// Error flags the interrupt saw, reported by the next read.
const FLAG_OVERRUN: u8 = 1;
const FLAG_LINE: u8 = 2;

/// What one USART's interrupt and its tasks share; lives in a `static`.
pub struct UsartState {
    /// Received bytes with the core cycle count (low 32 bits) of their arrival.
    rx: Mutex<RefCell<Deque<(u8, u32), RX_CAPACITY>>>,
    rx_waker: AtomicWaker,
    errors: AtomicU8,
}

impl UsartState {
    /// Empty rings.
    pub const fn new() -> Self {
        UsartState {
            rx: Mutex::new(RefCell::new(Deque::new())),
            rx_waker: AtomicWaker::new(),
            errors: AtomicU8::new(0),
        }
    }
}

/// One USART, both directions, as a port. [`Usart::split`] gives the halves to two tasks.
#[derive(Clone, Copy)]
pub struct Usart {
    regs: Regs,
    state: &'static UsartState,
    /// Peripheral clock, Hz (for the baud-rate divider).
    pclk_hz: u32,
    /// The name the debug channel gives it.
    name: &'static str,
}

impl Usart {
    /// Configures the USART for 8N1 at `baud`, enables receiver, transmitter and the receive
    /// interrupt. The NVIC line is unmasked by the caller once every port is set up.
    ///
    /// # Errors
    /// [`PortError::UnsupportedBaud`] if the divider cannot produce `baud`.
    pub fn new(
        regs: Regs,
        state: &'static UsartState,
        pclk_hz: u32,
        name: &'static str,
        baud: u32,
    ) -> Result<Usart, PortError> {
        let usart = Usart {
            regs,
            state,
            pclk_hz,
            name,
        };
        usart.write_divider(baud)?;
        regs.cr1().write(|w| {
            w.set_ue(true);
            w.set_re(true);
            w.set_te(true);
            w.set_rxneie(true);
        });
        Ok(usart)
    }

    /// The receiving and the transmitting half.
    pub fn split(self) -> (Usart, Usart) {
        (self, self)
    }

    /// Sets the divider for `baud` (16× oversampling: BRR = f_pclk / baud).
    fn write_divider(&self, baud: u32) -> Result<(), PortError> {
        let divider = self
            .pclk_hz
            .checked_add(baud / 2)
            .and_then(|n| n.checked_div(baud))
            .filter(|d| (16..=0xFFFF).contains(d))
            .ok_or(PortError::UnsupportedBaud)?;
        self.regs
            .brr()
            .write_value(stm32_metapac::usart::regs::Brr(divider));
        debug::baud(self.name, baud);
        Ok(())
    }

    /// Waits until every byte written has left the transmitter.
    async fn flush(&self) {
        while !self.regs.sr().read().tc() {
            yield_now().await;
        }
    }
}

/// Takes the received byte into the ring. Call from the interrupt handler of the USART `regs`
/// whose state is `state`.
pub fn on_interrupt(regs: Regs, state: &UsartState) {
    let sr = regs.sr().read();
    if sr.rxne() || sr.ore() {
        let stamp = time_driver::cycles() as u32;
        // Reading DR after SR clears RXNE and the error flags.
        let byte = regs.dr().read().dr() as u8;
        let mut flags = 0;
        if sr.ore() {
            flags |= FLAG_OVERRUN;
        }
        if sr.fe() || sr.ne() || sr.pe() {
            flags |= FLAG_LINE;
        }
        critical_section::with(|cs| {
            if state
                .rx
                .borrow_ref_mut(cs)
                .push_back((byte, stamp))
                .is_err()
            {
                flags |= FLAG_OVERRUN;
            }
        });
        if flags != 0 {
            state.errors.fetch_or(flags, Ordering::Relaxed);
        }
        state.rx_waker.wake();
    }
}

/// Reads the bytes waiting into `buf`; with the newest one's arrival stamp.
pub(crate) async fn read_stamped(usart: &Usart, buf: &mut [u8]) -> Result<(usize, u32), PortError> {
    poll_fn(|cx| {
        let flags = usart.state.errors.swap(0, Ordering::Relaxed);
        if flags & FLAG_OVERRUN != 0 {
            return Poll::Ready(Err(PortError::Overrun));
        }
        if flags & FLAG_LINE != 0 {
            return Poll::Ready(Err(PortError::LineError));
        }
        usart.state.rx_waker.register(cx.waker());
        let (n, stamp) = critical_section::with(|cs| {
            let mut rx = usart.state.rx.borrow_ref_mut(cs);
            let mut n = 0;
            let mut stamp = 0;
            for slot in buf.iter_mut() {
                let Some((byte, at)) = rx.pop_front() else {
                    break;
                };
                *slot = byte;
                stamp = at;
                n += 1;
            }
            (n, stamp)
        });
        if n == 0 && !buf.is_empty() {
            Poll::Pending
        } else {
            Poll::Ready(Ok((n, stamp)))
        }
    })
    .await
}

impl SerialRx for Usart {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError> {
        read_stamped(self, buf).await.map(|(n, _)| n)
    }
}

impl SerialTx for Usart {
    /// Writes `bytes` to the data register one by one as it empties; returns once the last
    /// one is in. A UART cannot tell whether anyone listens, so it never reports
    /// [`PortError::Disconnected`].
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), PortError> {
        for &byte in bytes {
            while !self.regs.sr().read().txe() {
                yield_now().await;
            }
            self.regs.dr().write(|w| w.set_dr(u16::from(byte)));
        }
        Ok(())
    }
}

impl BaudRate for Usart {
    /// Waits until the last written byte has left, then reprograms the divider. Transmitter
    /// and receiver share it.
    async fn set_baud(&mut self, baud: u32) -> Result<(), PortError> {
        self.flush().await;
        self.write_divider(baud)
    }
}
