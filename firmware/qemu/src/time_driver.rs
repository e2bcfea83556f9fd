//! embassy-time's driver for the emulated board: the time is the host's real time, read from
//! QEMU by semihosting; timers are checked in the periodic SysTick interrupt; [`cycles`] counts
//! the emulated core's cycles.
//!
//! * **Time** (`embassy_time::Instant::now()`, µs): `SYS_ELAPSED`, QEMU's monotonic host clock
//!   in nanoseconds. The board is driven by emulators on the wall clock, so its time must be
//!   the wall's. QEMU's virtual clock is not: under `-icount` it advances with the
//!   instructions executed and, while the core sleeps, with the wall, but every wake-up loses
//!   the host's latency (measured: 1.3 % at 100 wake-ups a second, more with every received
//!   byte waking the core), and without `-icount` SysTick interrupts get lost when the host is
//!   busy. A board clock that runs slow would shift the laser's scan slots and every timeout.
//! * **Timers**: SysTick interrupts [`TICK_HZ`] times a second of the emulated core and wakes
//!   the timers due, so a timer fires within about one period of being due.
//! * **Cycles** ([`cycles`]): SysTick periods counted plus what the counter has run down in
//!   the current one, at the core clock [`CORE_HZ`]. Under `-icount` that counts instructions
//!   (2^shift ns each) and the time the core slept, not the host's speed.

use core::cell::{Cell, RefCell};
use core::task::Waker;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};
use cortex_m_rt::exception;
use cortex_m_semihosting::nr;
use critical_section::{CriticalSection, Mutex};
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// The core clock QEMU gives the netduinoplus2 (SYSCLK of the STM32F405 at full speed).
pub const CORE_HZ: u32 = 168_000_000;
/// SysTick interrupts per second.
pub const TICK_HZ: u32 = 1_000;
/// Core cycles per SysTick period.
const CYCLES_PER_TICK: u32 = CORE_HZ / TICK_HZ;

struct SysTickDriver {
    /// The host clock at [`init`], ns.
    start_ns: Mutex<Cell<u64>>,
    /// SysTick periods elapsed.
    periods: Mutex<Cell<u64>>,
    /// The timers waiting.
    queue: Mutex<RefCell<Queue>>,
    /// When the earliest timer is due, µs (`u64::MAX`: none).
    next_due_us: Mutex<Cell<u64>>,
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    start_ns: Mutex::new(Cell::new(0)),
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

    /// Microseconds of the host clock since [`init`].
    fn now_us(&self, cs: CriticalSection<'_>) -> u64 {
        host_clock_ns().saturating_sub(self.start_ns.borrow(cs).get()) / 1_000
    }

    /// Wakes the timers due and notes when the next one is.
    fn wake_due(&self, cs: CriticalSection<'_>) {
        let now_us = self.now_us(cs);
        let next_us = self.queue.borrow_ref_mut(cs).next_expiration(now_us);
        self.next_due_us.borrow(cs).set(next_us);
    }
}

impl Driver for SysTickDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.now_us(cs))
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            if self.queue.borrow_ref_mut(cs).schedule_wake(at, waker) {
                self.wake_due(cs);
            }
        });
    }
}

/// QEMU's host clock, ns (semihosting `SYS_ELAPSED`; `SYS_TICKFREQ` is 10^9 in QEMU).
fn host_clock_ns() -> u64 {
    let mut ticks = [0u32; 2];
    // SAFETY: SYS_ELAPSED writes two words (low, high) to the block it is given; the block's
    // address is passed as a number, so the compiler takes it as written.
    let status =
        unsafe { cortex_m_semihosting::syscall1(nr::ELAPSED, ticks.as_mut_ptr() as usize) };
    if status != 0 {
        return 0;
    }
    u64::from(ticks[1]) << 32 | u64::from(ticks[0])
}

/// Starts the clock at zero and SysTick on the core clock with one interrupt per [`TICK_HZ`]
/// period.
pub fn init(mut syst: SYST) {
    critical_section::with(|cs| DRIVER.start_ns.borrow(cs).set(host_clock_ns()));
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
        if DRIVER.now_us(cs) >= DRIVER.next_due_us.borrow(cs).get() {
            DRIVER.wake_due(cs);
        }
    });
}
