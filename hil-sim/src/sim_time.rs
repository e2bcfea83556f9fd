//! The firmware's clock on the host: embassy-time's driver, on the wall clock or on a virtual
//! clock that a simulation advances.
//!
//! On the board, `embassy_time::Instant::now()` counts microseconds of a hardware timer. Here
//! the same firmware tasks run on a host thread, and this module is their timer:
//!
//! * **Wall** (the default): microseconds of [`std::time::Instant`] since first use, with a
//!   thread that wakes timers when they are due, like embassy's own std driver.
//! * **Virtual**, inside a [`VirtualClock`] session: time stands still until the session's
//!   owner calls [`VirtualClock::advance_to`], which wakes every timer due by then. Nothing the
//!   firmware does depends on how fast the host runs, so a run is reproducible to the byte and
//!   can go as fast as the host allows.
//!
//! Sessions are exclusive within a process ([`VirtualClock::begin`] waits for the previous one
//! to end) and start at time 0. When a session ends the clock returns to the wall, continuing
//! from the last virtual time so that it never runs backwards.

use std::sync::{Condvar, Mutex, MutexGuard, PoisonError};
use std::task::Waker;
use std::time::{Duration, Instant};

use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// The driver embassy-time calls.
struct SimDriver {
    inner: Mutex<Inner>,
    /// Wakes the wall-clock alarm thread when the earliest timer changes.
    alarm_changed: Condvar,
}

struct Inner {
    mode: Mode,
    queue: Queue,
    alarm_thread: bool,
}

#[derive(Clone, Copy)]
enum Mode {
    /// `now = offset_us + (Instant::now() − zero)`.
    Wall {
        zero: Option<Instant>,
        offset_us: u64,
    },
    /// `now = now_us`.
    Virtual { now_us: u64 },
}

embassy_time_driver::time_driver_impl!(static DRIVER: SimDriver = SimDriver {
    inner: Mutex::new(Inner {
        mode: Mode::Wall { zero: None, offset_us: 0 },
        queue: Queue::new(),
        alarm_thread: false,
    }),
    alarm_changed: Condvar::new(),
});

/// Serialises virtual sessions.
static SESSION: Mutex<()> = Mutex::new(());

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // The state stays consistent even if a holder panicked: every update is one assignment.
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Inner {
    fn now_us(&mut self) -> u64 {
        match &mut self.mode {
            Mode::Wall { zero, offset_us } => {
                let zero = *zero.get_or_insert_with(Instant::now);
                let elapsed = u64::try_from(zero.elapsed().as_micros()).unwrap_or(u64::MAX);
                offset_us.saturating_add(elapsed)
            }
            Mode::Virtual { now_us } => *now_us,
        }
    }
}

impl Driver for SimDriver {
    fn now(&self) -> u64 {
        lock(&self.inner).now_us()
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        let mut inner = lock(&self.inner);
        if !inner.alarm_thread {
            inner.alarm_thread = true;
            let started = std::thread::Builder::new()
                .name("sim-time alarms".into())
                .spawn(alarm_thread);
            if started.is_err() {
                // Without the thread, wall-clock timers only fire when time is read again.
                inner.alarm_thread = false;
            }
        }
        if inner.queue.schedule_wake(at, waker) {
            self.alarm_changed.notify_all();
        }
    }
}

/// Wakes wall-clock timers when they are due; idles during virtual sessions.
fn alarm_thread() {
    let mut inner = lock(&DRIVER.inner);
    loop {
        let wait = match inner.mode {
            Mode::Wall { .. } => {
                let now_us = inner.now_us();
                let next_us = inner.queue.next_expiration(now_us);
                (next_us != u64::MAX).then(|| Duration::from_micros(next_us - now_us))
            }
            Mode::Virtual { .. } => None,
        };
        inner = match wait {
            Some(timeout) => {
                DRIVER
                    .alarm_changed
                    .wait_timeout(inner, timeout)
                    .unwrap_or_else(PoisonError::into_inner)
                    .0
            }
            None => DRIVER
                .alarm_changed
                .wait(inner)
                .unwrap_or_else(PoisonError::into_inner),
        };
    }
}

/// A virtual-time session: while it lives, the firmware's clock moves only when told to.
/// See the [module documentation](self).
pub struct VirtualClock {
    _session: MutexGuard<'static, ()>,
}

impl core::fmt::Debug for VirtualClock {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("VirtualClock")
            .field("now_us", &self.now_us())
            .finish()
    }
}

impl VirtualClock {
    /// Starts a session at time 0, waiting for any other session in the process to end.
    /// Timers left from before are forgotten.
    pub fn begin() -> VirtualClock {
        let session = lock(&SESSION);
        let mut inner = lock(&DRIVER.inner);
        inner.mode = Mode::Virtual { now_us: 0 };
        inner.queue = Queue::new();
        drop(inner);
        DRIVER.alarm_changed.notify_all();
        VirtualClock { _session: session }
    }

    /// The current virtual time, µs.
    pub fn now_us(&self) -> u64 {
        lock(&DRIVER.inner).now_us()
    }

    /// Moves the clock forward to `t_us` (never back) and wakes every timer due by then.
    pub fn advance_to(&self, t_us: u64) {
        let mut inner = lock(&DRIVER.inner);
        if let Mode::Virtual { now_us } = &mut inner.mode {
            *now_us = (*now_us).max(t_us);
        }
        let now_us = inner.now_us();
        inner.queue.next_expiration(now_us);
    }

    /// The earliest pending timer, if any, after waking those already due.
    pub fn next_timer_us(&self) -> Option<u64> {
        let mut inner = lock(&DRIVER.inner);
        let now_us = inner.now_us();
        let next = inner.queue.next_expiration(now_us);
        (next != u64::MAX).then_some(next)
    }
}

impl Drop for VirtualClock {
    fn drop(&mut self) {
        let mut inner = lock(&DRIVER.inner);
        let offset_us = inner.now_us();
        inner.mode = Mode::Wall {
            zero: Some(Instant::now()),
            offset_us,
        };
        drop(inner);
        DRIVER.alarm_changed.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::task::Wake;

    struct Flag(AtomicBool);

    impl Wake for Flag {
        fn wake(self: Arc<Self>) {
            self.0.store(true, Ordering::SeqCst);
        }
    }

    #[test]
    fn virtual_time_moves_only_when_advanced() {
        let clock = VirtualClock::begin();
        assert_eq!(embassy_time::Instant::now().as_micros(), 0);
        let flag = Arc::new(Flag(AtomicBool::new(false)));
        let waker = Waker::from(Arc::clone(&flag));
        DRIVER.schedule_wake(1_500, &waker);
        assert_eq!(clock.next_timer_us(), Some(1_500));
        clock.advance_to(1_499);
        assert!(!flag.0.load(Ordering::SeqCst));
        std::thread::sleep(Duration::from_millis(5));
        assert_eq!(embassy_time::Instant::now().as_micros(), 1_499);
        clock.advance_to(1_500);
        assert!(flag.0.load(Ordering::SeqCst));
        assert_eq!(clock.next_timer_us(), None);
        clock.advance_to(10);
        assert_eq!(clock.now_us(), 1_500, "never backwards");
        drop(clock);
        // Back on the wall clock, continuing from there.
        assert!(embassy_time::Instant::now().as_micros() >= 1_500);
    }
}
