//! How the daemon's allocator hands memory back, for a process that runs all day.
//!
//! glibc's `malloc` serves a block of 128 KiB or more with a mapping of its own, but raises
//! that threshold to the size of any such block that is freed (up to 32 MiB), and keeps up
//! to twice the threshold of free memory at the top of each heap. The daemon frees a few
//! blocks of megabytes at start (decoding the aerial image for the web view), so from then
//! on the global map's covariance, a block that grows with every join, lives in the heaps:
//! each growth leaves the old block behind as free memory, and the heaps keep what the
//! largest working sets needed. With the thresholds fixed, blocks of 512 KiB and more are
//! mapped on their own (the covariance grows in place, by remapping, and its block is
//! handed back whole once it is freed), and a heap keeps at most 512 KiB free at its top.

/// The threshold from which a block gets a mapping of its own, and the free memory a heap
/// keeps at its top, bytes.
pub const MAPPED_BLOCK_BYTES: i32 = 512 * 1024;

/// Fixes glibc's thresholds (see the module documentation). Call it first thing in `main`,
/// before other threads start. Elsewhere than glibc it does nothing.
pub fn settle_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets allocator parameters; it is called before any other thread
    // runs, and a refused setting leaves glibc's default, which is correct, only larger.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MAPPED_BLOCK_BYTES);
        libc::mallopt(libc::M_TRIM_THRESHOLD, MAPPED_BLOCK_BYTES);
    }
}
