//! Whether this CPU runs the matcher's wide-vector code paths.
//!
//! The fast matcher's hottest loop, counting uncovered pixels, is compiled twice: for the
//! baseline of the target, and for x86-64 CPUs with AVX2 and POPCNT, where the compiler
//! shifts, masks and counts a whole 256-pixel row in a few instructions. Which one runs is
//! decided once, at run time; both compute the same integers, so the answer does not depend
//! on the CPU.

/// Whether the AVX2 + POPCNT paths may run on this CPU (checked once, then cached).
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx2() -> bool {
    static HAS_AVX2: std::sync::LazyLock<bool> = std::sync::LazyLock::new(|| {
        std::is_x86_feature_detected!("avx2")
            && std::is_x86_feature_detected!("popcnt")
            && std::is_x86_feature_detected!("bmi2")
    });
    *HAS_AVX2
}
