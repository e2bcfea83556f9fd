//! embassy-time's driver on the Cortex-M SysTick, the one timer QEMU models faithfully on the
//! netduinoplus2 machine.
//!
//! SysTick counts the core clock ([`CORE_HZ`]) down from a reload value and interrupts once per
//! [`TICK_HZ`] period; the interrupt counts periods. The time is the periods counted plus what
//! the counter has run down in the current one, so [`cycles`] has the resolution of one core
//! cycle and `embassy_time::Instant::now()` (1 MHz ticks) of one microsecond. Timers are checked
//! in the periodic interrupt: a timer fires within one period ([`TICK_HZ`]) after it is due.
//!
//! Under QEMU the counter runs on QEMU's virtual clock; with `-icount` that clock advances with
//! the instructions executed, so [`cycles`] measures emulated work, not the host's speed.

use core::cell::{Cell, RefCell};
use core::task::Waker;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};
use cortex_m_rt::exception;
use critical_section::{CriticalSection, Mutex};
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// The core clock QEMU gives the netduinoplus2 (SYSCLK of the STM32F405 at full speed).
pub const CORE_HZ: u32 = 168_000_000;
/// SysTick interrupts per second.
pub const TICK_HZ: u32 = 1_000;
/// Core cycles per SysTick period.
const CYCLES_PER_TICK: u32 = CORE_HZ / TICK_HZ;
/// Core cycles per microsecond (embassy-time's tick).
const CYCLES_PER_US: u64 = (CORE_HZ / 1_000_000) as u64;

struct SysTickDriver {
    /// SysTick periods elapsed.
    periods: Mutex<Cell<u64>>,
    /// The timers waiting.
    queue: Mutex<RefCell<Queue>>,
    /// When the earliest timer is due, µs (`u64::MAX`: none).
    next_due_us: Mutex<Cell<u64>>,
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    periods: Mutex::new(Cell::new(0)),
    queue: Mutex::new(RefCell::new(Queue::new())),
    next_due_us: Mutex::new(Cell::new(u64::MAX)),
});

impl SysTickDriver {
    /// Core cycles since [`init`].
    fn cycles(&self, cs: CriticalSection<'_>) -> u64 {
        let mut periods = self.periods.borrow(cs).get();
        let mut current = SYST::get_current();
        // A wrap not counted yet (the interrupt is pending): the value read may be from before
        // or after it, so read again, after it for sure.
        if SCB::is_pendst_pending() {
            current = SYST::get_current();
            periods += 1;
        }
        let elapsed = CYCLES_PER_TICK - 1 - current.min(CYCLES_PER_TICK - 1);
        periods * u64::from(CYCLES_PER_TICK) + u64::from(elapsed)
    }

    /// Wakes the timers due and notes when the next one is.
    fn wake_due(&self, cs: CriticalSection<'_>) {
        let now_us = self.cycles(cs) / CYCLES_PER_US;
        let next_us = self.queue.borrow_ref_mut(cs).next_expiration(now_us);
        self.next_due_us.borrow(cs).set(next_us);
    }
}

impl Driver for SysTickDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.cycles(cs) / CYCLES_PER_US)
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            if self.queue.borrow_ref_mut(cs).schedule_wake(at, waker) {
                self.wake_due(cs);
            }
        });
    }
}

/// Starts SysTick on the core clock with one interrupt per [`TICK_HZ`] period.
pub fn init(mut syst: SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(CYCLES_PER_TICK - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// Core cycles since [`init`] (of QEMU's virtual clock under emulation).
pub fn cycles() -> u64 {
    critical_section::with(|cs| DRIVER.cycles(cs))
}

#[exception]
fn SysTick() {
    critical_section::with(|cs| {
        let periods = DRIVER.periods.borrow(cs);
        periods.set(periods.get() + 1);
        if DRIVER.cycles(cs) / CYCLES_PER_US >= DRIVER.next_due_us.borrow(cs).get() {
            DRIVER.wake_due(cs);
        }
    });
}
