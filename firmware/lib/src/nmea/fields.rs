//! Field decoders: fixed-point decimals, time of day, date and latitude/longitude, all
//! without floating point.
//!
//! Every decoder takes the raw field bytes and returns `Ok(None)` for an empty field, so
//! that every numeric field of a sentence can be optional (receivers without a fix send
//! empty fields).
//!
//! Rounding: decimals with more fraction digits than the target unit keeps are rounded half
//! away from zero (`1.2345` m → 1235 mm, `-1.2345` m → −1235 mm); time fractions beyond
//! microseconds are truncated, so that a time never rolls over into the next second.
//!
//! Latitude and longitude follow §8 of `shared/protocols/nmea0183.md`: the text `ddmm.mmmm`
//! (`dddmm.mmmm` for longitude) is read as an integer of minutes × 10^k (k = number of
//! minute decimals, up to [`MAX_MINUTE_DECIMALS`]), the degrees are split off with an
//! integer division by 100 × 10^k, and the minutes are converted to nanodegrees with
//! `u64` arithmetic, rounded half away from zero. The result is exact to the nanodegree:
//! no float ever touches it.

use protocol::{Date, TimeOfDay};

use super::Error;

/// The most minute decimals a latitude or longitude may carry (receivers send 2 to 8).
pub const MAX_MINUTE_DECIMALS: u32 = 12;

/// Nanodegrees per degree.
pub const NDEG_PER_DEG: i64 = 1_000_000_000;

/// Powers of ten that fit in a `u64`.
const POW10: [u64; 20] = {
    let mut table = [1u64; 20];
    let mut i = 1;
    while i < table.len() {
        table[i] = table[i - 1] * 10;
        i += 1;
    }
    table
};

/// `10^exp` (saturating at `u64::MAX` for exponents that do not fit).
const fn pow10(exp: u32) -> u64 {
    if (exp as usize) < POW10.len() {
        POW10[exp as usize]
    } else {
        u64::MAX
    }
}

/// The value of an ASCII digit, or `None`.
#[inline]
const fn digit(byte: u8) -> Option<u8> {
    if byte.is_ascii_digit() {
        Some(byte - b'0')
    } else {
        None
    }
}

/// Parses a run of ASCII digits (at least one) into a `u64`.
fn parse_digits(digits: &[u8]) -> Result<u64, Error> {
    if digits.is_empty() {
        return Err(Error::Malformed);
    }
    let mut value: u64 = 0;
    for &b in digits {
        let d = digit(b).ok_or(Error::Malformed)?;
        value = value
            .checked_mul(10)
            .and_then(|v| v.checked_add(u64::from(d)))
            .ok_or(Error::Malformed)?;
    }
    Ok(value)
}

/// Parses an unsigned integer field (`"07"` → 7).
///
/// # Errors
/// [`Error::Malformed`] for anything but digits, or a value above `u64::MAX`.
pub fn parse_uint(field: &[u8]) -> Result<Option<u64>, Error> {
    if field.is_empty() {
        return Ok(None);
    }
    parse_digits(field).map(Some)
}

/// Parses a decimal number with an optional sign (`-12.345`, `+0.5`, `.5`, `7.`) into an
/// integer counting units of 10^−`frac_digits`: `parse_fixed(b"-1.2345", 3)` is `-1235`
/// (milli-units, rounded half away from zero).
///
/// # Errors
/// [`Error::Malformed`] when the field is not a decimal number or does not fit in an `i64`
/// at that scale.
pub fn parse_fixed(field: &[u8], frac_digits: u32) -> Result<Option<i64>, Error> {
    if field.is_empty() {
        return Ok(None);
    }
    let (negative, rest) = match field.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, field),
    };
    let mut magnitude: u64 = 0;
    let mut seen_digit = false;
    let mut in_fraction = false;
    let mut kept_frac = 0u32;
    let mut dropped_any = false;
    let mut round_up = false;
    for &b in rest {
        if b == b'.' {
            if in_fraction {
                return Err(Error::Malformed);
            }
            in_fraction = true;
            continue;
        }
        let d = digit(b).ok_or(Error::Malformed)?;
        seen_digit = true;
        if in_fraction {
            if kept_frac == frac_digits {
                // The first dropped digit decides the rounding; later ones are only checked.
                if !dropped_any {
                    dropped_any = true;
                    round_up = d >= 5;
                }
                continue;
            }
            kept_frac += 1;
        }
        magnitude = magnitude
            .checked_mul(10)
            .and_then(|v| v.checked_add(u64::from(d)))
            .ok_or(Error::Malformed)?;
    }
    if !seen_digit {
        return Err(Error::Malformed);
    }
    let missing = frac_digits.saturating_sub(kept_frac);
    magnitude = magnitude
        .checked_mul(pow10(missing))
        .and_then(|v| v.checked_add(u64::from(round_up)))
        .ok_or(Error::Malformed)?;
    let value = i64::try_from(magnitude).map_err(|_| Error::Malformed)?;
    Ok(Some(if negative { -value } else { value }))
}

/// As [`parse_fixed`], for a quantity that cannot be negative and fits in `U`.
///
/// # Errors
/// [`Error::Malformed`] for a malformed, negative or too large value.
pub fn parse_fixed_unsigned<U: TryFrom<i64>>(
    field: &[u8],
    frac_digits: u32,
) -> Result<Option<U>, Error> {
    match parse_fixed(field, frac_digits)? {
        None => Ok(None),
        Some(v) if v < 0 => Err(Error::Malformed),
        Some(v) => U::try_from(v).map(Some).map_err(|_| Error::Malformed),
    }
}

/// As [`parse_fixed`], narrowed to an `i32`.
///
/// # Errors
/// [`Error::Malformed`] for a malformed or out-of-range value.
pub fn parse_fixed_i32(field: &[u8], frac_digits: u32) -> Result<Option<i32>, Error> {
    match parse_fixed(field, frac_digits)? {
        None => Ok(None),
        Some(v) => i32::try_from(v).map(Some).map_err(|_| Error::Malformed),
    }
}

/// Parses a course or angle in degrees into hundredths of a degree, folding 360° onto 0°.
///
/// # Errors
/// [`Error::Malformed`] for a malformed value, or one not in 0–360°.
pub fn parse_course_cdeg(field: &[u8]) -> Result<Option<u32>, Error> {
    match parse_fixed_unsigned::<u32>(field, 2)? {
        Some(cdeg) if cdeg > 36_000 => Err(Error::Malformed),
        Some(36_000) => Ok(Some(0)),
        other => Ok(other),
    }
}

/// Parses a two-digit decimal number at `at`.
fn two_digits(field: &[u8], at: usize) -> Result<u8, Error> {
    let tens = field
        .get(at)
        .copied()
        .and_then(digit)
        .ok_or(Error::Malformed)?;
    let ones = field
        .get(at + 1)
        .copied()
        .and_then(digit)
        .ok_or(Error::Malformed)?;
    Ok(tens * 10 + ones)
}

/// Parses a UTC time `hhmmss` with an optional fraction (`hhmmss.s…`). Fraction digits
/// beyond microseconds are truncated. Second 60 (leap second) is accepted.
///
/// # Errors
/// [`Error::Malformed`] for a wrong layout or an out-of-range hour, minute or second.
pub fn parse_time(field: &[u8]) -> Result<Option<TimeOfDay>, Error> {
    if field.is_empty() {
        return Ok(None);
    }
    let hour = two_digits(field, 0)?;
    let minute = two_digits(field, 2)?;
    let second = two_digits(field, 4)?;
    if hour > 23 || minute > 59 || second > 60 {
        return Err(Error::Malformed);
    }
    let micros = match field.get(6..) {
        Some([]) | None => 0,
        Some([b'.', fraction @ ..]) => {
            let mut micros = 0u32;
            for (i, &b) in fraction.iter().enumerate() {
                let d = digit(b).ok_or(Error::Malformed)?;
                if i < 6 {
                    micros = micros * 10 + u32::from(d);
                }
            }
            let shown = u32::try_from(fraction.len().min(6)).unwrap_or(6);
            micros * 10u32.pow(6 - shown)
        }
        Some(_) => return Err(Error::Malformed),
    };
    Ok(Some(TimeOfDay {
        hour,
        minute,
        second,
        micros,
    }))
}

/// Whether `year` is a Gregorian leap year.
const fn is_leap_year(year: u16) -> bool {
    (year % 4 == 0 && year % 100 != 0) || year % 400 == 0
}

/// Days in `month` (1–12) of `year`.
const fn days_in_month(year: u16, month: u8) -> u8 {
    match month {
        2 if is_leap_year(year) => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

/// Parses a date `ddmmyy`; the year is 2000 + `yy`.
///
/// # Errors
/// [`Error::Malformed`] for a wrong layout or a day that does not exist.
pub fn parse_date(field: &[u8]) -> Result<Option<Date>, Error> {
    if field.is_empty() {
        return Ok(None);
    }
    if field.len() != 6 {
        return Err(Error::Malformed);
    }
    let day = two_digits(field, 0)?;
    let month = two_digits(field, 2)?;
    let year = 2000 + u16::from(two_digits(field, 4)?);
    if !(1..=12).contains(&month) || day == 0 || day > days_in_month(year, month) {
        return Err(Error::Malformed);
    }
    Ok(Some(Date { year, month, day }))
}

/// Parses a latitude `ddmm.mmmm` with its hemisphere field (`N`/`S`) into nanodegrees,
/// north positive. An empty value is `None` whatever the hemisphere field holds.
///
/// # Errors
/// [`Error::Malformed`] for a malformed number, minutes ≥ 60, more than 90°, or a
/// hemisphere other than `N`/`S`.
pub fn parse_latitude(value: &[u8], hemisphere: &[u8]) -> Result<Option<i64>, Error> {
    parse_angle(value, hemisphere, 90, b'N', b'S')
}

/// Parses a longitude `dddmm.mmmm` with its hemisphere field (`E`/`W`) into nanodegrees,
/// east positive. An empty value is `None` whatever the hemisphere field holds.
///
/// # Errors
/// [`Error::Malformed`] for a malformed number, minutes ≥ 60, more than 180°, or a
/// hemisphere other than `E`/`W`.
pub fn parse_longitude(value: &[u8], hemisphere: &[u8]) -> Result<Option<i64>, Error> {
    parse_angle(value, hemisphere, 180, b'E', b'W')
}

/// The common part of [`parse_latitude`] and [`parse_longitude`].
fn parse_angle(
    value: &[u8],
    hemisphere: &[u8],
    max_deg: u64,
    positive: u8,
    negative: u8,
) -> Result<Option<i64>, Error> {
    if value.is_empty() {
        return Ok(None);
    }
    let negate = match hemisphere {
        [h] if *h == positive => false,
        [h] if *h == negative => true,
        _ => return Err(Error::Malformed),
    };
    let (int_text, frac_text) = match value.iter().position(|&b| b == b'.') {
        Some(dot) => (
            value.get(..dot).unwrap_or(&[]),
            value.get(dot + 1..).unwrap_or(&[]),
        ),
        None => (value, &[][..]),
    };
    let decimals = u32::try_from(frac_text.len()).map_err(|_| Error::Malformed)?;
    if decimals > MAX_MINUTE_DECIMALS || int_text.len() > 5 {
        return Err(Error::Malformed);
    }
    let int_part = parse_digits(int_text)?;
    let frac_part = if frac_text.is_empty() {
        0
    } else {
        parse_digits(frac_text)?
    };
    let degrees = int_part / 100;
    let scale = pow10(decimals);
    // Both factors are bounded (minutes < 100, scale ≤ 10^12), so this cannot overflow.
    let minutes_scaled = (int_part % 100) * scale + frac_part;
    if minutes_scaled >= 60 * scale {
        return Err(Error::Malformed);
    }
    // nanodegrees of the minutes = minutes_scaled × 10⁹ / (60 × 10^k), rounded half up.
    let minutes_ndeg = if decimals <= 9 {
        (minutes_scaled * pow10(9 - decimals) + 30) / 60
    } else {
        let divisor = 60 * pow10(decimals - 9);
        (minutes_scaled + divisor / 2) / divisor
    };
    let ndeg_per_deg = NDEG_PER_DEG.unsigned_abs();
    let magnitude = degrees * ndeg_per_deg + minutes_ndeg;
    if magnitude > max_deg * ndeg_per_deg {
        return Err(Error::Malformed);
    }
    let magnitude = i64::try_from(magnitude).map_err(|_| Error::Malformed)?;
    Ok(Some(if negate { -magnitude } else { magnitude }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn fixed_point_rounds_half_away_from_zero() {
        assert_eq!(parse_fixed(b"1.2345", 3), Ok(Some(1235)));
        assert_eq!(parse_fixed(b"-1.2345", 3), Ok(Some(-1235)));
        assert_eq!(parse_fixed(b"1.2344999", 3), Ok(Some(1234)));
        assert_eq!(parse_fixed(b"0.9", 2), Ok(Some(90)));
        assert_eq!(parse_fixed(b"99.99", 2), Ok(Some(9999)));
        assert_eq!(parse_fixed(b"+5", 1), Ok(Some(50)));
        assert_eq!(parse_fixed(b".5", 0), Ok(Some(1)));
        assert_eq!(parse_fixed(b"7.", 1), Ok(Some(70)));
        assert_eq!(parse_fixed(b"-31.442", 3), Ok(Some(-31442)));
        assert_eq!(parse_fixed(b"", 3), Ok(None));
    }

    #[test]
    fn fixed_point_rejects_garbage() {
        for bad in [&b"."[..], b"-", b"1.2.3", b"1e5", b"12a", b" 1", b"--1"] {
            assert_eq!(parse_fixed(bad, 2), Err(Error::Malformed), "{bad:?}");
        }
        assert_eq!(
            parse_fixed(b"99999999999999999999", 0),
            Err(Error::Malformed)
        );
        assert_eq!(parse_fixed(b"9999999999999999", 6), Err(Error::Malformed));
        assert_eq!(parse_fixed_unsigned::<u16>(b"-1", 0), Err(Error::Malformed));
        assert_eq!(
            parse_fixed_unsigned::<u16>(b"655.36", 2),
            Err(Error::Malformed)
        );
    }

    #[test]
    fn course_folds_360() {
        assert_eq!(parse_course_cdeg(b"359.996"), Ok(Some(0)));
        assert_eq!(parse_course_cdeg(b"124.888"), Ok(Some(12489)));
        assert_eq!(parse_course_cdeg(b"360.5"), Err(Error::Malformed));
    }

    #[test]
    fn time_of_day() {
        let t = parse_time(b"132819.60").unwrap().unwrap();
        assert_eq!(
            (t.hour, t.minute, t.second, t.micros),
            (13, 28, 19, 600_000)
        );
        let t = parse_time(b"235960").unwrap().unwrap();
        assert_eq!((t.second, t.micros), (60, 0));
        let t = parse_time(b"000000.1234567").unwrap().unwrap();
        assert_eq!(t.micros, 123_456);
        assert_eq!(parse_time(b""), Ok(None));
        for bad in [
            &b"24000"[..],
            b"240000",
            b"126000",
            b"1200",
            b"120000,",
            b"120000.x",
        ] {
            assert_eq!(parse_time(bad), Err(Error::Malformed), "{bad:?}");
        }
    }

    #[test]
    fn dates() {
        assert_eq!(
            parse_date(b"180320"),
            Ok(Some(Date {
                year: 2020,
                month: 3,
                day: 18
            }))
        );
        assert!(parse_date(b"290224").unwrap().is_some());
        for bad in [&b"290223"[..], b"001220", b"011320", b"31042", b"3104200"] {
            assert_eq!(parse_date(bad), Err(Error::Malformed), "{bad:?}");
        }
    }

    #[test]
    fn latitude_longitude_examples_of_the_protocol_doc() {
        assert_eq!(parse_latitude(b"4807.038", b"N"), Ok(Some(48_117_300_000)));
        // −(123 + 11.12/60) = −123.185333…
        assert_eq!(
            parse_longitude(b"12311.12", b"W"),
            Ok(Some(-123_185_333_333))
        );
        assert_eq!(
            parse_longitude(b"00854.7249096", b"E"),
            Ok(Some(8_912_081_827))
        );
        // gpsd: 41.574965910, −93.750571901 (nmea-rtk.log).
        assert_eq!(
            parse_latitude(b"4134.49795459", b"N"),
            Ok(Some(41_574_965_910))
        );
        assert_eq!(
            parse_longitude(b"09345.03431408", b"W"),
            Ok(Some(-93_750_571_901))
        );
        assert_eq!(parse_latitude(b"", b"N"), Ok(None));
        assert_eq!(parse_latitude(b"", b""), Ok(None));
        assert_eq!(parse_latitude(b"9000.000", b"S"), Ok(Some(-90_000_000_000)));
        assert_eq!(parse_longitude(b"18000", b"W"), Ok(Some(-180_000_000_000)));
    }

    #[test]
    fn latitude_longitude_validation() {
        for (value, hemi) in [
            (&b"4860.000"[..], &b"N"[..]),
            (b"9000.001", b"N"),
            (b"4807.038", b"E"),
            (b"4807.038", b""),
            (b"4807.038", b"n"),
            (b"48O7.038", b"N"),
            (b"4807.0380000000001", b"N"),
            (b".5", b"N"),
        ] {
            assert_eq!(
                parse_latitude(value, hemi),
                Err(Error::Malformed),
                "{value:?}"
            );
        }
        assert_eq!(parse_longitude(b"18000.0001", b"E"), Err(Error::Malformed));
        assert_eq!(parse_longitude(b"123456.0", b"E"), Err(Error::Malformed));
    }

    proptest! {
        /// Any printed minute value converts to the exact rational value, rounded.
        #[test]
        fn latitude_matches_exact_rational(deg in 0u64..90, min_scaled in 0u64..60_000_000_000, k in 0u32..=10) {
            let scale = pow10(k);
            let min_scaled = min_scaled % (60 * scale);
            let text = if k == 0 {
                format!("{:02}{:02}", deg, min_scaled)
            } else {
                format!("{:02}{:02}.{:0width$}", deg, min_scaled / scale, min_scaled % scale, width = k as usize)
            };
            let expected = {
                let num = u128::from(deg) * 60 * u128::from(scale) * 1_000_000_000
                    + u128::from(min_scaled) * 1_000_000_000;
                let den = 60 * u128::from(scale);
                i64::try_from((2 * num + den) / (2 * den)).unwrap()
            };
            prop_assert_eq!(parse_latitude(text.as_bytes(), b"N"), Ok(Some(expected)));
            prop_assert_eq!(parse_latitude(text.as_bytes(), b"S"), Ok(Some(-expected)));
        }

        #[test]
        fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..24)) {
            let _ = parse_fixed(&bytes, 3);
            let _ = parse_time(&bytes);
            let _ = parse_date(&bytes);
            let _ = parse_latitude(&bytes, b"N");
            let _ = parse_longitude(&bytes, b"W");
            let _ = parse_uint(&bytes);
        }
    }
}
