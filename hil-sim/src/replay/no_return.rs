//! Which ranges of a laser log mean "no return".
//!
//! A SICK LMS2xx reports a beam that met nothing within its reach as its largest value, and
//! logs keep that value as a range: 81.83 m or 81.91 m in the 80 m modes, 32.767 m where the
//! ranges are 16-bit millimetres, 8.191 m in the 8 m mode, or whatever a converter clipped
//! to. Taken as an end point it is a wall that is not there, drawn at the same distance
//! whichever way the robot moved; weighted by its range, a handful of them outweigh every
//! near wall of a scan. Logs do not say which value they use (a `ROBOTLASER1` line gives a
//! maximum range, a `FLASER` line nothing), so it is read from the ranges themselves: the
//! largest range of a log is its no-return value when many ranges pile up just below it, as
//! saturated readings do and real surfaces do not.

use super::LaserRecord;

/// Ranges within this fraction below a log's largest range count as that value (a sensor's
/// saturated readings differ in their last digits: 32.759–32.767 m, 81.83 and 81.91 m).
pub const SATURATION_BAND: f64 = 0.01;

/// A log's largest range is its no-return value when at least this share of all its ranges
/// lie in [`SATURATION_BAND`] below it.
pub const MIN_SATURATED_SHARE: f64 = 0.001;

/// Where no pile-up is found: ranges at or above this are no return, m (the LMS2xx reaches
/// no farther than 80 m).
pub const DEFAULT_NO_RETURN_FROM_M: f64 = 80.0;

/// Ranges at or above the returned value are no return, m: the lower edge of the
/// [`SATURATION_BAND`] below the largest range of `lasers` when at least
/// [`MIN_SATURATED_SHARE`] of their ranges lie in it ([`saturation_from_m`]), at most
/// [`DEFAULT_NO_RETURN_FROM_M`], else [`DEFAULT_NO_RETURN_FROM_M`].
pub fn detect_no_return_from_m<'a>(lasers: impl IntoIterator<Item = &'a LaserRecord>) -> f64 {
    saturation_from_m(lasers).map_or(DEFAULT_NO_RETURN_FROM_M, |from_m| {
        from_m.min(DEFAULT_NO_RETURN_FROM_M)
    })
}

/// The lower edge of the [`SATURATION_BAND`] below the largest range of `lasers`, m, when at
/// least [`MIN_SATURATED_SHARE`] of their ranges lie in it; `None` when they do not pile up
/// there (or there are no ranges).
pub fn saturation_from_m<'a>(lasers: impl IntoIterator<Item = &'a LaserRecord>) -> Option<f64> {
    let lasers: Vec<&LaserRecord> = lasers.into_iter().collect();
    let ranges = || {
        lasers
            .iter()
            .flat_map(|l| l.ranges_m.iter().copied())
            .filter(|r| r.is_finite() && *r > 0.0)
    };
    let largest_m = ranges().reduce(f64::max)?;
    let from_m = largest_m * (1.0 - SATURATION_BAND);
    let (saturated, all) = ranges().fold((0usize, 0usize), |(saturated, all), r| {
        (saturated + usize::from(r >= from_m), all + 1)
    });
    (saturated as f64 >= MIN_SATURATED_SHARE * all as f64).then_some(from_m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::CarmenLog;

    fn log_of(scans: &[Vec<f64>]) -> CarmenLog {
        let text: String = scans
            .iter()
            .enumerate()
            .map(|(i, ranges)| {
                let ranges: Vec<String> = ranges.iter().map(|r| format!("{r:.3}")).collect();
                format!(
                    "FLASER {} {} 0 0 0 0 0 0 {i}.0 host {i}.0\n",
                    ranges.len(),
                    ranges.join(" ")
                )
            })
            .collect();
        CarmenLog::parse(&text, "test.clf").expect("a valid log")
    }

    #[test]
    fn a_pile_up_at_the_largest_range_is_no_return() {
        // Near walls, one far wall at 20 m, and a few beams saturated at 32.767 m and a
        // millimetre or so below.
        let mut scans = Vec::new();
        for i in 0..50 {
            let mut ranges = vec![2.0 + f64::from(i) * 0.01; 170];
            ranges.extend([20.0; 5]);
            ranges.extend([32.767, 32.763, 32.759, 32.767]);
            scans.push(ranges);
        }
        let log = log_of(&scans);
        let from_m = detect_no_return_from_m(log.lasers());
        assert!((32.3..32.759).contains(&from_m), "{from_m}");
    }

    #[test]
    fn two_saturation_codes_of_the_80_m_mode_are_both_no_return() {
        let mut ranges = vec![5.0; 170];
        ranges.extend([81.83, 81.91, 81.91]);
        let log = log_of(&[ranges]);
        let from_m = saturation_from_m(log.lasers()).expect("a pile-up");
        assert!((81.0..81.83).contains(&from_m), "{from_m}");
        assert_eq!(
            detect_no_return_from_m(log.lasers()),
            DEFAULT_NO_RETURN_FROM_M
        );
    }

    #[test]
    fn a_log_whose_largest_range_is_a_lone_real_wall_keeps_it() {
        // One beam a scan reaches a far wall at up to 30 m; nothing piles up below it.
        let scans: Vec<Vec<f64>> = (0..20)
            .map(|i| {
                let mut ranges = vec![3.0; 2000];
                ranges.push(20.0 + f64::from(i) * 0.5);
                ranges
            })
            .collect();
        let log = log_of(&scans);
        assert_eq!(saturation_from_m(log.lasers()), None);
        assert_eq!(
            detect_no_return_from_m(log.lasers()),
            DEFAULT_NO_RETURN_FROM_M
        );
    }

    #[test]
    fn a_log_without_ranges_falls_back_to_the_default() {
        assert_eq!(
            detect_no_return_from_m(std::iter::empty()),
            DEFAULT_NO_RETURN_FROM_M
        );
    }
}
