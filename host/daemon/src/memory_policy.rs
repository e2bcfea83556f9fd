//! How the daemon's allocator hands memory back, for a process that runs all day.
//!
//! glibc's `malloc` serves a block of 128 KiB or more with a mapping of its own, but raises
//! that threshold to the size of any such block that is freed (up to 32 MiB), and keeps up
//! to twice the threshold of free memory at the top of each heap. The daemon frees a few
//! blocks of megabytes at start (decoding the aerial image for the web view), so from then
//! on the large working sets would live in the heaps: the global map's covariance, a block
//! that grows with every join, and the passing ones (a join's matrices, place recognition's
//! voting table, a web answer of the whole state, a burst of scans queued after a replug).
//! Each leaves its block behind as free memory among blocks still in use, and over hours
//! the heaps grow to hold the high points of all of them. With the thresholds fixed, blocks
//! of [`MAPPED_BLOCK_BYTES`] and more are mapped on their own and handed back whole once
//! freed (the covariance grows in place, by remapping), and a heap keeps at most that much
//! free at its top.
//!
//! glibc also gives threads heaps of their own (up to eight per core), each holding its own
//! free memory among its blocks in use. The daemon keeps [`HEAPS`] heap, so a block one
//! thread frees serves the next request of any other; over the last simulated 1 000 s of
//! the soak the median of its resident memory was 0.1–0.9 MiB lower than with a heap per
//! thread (three runs against two). The price is one lock: a thread that allocates while
//! another does waits for it, and so does one that allocates while the heap is trimmed
//! (below). The serial reader takes a read's receive time before it allocates anything for
//! it.
//!
//! The smaller blocks a working set frees in the middle of a heap are out of any threshold's
//! reach. So a thread of the daemon also hands free pages back every
//! [`RETURN_FREE_MEMORY_EVERY`] ([`FreeMemoryReturner`]): `malloc_trim` gives the kernel
//! every whole free page of every heap, and the resident memory follows what is in use
//! rather than what ever was.

use std::time::{Duration, Instant};

/// The threshold from which a block gets a mapping of its own, and the free memory a heap
/// keeps at its top, bytes.
pub const MAPPED_BLOCK_BYTES: i32 = 128 * 1024;

/// How many heaps glibc keeps for the daemon's threads (see the module documentation).
pub const HEAPS: i32 = 1;

/// Whether [`FreeMemoryReturner`] hands pages back on this target (glibc only).
pub const RETURNS_FREE_MEMORY: bool = cfg!(all(target_os = "linux", target_env = "gnu"));

/// How often the free pages of the heaps go back to the kernel.
pub const RETURN_FREE_MEMORY_EVERY: Duration = Duration::from_secs(1);

/// Fixes glibc's thresholds (see the module documentation). Call it first thing in `main`,
/// before other threads start. Elsewhere than glibc it does nothing.
pub fn settle_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets allocator parameters; it is called before any other thread
    // runs, and a refused setting leaves glibc's default, which is correct, only larger.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MAPPED_BLOCK_BYTES);
        libc::mallopt(libc::M_TRIM_THRESHOLD, MAPPED_BLOCK_BYTES);
        libc::mallopt(libc::M_ARENA_MAX, HEAPS);
    }
}

/// Hands the heaps' free pages back to the kernel, at most once per
/// [`RETURN_FREE_MEMORY_EVERY`] (see the module documentation). Elsewhere than glibc it does
/// nothing.
#[derive(Debug)]
pub struct FreeMemoryReturner {
    next: Instant,
}

impl Default for FreeMemoryReturner {
    fn default() -> Self {
        FreeMemoryReturner {
            next: Instant::now() + RETURN_FREE_MEMORY_EVERY,
        }
    }
}

impl FreeMemoryReturner {
    /// Hands the free pages back if [`RETURN_FREE_MEMORY_EVERY`] has passed since the last
    /// time (on glibc; elsewhere nothing); returns whether the interval had passed. Takes
    /// each heap's lock in turn while it walks that heap's free blocks, so the daemon calls
    /// it from a thread of its own, off the serial reader's timing.
    pub fn tick(&mut self) -> bool {
        let now = Instant::now();
        if now < self.next {
            return false;
        }
        self.next = now + RETURN_FREE_MEMORY_EVERY;
        #[cfg(all(target_os = "linux", target_env = "gnu"))]
        // SAFETY: `malloc_trim` only returns free pages of the allocator's own heaps to the
        // kernel; it takes each heap's lock and may be called from any thread (not from a
        // signal handler, which this is not).
        unsafe {
            libc::malloc_trim(0);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_memory_goes_back_at_most_once_per_interval() {
        let mut returner = FreeMemoryReturner {
            next: Instant::now(),
        };
        assert!(returner.tick());
        assert!(!returner.tick(), "not again within the interval");
    }
}
