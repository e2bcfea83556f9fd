//! Stack high-water mark by painting: at boot every word of the free stack below the stack
//! pointer is set to [`PAINT`]; later, the lowest word no longer holding it marks the deepest
//! the stack has been. Interrupt handlers run on the same (main) stack, so their frames count.
//!
//! The stack spans from cortex-m-rt's `_stack_end` (the end of the static data) up to
//! `_stack_start` (the top of RAM). A task's state lives in its static pool, not on the stack:
//! what the stack holds is `main`, the executor's poll of one task at a time, and interrupts.

use core::ptr;

/// The paint: a word unlikely to be stored by the program.
const PAINT: u32 = 0x5AC0_FFEE;

/// Words below the stack pointer left unpainted: room for [`paint`]'s own use.
const MARGIN_WORDS: usize = 64;

unsafe extern "C" {
    static mut _stack_end: u32;
    static mut _stack_start: u32;
}

fn bounds() -> (*mut u32, *mut u32) {
    // Only the addresses of the linker symbols are taken.
    (&raw mut _stack_end, &raw mut _stack_start)
}

/// Paints the free stack. Call first thing in `main`.
pub fn paint() {
    let (bottom, _) = bounds();
    let sp = cortex_m::register::msp::read() as *mut u32;
    let top = sp.wrapping_sub(MARGIN_WORDS);
    let mut word = bottom;
    while word < top {
        // SAFETY: `word` lies between the end of the static data and below the stack pointer:
        // RAM that nothing uses yet.
        unsafe { ptr::write_volatile(word, PAINT) };
        word = word.wrapping_add(1);
    }
}

/// The stack's size, bytes.
pub fn size_bytes() -> u32 {
    let (bottom, top) = bounds();
    (top as u32).wrapping_sub(bottom as u32)
}

/// The most stack used since [`paint`], bytes.
pub fn used_bytes() -> u32 {
    let (bottom, top) = bounds();
    let mut word = bottom;
    // SAFETY: reads of RAM between the end of the static data and the top of the stack.
    while word < top && unsafe { ptr::read_volatile(word) } == PAINT {
        word = word.wrapping_add(1);
    }
    (top as u32).wrapping_sub(word as u32)
}
