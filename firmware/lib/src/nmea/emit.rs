//! Writing sentences: the `$`, address, fields, `*hh` checksum and CR LF, into any
//! [`core::fmt::Write`] (a `heapless::String`, a `String`, a UART adapter).
//!
//! The field encoders are the inverses of [`super::fields`]: a value written here parses
//! back to the same integer. Values outside what NMEA can express (a year outside
//! 2000–2099, a latitude beyond ±90°, a time past 23:59:60) make the writer fail with
//! [`fmt::Error`] instead of producing a sentence that would not parse.

use core::fmt::{self, Write};

use protocol::{Date, TimeOfDay};

use super::fields::NDEG_PER_DEG;

/// Writes one sentence: `$`, `address`, the fields written by `body` (which starts each
/// field with a comma), then `*hh` and CR LF.
///
/// # Errors
/// When `out` fails or `body` returns an error.
pub fn write_sentence<W: Write>(
    out: &mut W,
    address: &[u8],
    body: impl FnOnce(&mut ChecksumWriter<'_, W>) -> fmt::Result,
) -> fmt::Result {
    if !address.iter().all(u8::is_ascii_alphanumeric) {
        return Err(fmt::Error);
    }
    let address = core::str::from_utf8(address).map_err(|_| fmt::Error)?;
    out.write_char('$')?;
    let mut writer = ChecksumWriter {
        inner: out,
        checksum: 0,
    };
    writer.write_str(address)?;
    body(&mut writer)?;
    let checksum = writer.checksum;
    write!(out, "*{checksum:02X}\r\n")
}

/// A writer that forwards to another and keeps the XOR of every byte written.
#[derive(Debug)]
pub struct ChecksumWriter<'w, W: Write> {
    inner: &'w mut W,
    checksum: u8,
}

impl<W: Write> Write for ChecksumWriter<'_, W> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        if !s.bytes().all(super::sentence::is_printable) || s.contains(['$', '*']) {
            return Err(fmt::Error);
        }
        self.checksum = s.bytes().fold(self.checksum, |acc, b| acc ^ b);
        self.inner.write_str(s)
    }
}

/// Writes `,` and then `value` × 10^−`frac_digits` with exactly `frac_digits` decimals
/// (`12345`, 2 → `123.45`); nothing after the comma for `None`.
///
/// # Errors
/// When the writer fails.
pub fn write_fixed<W: Write>(w: &mut W, value: Option<i64>, frac_digits: u32) -> fmt::Result {
    w.write_char(',')?;
    let Some(value) = value else {
        return Ok(());
    };
    if value < 0 {
        w.write_char('-')?;
    }
    let magnitude = value.unsigned_abs();
    if frac_digits == 0 {
        return write!(w, "{magnitude}");
    }
    let scale = 10u64.checked_pow(frac_digits).ok_or(fmt::Error)?;
    let width = usize::try_from(frac_digits).map_err(|_| fmt::Error)?;
    write!(w, "{}.{:0width$}", magnitude / scale, magnitude % scale)
}

/// [`write_fixed`] for any integer type that converts into an `i64`.
///
/// # Errors
/// When the writer fails.
pub fn write_opt<W: Write, V: Into<i64>>(
    w: &mut W,
    value: Option<V>,
    frac_digits: u32,
) -> fmt::Result {
    write_fixed(w, value.map(Into::into), frac_digits)
}

/// Writes `,` and an optional single character field.
///
/// # Errors
/// When the writer fails.
pub fn write_char_field<W: Write>(w: &mut W, value: Option<u8>) -> fmt::Result {
    w.write_char(',')?;
    match value {
        Some(c) => w.write_char(char::from(c)),
        None => Ok(()),
    }
}

/// Writes `,` and a time `hhmmss.ss`, with as many decimals (2 to 6) as the microseconds
/// need to be exact.
///
/// # Errors
/// When the writer fails or the time is out of range.
pub fn write_time<W: Write>(w: &mut W, time: Option<TimeOfDay>) -> fmt::Result {
    w.write_char(',')?;
    let Some(t) = time else {
        return Ok(());
    };
    if t.hour > 23 || t.minute > 59 || t.second > 60 || t.micros > 999_999 {
        return Err(fmt::Error);
    }
    write!(w, "{:02}{:02}{:02}.", t.hour, t.minute, t.second)?;
    let (digits, decimals) = trim_decimals(u64::from(t.micros), 6, 2);
    write!(w, "{digits:0decimals$}")
}

/// Writes `,` and a date `ddmmyy`.
///
/// # Errors
/// When the writer fails or the year is not in 2000–2099.
pub fn write_date<W: Write>(w: &mut W, date: Option<Date>) -> fmt::Result {
    w.write_char(',')?;
    let Some(d) = date else {
        return Ok(());
    };
    if !(2000..=2099).contains(&d.year)
        || !(1..=12).contains(&d.month)
        || !(1..=31).contains(&d.day)
    {
        return Err(fmt::Error);
    }
    write!(w, "{:02}{:02}{:02}", d.day, d.month, d.year - 2000)
}

/// Writes `,ddmm.mmmm,N` (or `,,` for `None`): the latitude with the fewest minute
/// decimals, at least 4 and at most 8, that represent the nanodegrees exactly.
///
/// # Errors
/// When the writer fails or the latitude is beyond ±90°.
pub fn write_latitude<W: Write>(w: &mut W, lat_ndeg: Option<i64>) -> fmt::Result {
    write_angle(w, lat_ndeg, 90, 2, 'N', 'S')
}

/// Writes `,dddmm.mmmm,E` (or `,,` for `None`), as [`write_latitude`].
///
/// # Errors
/// When the writer fails or the longitude is beyond ±180°.
pub fn write_longitude<W: Write>(w: &mut W, lon_ndeg: Option<i64>) -> fmt::Result {
    write_angle(w, lon_ndeg, 180, 3, 'E', 'W')
}

/// The common part of [`write_latitude`] and [`write_longitude`].
fn write_angle<W: Write>(
    w: &mut W,
    ndeg: Option<i64>,
    max_deg: u64,
    degree_digits: usize,
    positive: char,
    negative: char,
) -> fmt::Result {
    let Some(ndeg) = ndeg else {
        return w.write_str(",,");
    };
    let per_deg = NDEG_PER_DEG.unsigned_abs();
    let magnitude = ndeg.unsigned_abs();
    if magnitude > max_deg * per_deg {
        return Err(fmt::Error);
    }
    let degrees = magnitude / per_deg;
    // One nanodegree is exactly 6 × 10⁻⁸ minutes, so 8 decimals represent it exactly.
    let minutes_e8 = (magnitude % per_deg) * 6;
    let (fraction, decimals) = trim_decimals(minutes_e8 % 100_000_000, 8, 4);
    write!(
        w,
        ",{degrees:0degree_digits$}{:02}.{fraction:0decimals$},{}",
        minutes_e8 / 100_000_000,
        if ndeg < 0 { negative } else { positive }
    )
}

/// Drops trailing zero decimals of `fraction` (which has `decimals` digits) while more than
/// `min_decimals` remain; returns the shortened fraction and its digit count.
fn trim_decimals(mut fraction: u64, mut decimals: usize, min_decimals: usize) -> (u64, usize) {
    while decimals > min_decimals && fraction % 10 == 0 {
        fraction /= 10;
        decimals -= 1;
    }
    (fraction, decimals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::Sentence;
    use crate::nmea::fields::{parse_latitude, parse_longitude, parse_time};
    use proptest::prelude::*;

    #[test]
    fn sentence_frame_and_checksum() {
        let mut out = String::new();
        write_sentence(&mut out, b"GPGGA", |w| {
            write_time(w, None)?;
            write_latitude(w, None)?;
            write_longitude(w, None)?;
            write_opt::<_, u8>(w, Some(0), 0)?;
            for _ in 0..8 {
                write_opt::<_, u8>(w, None, 0)?;
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(out, "$GPGGA,,,,,,0,,,,,,,,*66\r\n");
        assert!(Sentence::new_checked(out.trim_end().as_bytes()).is_ok());
    }

    #[test]
    fn refuses_reserved_characters_and_bad_addresses() {
        let mut out = String::new();
        assert!(write_sentence(&mut out, b"GP*GA", |_| Ok(())).is_err());
        let mut out = String::new();
        assert!(write_sentence(&mut out, b"GPTXT", |w| w.write_str(",a*b")).is_err());
    }

    #[test]
    fn fixed_point_text() {
        let mut s = String::new();
        write_fixed(&mut s, Some(-31442), 3).unwrap();
        write_fixed(&mut s, Some(5), 2).unwrap();
        write_fixed(&mut s, None, 2).unwrap();
        write_fixed(&mut s, Some(7), 0).unwrap();
        assert_eq!(s, ",-31.442,0.05,,7");
    }

    #[test]
    fn latitude_text_is_short_when_exact() {
        let mut s = String::new();
        write_latitude(&mut s, Some(48_117_300_000)).unwrap();
        write_longitude(&mut s, Some(-123_185_333_333)).unwrap();
        assert_eq!(s, ",4807.0380,N,12311.11999998,W");
    }

    #[test]
    fn time_text() {
        let mut s = String::new();
        write_time(
            &mut s,
            Some(TimeOfDay {
                hour: 1,
                minute: 2,
                second: 3,
                micros: 120_000,
            }),
        )
        .unwrap();
        assert_eq!(s, ",010203.12");
    }

    proptest! {
        #[test]
        fn angles_round_trip(lat in -90_000_000_000i64..=90_000_000_000, lon in -180_000_000_000i64..=180_000_000_000) {
            let mut s = String::new();
            write_latitude(&mut s, Some(lat)).unwrap();
            write_longitude(&mut s, Some(lon)).unwrap();
            let f: Vec<&str> = s.split(',').collect();
            prop_assert_eq!(parse_latitude(f[1].as_bytes(), f[2].as_bytes()), Ok(Some(lat)));
            prop_assert_eq!(parse_longitude(f[3].as_bytes(), f[4].as_bytes()), Ok(Some(lon)));
        }

        #[test]
        fn times_round_trip(h in 0u8..24, m in 0u8..60, sec in 0u8..=60, micros in 0u32..1_000_000) {
            let t = TimeOfDay { hour: h, minute: m, second: sec, micros };
            let mut s = String::new();
            write_time(&mut s, Some(t)).unwrap();
            prop_assert_eq!(parse_time(&s.as_bytes()[1..]), Ok(Some(t)));
        }
    }
}
