//! A thread executor for the firmware tasks that can tell when it has nothing left to do.
//!
//! It is embassy's raw executor on a host thread, like embassy's std executor, plus what a
//! lock-step simulation needs: [`ExecutorHandle::idle_epoch`] says whether the executor is
//! idle (every task waits for I/O or a timer) and counts how often it went idle, so a caller
//! can tell that nothing ran between two looks; [`ExecutorHandle::stop`] ends the thread;
//! [`ExecutorHandle::longest_wake_delay_us`] says how long a woken task waited at most for
//! the thread to poll it (on a busy machine, for a core).
//!
//! Embassy calls the `__pender` function below whenever a task is woken; it marks the
//! executor busy before the thread polls again.

use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Instant;

use embassy_executor::{Spawner, raw};

/// What the executor thread and its observers share.
#[derive(Default)]
struct Signal {
    state: Mutex<State>,
    changed: Condvar,
}

#[derive(Default)]
struct State {
    /// A task was woken since the last poll.
    pending: bool,
    /// The thread waits for a wake.
    idle: bool,
    /// How often the thread went idle.
    epoch: u64,
    /// The thread should end.
    stop: bool,
    /// Polls that panicked (the thread ends after the first).
    panics: u32,
    /// When the first task woken since the last poll was woken.
    woken_at: Option<Instant>,
    /// The longest from a wake to the poll that followed it, µs.
    longest_wake_delay_us: u64,
}

impl Signal {
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn pend(&self) {
        let mut state = self.lock();
        state.pending = true;
        state.idle = false;
        state.woken_at.get_or_insert_with(Instant::now);
        self.changed.notify_all();
    }
}

#[unsafe(export_name = "__pender")]
fn __pender(context: *mut ()) {
    // SAFETY: every executor of this process is created by `spawn` below with a context
    // pointing to a leaked, never freed `Signal`.
    let signal = unsafe { &*(context as *const Signal) };
    signal.pend();
}

/// A view of a running executor thread.
#[derive(Clone)]
pub struct ExecutorHandle {
    signal: &'static Signal,
    thread: Arc<Mutex<Option<JoinHandle<()>>>>,
}

impl core::fmt::Debug for ExecutorHandle {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ExecutorHandle")
            .field("idle_epoch", &self.idle_epoch())
            .finish()
    }
}

impl ExecutorHandle {
    /// `Some(epoch)` when the executor is idle, with the number of times it went idle so
    /// far; `None` while it runs or has work queued.
    pub fn idle_epoch(&self) -> Option<u64> {
        let state = self.signal.lock();
        (state.idle && !state.pending).then_some(state.epoch)
    }

    /// The longest a woken task waited for the thread to poll it, µs.
    pub fn longest_wake_delay_us(&self) -> u64 {
        self.signal.lock().longest_wake_delay_us
    }

    /// How many times a task panicked (the executor stops at the first).
    pub fn panics(&self) -> u32 {
        self.signal.lock().panics
    }

    /// Ends the executor thread after its current poll and waits for it. Its tasks are
    /// never polled again.
    pub fn stop(&self) {
        {
            let mut state = self.signal.lock();
            state.stop = true;
            self.signal.changed.notify_all();
        }
        let thread = self
            .thread
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take();
        if let Some(thread) = thread {
            let _ = thread.join();
        }
    }
}

/// Starts an executor on a thread named `name`; `init` spawns its tasks.
///
/// # Errors
/// When the thread cannot be started.
pub fn spawn(
    name: &str,
    init: impl FnOnce(Spawner) + Send + 'static,
) -> std::io::Result<ExecutorHandle> {
    let signal: &'static Signal = Box::leak(Box::default());
    let thread = std::thread::Builder::new()
        .name(name.into())
        .spawn(move || {
            let context = signal as *const Signal as *mut ();
            let executor: &'static raw::Executor = Box::leak(Box::new(raw::Executor::new(context)));
            init(executor.spawner());
            loop {
                let polled = std::panic::catch_unwind(|| {
                    // SAFETY: `poll` is only ever called from this thread, never re-entrantly.
                    unsafe { executor.poll() }
                });
                let mut state = signal.lock();
                if polled.is_err() {
                    // A task's state is unknown after a panic: stop, as the board would reset.
                    state.panics += 1;
                    state.stop = true;
                    signal.changed.notify_all();
                    return;
                }
                if state.stop {
                    return;
                }
                if !state.pending {
                    state.idle = true;
                    state.epoch += 1;
                    signal.changed.notify_all();
                    while !state.pending && !state.stop {
                        state = signal
                            .changed
                            .wait(state)
                            .unwrap_or_else(PoisonError::into_inner);
                    }
                    if state.stop {
                        return;
                    }
                }
                state.pending = false;
                state.idle = false;
                if let Some(woken_at) = state.woken_at.take() {
                    let delay_us =
                        u64::try_from(woken_at.elapsed().as_micros()).unwrap_or(u64::MAX);
                    state.longest_wake_delay_us = state.longest_wake_delay_us.max(delay_us);
                }
            }
        })?;
    Ok(ExecutorHandle {
        signal,
        thread: Arc::new(Mutex::new(Some(thread))),
    })
}
