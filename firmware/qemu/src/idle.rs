//! Runs embassy's executor in thread mode and sleeps with `WFI` when no task is ready.
//!
//! embassy's Cortex-M thread executor sleeps with `WFE`, which QEMU executes as a no-op: the
//! core would spin at full speed on the host. `WFI` halts the emulated core until an interrupt.
//! Interrupts are masked between the check and the `WFI`, so a wake-up in between is not
//! missed: a pending interrupt ends `WFI` even while masked, and runs once unmasked.

use core::sync::atomic::{AtomicBool, Ordering};

use embassy_executor::raw::Executor;

/// Set by the pender when a task was woken.
static WORK: AtomicBool = AtomicBool::new(true);

#[unsafe(export_name = "__pender")]
fn pender(_context: *mut ()) {
    WORK.store(true, Ordering::SeqCst);
}

/// Polls `executor` whenever a task is ready; never returns.
pub fn run(executor: &'static Executor) -> ! {
    loop {
        WORK.store(false, Ordering::SeqCst);
        // SAFETY: only this loop polls the executor, never re-entrantly.
        unsafe { executor.poll() };
        cortex_m::interrupt::free(|_| {
            if !WORK.load(Ordering::SeqCst) {
                cortex_m::asm::wfi();
            }
        });
    }
}
