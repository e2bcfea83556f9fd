//! `floor` without a library call.
//!
//! On the baseline x86-64 (no SSE4.1), [`f64::floor`] calls into the C library, and cell and
//! pixel indices are computed millions of times a run. Truncating and correcting gives the
//! same value with a few instructions.

/// Exactly [`f64::floor`] of `value`, for every `value` (NaN and infinities included).
#[inline]
pub(crate) fn floor(value: f64) -> f64 {
    // Below 2^52 in magnitude the truncation to an integer is exact; beyond, every `f64` is
    // an integer already, and NaN fails the test.
    if value.abs() < 4_503_599_627_370_496.0 {
        let truncated = value as i64 as f64;
        if truncated > value {
            truncated - 1.0
        } else {
            // Keeps the sign of -0.0.
            truncated.copysign(value)
        }
    } else {
        value.floor()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn edge_cases_match_the_library() {
        for value in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            -1.0,
            1.0 - f64::EPSILON,
            -1e-300,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
        ] {
            assert_eq!(floor(value).to_bits(), value.floor().to_bits(), "{value}");
        }
        assert!(floor(f64::NAN).is_nan());
    }

    proptest! {
        #[test]
        fn prop_matches_the_library(value in any::<f64>()) {
            prop_assert!(
                floor(value).to_bits() == value.floor().to_bits()
                    || (value.is_nan() && floor(value).is_nan())
            );
        }
    }
}
