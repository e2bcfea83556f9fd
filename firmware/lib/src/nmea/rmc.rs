//! `$--RMC`: recommended minimum specific GNSS data (§5.2 of
//! `shared/protocols/nmea0183.md`).
//!
//! ```text
//! $--RMC,hhmmss.ss,A,ddmm.mm,N,dddmm.mm,W,sog,cog,ddmmyy,mv,E,m,s*hh
//! ```
//!
//! Accepted field counts: 11 (before NMEA 2.3, no mode), 12 (mode) and 13 (NMEA 4.10
//! navigational status). Without a fix (status `V`, mode `N`), a position that does not
//! decode reads as `None`. Speed is sent in knots and kept in mm/s (1 kn = 1852/3600 m/s,
//! rounded half away from zero); [`RmcRepr::emit`] writes knots with 4 decimals, enough for
//! the mm/s value to survive the round trip.

use core::fmt::{self, Write};

use protocol::{Date, FixQuality, Position, TimeOfDay};

use super::emit::{
    write_char_field, write_date, write_fixed, write_latitude, write_longitude, write_opt,
    write_sentence, write_time,
};
use super::fields::{parse_course_cdeg, parse_date, parse_fixed, parse_fixed_unsigned, parse_time};
use super::gga::parse_position;
use super::mode::{parse_status, status_letter, status_quality};
use super::{Error, Mode, Sentence, SentenceKind};

/// Field positions, counted from 0 after the address.
mod field {
    pub const TIME: usize = 0;
    pub const STATUS: usize = 1;
    pub const LAT: usize = 2;
    pub const LAT_HEMI: usize = 3;
    pub const LON: usize = 4;
    pub const LON_HEMI: usize = 5;
    pub const SPEED_KN: usize = 6;
    pub const COURSE: usize = 7;
    pub const DATE: usize = 8;
    pub const MAG_VAR: usize = 9;
    pub const MAG_VAR_DIR: usize = 10;
    pub const MODE: usize = 11;
    pub const NAV_STATUS: usize = 12;
    /// The fewest and most fields accepted.
    pub const MIN_COUNT: usize = 11;
    pub const MAX_COUNT: usize = 13;
}

/// Micro-knots per mm/s is 3600 / 1852 × 1000: speed_mm_s = µkn × 1852 / 3 600 000.
const MM_S_PER_UKN_NUM: i64 = 1852;
/// See [`MM_S_PER_UKN_NUM`].
const MM_S_PER_UKN_DEN: i64 = 3_600_000;

/// The content of an RMC sentence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RmcRepr {
    /// UTC time of the fix.
    pub time: Option<TimeOfDay>,
    /// Status: `Some(true)` for `A` (valid), `Some(false)` for `V` (warning).
    pub valid: Option<bool>,
    /// Position as sent, whatever the status (see [`RmcRepr::fix_position`]).
    pub position: Option<Position>,
    /// Speed over ground, mm/s.
    pub speed_mm_s: Option<u32>,
    /// Course over ground from true north, hundredths of a degree.
    pub course_cdeg: Option<u32>,
    /// UTC date.
    pub date: Option<Date>,
    /// Magnetic variation, hundredths of a degree, east positive.
    pub mag_var_cdeg: Option<i32>,
    /// Mode indicator (NMEA 2.3+).
    pub mode: Option<Mode>,
    /// Navigational status letter (NMEA 4.10+), e.g. `b'V'`.
    pub nav_status: Option<u8>,
}

impl RmcRepr {
    /// Decodes an RMC sentence from any talker. The view should have passed
    /// [`Sentence::new_checked`]; the checksum is not verified again.
    ///
    /// # Errors
    /// [`Error::WrongFormatter`] for another sentence type, [`Error::Malformed`] for a wrong
    /// field count or any field that does not decode.
    pub fn parse<T: AsRef<[u8]>>(sentence: &Sentence<T>) -> Result<Self, Error> {
        if sentence.kind() != SentenceKind::Rmc {
            return Err(Error::WrongFormatter);
        }
        let (f, count) = sentence.field_array::<{ field::MAX_COUNT }>();
        if !(field::MIN_COUNT..=field::MAX_COUNT).contains(&count) {
            return Err(Error::Malformed);
        }
        let mag_var_cdeg = match (
            parse_fixed_unsigned::<u16>(f[field::MAG_VAR], 2)?,
            f[field::MAG_VAR_DIR],
        ) {
            (None, _) => None,
            (Some(v), b"E") => Some(i32::from(v)),
            (Some(v), b"W") => Some(-i32::from(v)),
            (Some(_), _) => return Err(Error::Malformed),
        };
        let nav_status = match f[field::NAV_STATUS] {
            [] => None,
            [c] if c.is_ascii_uppercase() => Some(*c),
            _ => return Err(Error::Malformed),
        };
        let valid = parse_status(f[field::STATUS])?;
        let mode = Mode::parse(f[field::MODE])?;
        Ok(RmcRepr {
            time: parse_time(f[field::TIME])?,
            valid,
            position: parse_position(
                (f[field::LAT], f[field::LAT_HEMI]),
                (f[field::LON], f[field::LON_HEMI]),
                status_quality(valid, mode) == FixQuality::Invalid,
            )?,
            speed_mm_s: parse_knots(f[field::SPEED_KN])?,
            course_cdeg: parse_course_cdeg(f[field::COURSE])?,
            date: parse_date(f[field::DATE])?,
            mag_var_cdeg,
            mode,
            nav_status,
        })
    }

    /// The fix quality the status and mode imply (§9: status `V` or mode `N` is invalid).
    pub fn quality(&self) -> FixQuality {
        status_quality(self.valid, self.mode)
    }

    /// The position if status and mode say it is a fix.
    pub fn fix_position(&self) -> Option<Position> {
        match self.quality() {
            FixQuality::Invalid => None,
            _ => self.position,
        }
    }

    /// Writes the sentence with `talker`: 11 fields when there is neither mode nor
    /// navigational status, 12 with a mode, 13 with a navigational status.
    ///
    /// # Errors
    /// When `out` fails or a value cannot be expressed (see [`super::emit`]).
    pub fn emit<W: Write>(&self, talker: [u8; 2], out: &mut W) -> fmt::Result {
        let [a, b] = talker;
        write_sentence(out, &[a, b, b'R', b'M', b'C'], |w| {
            write_time(w, self.time)?;
            write_char_field(w, status_letter(self.valid))?;
            write_latitude(w, self.position.map(|p| p.lat_ndeg))?;
            write_longitude(w, self.position.map(|p| p.lon_ndeg))?;
            write_fixed(w, self.speed_mm_s.map(mm_s_to_centi_milli_knots), 4)?;
            write_opt(w, self.course_cdeg, 2)?;
            write_date(w, self.date)?;
            write_opt(w, self.mag_var_cdeg.map(i32::unsigned_abs), 2)?;
            write_char_field(
                w,
                self.mag_var_cdeg.map(|v| if v < 0 { b'W' } else { b'E' }),
            )?;
            if self.mode.is_some() || self.nav_status.is_some() {
                write_char_field(w, self.mode.map(Mode::letter))?;
            }
            if self.nav_status.is_some() {
                write_char_field(w, self.nav_status)?;
            }
            Ok(())
        })
    }
}

/// Parses a speed in knots into mm/s, rounded half away from zero.
///
/// # Errors
/// [`Error::Malformed`] for a malformed, negative or too large value.
pub fn parse_knots(field: &[u8]) -> Result<Option<u32>, Error> {
    let Some(micro_knots) = parse_fixed(field, 6)? else {
        return Ok(None);
    };
    if micro_knots < 0 {
        return Err(Error::Malformed);
    }
    let mm_s = micro_knots
        .checked_mul(MM_S_PER_UKN_NUM)
        .map(|n| (n + MM_S_PER_UKN_DEN / 2) / MM_S_PER_UKN_DEN)
        .ok_or(Error::Malformed)?;
    u32::try_from(mm_s).map(Some).map_err(|_| Error::Malformed)
}

/// Converts mm/s into ten-thousandths of a knot, rounded half up.
pub fn mm_s_to_centi_milli_knots(speed_mm_s: u32) -> i64 {
    // 1 mm/s = 3600 / 1852 × 10 kn/10⁴ ; numerator and denominator in i64 cannot overflow.
    (i64::from(speed_mm_s) * 36_000 + 926) / 1852
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    static SENTENCE: &str =
        "$GNRMC,132819.60,A,4134.49795459,N,09345.03431408,W,0.148,124.888,180320,11.5985,E,D*3F";

    fn repr() -> RmcRepr {
        RmcRepr {
            time: Some(TimeOfDay {
                hour: 13,
                minute: 28,
                second: 19,
                micros: 600_000,
            }),
            valid: Some(true),
            position: Some(Position {
                lat_ndeg: 41_574_965_910,
                lon_ndeg: -93_750_571_901,
            }),
            speed_mm_s: Some(76),
            course_cdeg: Some(12_489),
            date: Some(Date {
                year: 2020,
                month: 3,
                day: 18,
            }),
            mag_var_cdeg: Some(1_160),
            mode: Some(Mode::Differential),
            nav_status: None,
        }
    }

    #[test]
    fn test_parse() {
        let s = Sentence::new_checked(SENTENCE).unwrap();
        let rmc = RmcRepr::parse(&s).unwrap();
        assert_eq!(rmc, repr());
        assert_eq!(rmc.quality(), FixQuality::Dgps);
    }

    #[test]
    fn test_emit() {
        let mut out = String::new();
        repr().emit(*b"GN", &mut out).unwrap();
        let s = Sentence::new_checked(out.trim_end()).unwrap();
        assert_eq!(RmcRepr::parse(&s), Ok(repr()));
    }

    #[test]
    fn no_fix_rule() {
        for text in [
            "$GPRMC,,V,,,,,,,,,,N,V*29",
            "$GPRMC,030851.00,V,,,,,,,100806,,,N*7D",
        ] {
            let rmc = RmcRepr::parse(&Sentence::new_checked(text).unwrap()).unwrap();
            assert_eq!(rmc.quality(), FixQuality::Invalid);
            assert_eq!(rmc.fix_position(), None);
        }
        // Telit SL869 keeps printing a position with status V.
        let mut out = String::new();
        write_sentence(&mut out, b"GPRMC", |w| {
            w.write_str(",102136.000,V,3340.8472,S,15057.3804,E,0.00,0.00,180512,,")
        })
        .unwrap();
        let rmc = RmcRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()).unwrap();
        assert!(rmc.position.is_some());
        assert_eq!(rmc.fix_position(), None);
    }

    #[test]
    fn eleven_field_rmc_is_a_fix() {
        let rmc = RmcRepr::parse(
            &Sentence::new_checked(
                "$GPRMC,005947.00,A,3715.6616,N,12157.6709,W,0.0,0.0,080710,,*2F",
            )
            .unwrap(),
        )
        .unwrap();
        assert_eq!(rmc.quality(), FixQuality::Gps);
        assert_eq!(rmc.fix_position().unwrap().lat_ndeg, 37_261_026_667);
    }

    #[test]
    fn knots() {
        assert_eq!(parse_knots(b"1"), Ok(Some(514)));
        assert_eq!(parse_knots(b"0.148"), Ok(Some(76)));
        assert_eq!(parse_knots(b"-1"), Err(Error::Malformed));
        assert_eq!(mm_s_to_centi_milli_knots(514), 9991);
    }

    fn arb_repr() -> impl Strategy<Value = RmcRepr> {
        (
            proptest::option::of((0u8..24, 0u8..60, 0u8..=60, 0u32..1_000_000)),
            proptest::option::of(any::<bool>()),
            proptest::option::of((
                -90_000_000_000i64..=90_000_000_000,
                -180_000_000_000i64..=180_000_000_000,
            )),
            proptest::option::of(0u32..100_000_000),
            proptest::option::of(0u32..36_000),
            proptest::option::of((2000u16..2100, 1u8..=12, 1u8..=28)),
            proptest::option::of(-18_000i32..=18_000),
            proptest::option::of(proptest::sample::select(b"ADEFMNPRS".to_vec())),
            proptest::option::of(proptest::sample::select(b"ACSUV".to_vec())),
        )
            .prop_map(
                |(t, valid, p, speed, course, date, mv, mode, nav)| RmcRepr {
                    time: t.map(|(hour, minute, second, micros)| TimeOfDay {
                        hour,
                        minute,
                        second,
                        micros,
                    }),
                    valid,
                    position: p.map(|(lat_ndeg, lon_ndeg)| Position { lat_ndeg, lon_ndeg }),
                    speed_mm_s: speed,
                    course_cdeg: course,
                    date: date.map(|(year, month, day)| Date { year, month, day }),
                    mag_var_cdeg: mv,
                    mode: mode.and_then(|m| Mode::parse(&[m]).unwrap()),
                    nav_status: nav,
                },
            )
    }

    proptest! {
        #[test]
        fn emit_parse_round_trip(repr in arb_repr()) {
            let mut out = heapless::String::<{ protocol::MAX_NMEA_LEN + 2 }>::new();
            repr.emit(*b"GN", &mut out).unwrap();
            let s = Sentence::new_checked(out.trim_end()).unwrap();
            prop_assert_eq!(RmcRepr::parse(&s), Ok(repr));
        }
    }
}
