//! Which wide-vector build of the matcher's hottest loop this CPU runs.
//!
//! Counting uncovered pixels ([`super::rotated_scan`]) is compiled three times: for the
//! baseline of the target, for x86-64 CPUs with AVX2 and POPCNT, where a 256-pixel row is
//! shifted, masked and counted as one vector, and for those with AVX-512's vector popcount,
//! which counts the row's four words in one instruction. Which one runs is decided once, at
//! run time; all compute the same integers, so no answer depends on the CPU.

/// A build of the vector code, each needing more of the CPU than the one before.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum SimdLevel {
    /// Whatever the target guarantees.
    Baseline,
    /// AVX2, POPCNT and BMI2 (x86-64).
    Avx2,
    /// The above with AVX-512 F, VL, BW and VPOPCNTDQ (x86-64).
    Avx512,
}

impl SimdLevel {
    /// The highest level this CPU runs (checked once, then cached).
    pub(crate) fn detected() -> SimdLevel {
        #[cfg(target_arch = "x86_64")]
        {
            static DETECTED: std::sync::LazyLock<SimdLevel> = std::sync::LazyLock::new(|| {
                use std::is_x86_feature_detected as has;
                let avx2 = has!("avx2") && has!("popcnt") && has!("bmi2");
                let avx512 = has!("avx512f")
                    && has!("avx512vl")
                    && has!("avx512bw")
                    && has!("avx512vpopcntdq");
                match (avx2, avx512) {
                    (true, true) => SimdLevel::Avx512,
                    (true, false) => SimdLevel::Avx2,
                    _ => SimdLevel::Baseline,
                }
            });
            *DETECTED
        }
        #[cfg(not(target_arch = "x86_64"))]
        SimdLevel::Baseline
    }
}
