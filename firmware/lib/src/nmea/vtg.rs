//! `$--VTG`: course and speed over ground (§5.4 of `shared/protocols/nmea0183.md`).
//!
//! ```text
//! $--VTG,cog_t,T,cog_m,M,sog_kn,N,sog_kmh,K,mode*hh
//! ```
//!
//! Accepted field counts: 8 (before NMEA 2.3) and 9 (mode). The unit letters may be empty
//! (no-fix sentences). VTG carries no time; [`super::GpsReceiver`] attributes it to the
//! epoch of the last timed sentence. The speed comes from the knots field, or from the km/h
//! field when the knots field is empty.

use core::fmt::{self, Write};

use super::emit::{write_char_field, write_fixed, write_opt, write_sentence};
use super::fields::{parse_course_cdeg, parse_fixed};
use super::rmc::{mm_s_to_centi_milli_knots, parse_knots};
use super::{Error, Mode, Sentence, SentenceKind};

/// Field positions, counted from 0 after the address.
mod field {
    pub const COURSE_TRUE: usize = 0;
    pub const COURSE_TRUE_UNIT: usize = 1;
    pub const COURSE_MAG: usize = 2;
    pub const COURSE_MAG_UNIT: usize = 3;
    pub const SPEED_KN: usize = 4;
    pub const SPEED_KN_UNIT: usize = 5;
    pub const SPEED_KMH: usize = 6;
    pub const SPEED_KMH_UNIT: usize = 7;
    pub const MODE: usize = 8;
    /// The fewest and most fields accepted.
    pub const MIN_COUNT: usize = 8;
    pub const MAX_COUNT: usize = 9;
}

/// The content of a VTG sentence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VtgRepr {
    /// Course over ground from true north, hundredths of a degree.
    pub course_cdeg: Option<u32>,
    /// Course over ground from magnetic north, hundredths of a degree.
    pub course_mag_cdeg: Option<u32>,
    /// Speed over ground, mm/s.
    pub speed_mm_s: Option<u32>,
    /// Mode indicator (NMEA 2.3+).
    pub mode: Option<Mode>,
}

impl VtgRepr {
    /// Decodes a VTG sentence from any talker. The view should have passed
    /// [`Sentence::new_checked`]; the checksum is not verified again.
    ///
    /// # Errors
    /// [`Error::WrongFormatter`] for another sentence type, [`Error::Malformed`] for a wrong
    /// field count, a wrong unit letter or any field that does not decode.
    pub fn parse<T: AsRef<[u8]>>(sentence: &Sentence<T>) -> Result<Self, Error> {
        if sentence.kind() != SentenceKind::Vtg {
            return Err(Error::WrongFormatter);
        }
        let (f, count) = sentence.field_array::<{ field::MAX_COUNT }>();
        if !(field::MIN_COUNT..=field::MAX_COUNT).contains(&count) {
            return Err(Error::Malformed);
        }
        for (unit, letter) in [
            (field::COURSE_TRUE_UNIT, b"T"),
            (field::COURSE_MAG_UNIT, b"M"),
            (field::SPEED_KN_UNIT, b"N"),
            (field::SPEED_KMH_UNIT, b"K"),
        ] {
            if !f[unit].is_empty() && f[unit] != letter {
                return Err(Error::Malformed);
            }
        }
        let speed_mm_s = match parse_knots(f[field::SPEED_KN])? {
            Some(speed) => Some(speed),
            None => parse_kmh(f[field::SPEED_KMH])?,
        };
        Ok(VtgRepr {
            course_cdeg: parse_course_cdeg(f[field::COURSE_TRUE])?,
            course_mag_cdeg: parse_course_cdeg(f[field::COURSE_MAG])?,
            speed_mm_s,
            mode: Mode::parse(f[field::MODE])?,
        })
    }

    /// Writes the sentence with `talker`: speed in knots (4 decimals) and km/h (3 decimals);
    /// 9 fields with a mode, otherwise 8.
    ///
    /// # Errors
    /// When `out` fails.
    pub fn emit<W: Write>(&self, talker: [u8; 2], out: &mut W) -> fmt::Result {
        let [a, b] = talker;
        write_sentence(out, &[a, b, b'V', b'T', b'G'], |w| {
            write_opt(w, self.course_cdeg, 2)?;
            w.write_str(",T")?;
            write_opt(w, self.course_mag_cdeg, 2)?;
            w.write_str(",M")?;
            write_fixed(w, self.speed_mm_s.map(mm_s_to_centi_milli_knots), 4)?;
            w.write_str(",N")?;
            // mm/s × 3.6 = m/h, i.e. km/h with 3 decimals.
            write_fixed(w, self.speed_mm_s.map(|v| (i64::from(v) * 36 + 5) / 10), 3)?;
            w.write_str(",K")?;
            if let Some(mode) = self.mode {
                write_char_field(w, Some(mode.letter()))?;
            }
            Ok(())
        })
    }
}

/// Parses a speed in km/h into mm/s, rounded half away from zero.
fn parse_kmh(field: &[u8]) -> Result<Option<u32>, Error> {
    let Some(m_per_h) = parse_fixed(field, 3)? else {
        return Ok(None);
    };
    if m_per_h < 0 {
        return Err(Error::Malformed);
    }
    // mm/s = m/h / 3.6 = m/h × 10 / 36.
    let mm_s = m_per_h
        .checked_mul(10)
        .map(|n| (n + 18) / 36)
        .ok_or(Error::Malformed)?;
    u32::try_from(mm_s).map(Some).map_err(|_| Error::Malformed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn test_parse() {
        let vtg = VtgRepr::parse(
            &Sentence::new_checked("$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K,A*25").unwrap(),
        )
        .unwrap();
        assert_eq!(
            vtg,
            VtgRepr {
                course_cdeg: Some(5470),
                course_mag_cdeg: Some(3440),
                speed_mm_s: Some(2829),
                mode: Some(Mode::Autonomous),
            }
        );
    }

    #[test]
    fn no_fix_and_kmh_only() {
        let vtg = VtgRepr::parse(&Sentence::new_checked("$GNVTG,,,,,,,,,N*2E").unwrap()).unwrap();
        assert_eq!(vtg.speed_mm_s, None);
        assert_eq!(vtg.mode, Some(Mode::NotValid));
        let mut out = String::new();
        write_sentence(&mut out, b"GPVTG", |w| w.write_str(",,T,,M,,N,3.6,K")).unwrap();
        let vtg = VtgRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()).unwrap();
        assert_eq!(vtg.speed_mm_s, Some(1000));
        assert_eq!(vtg.mode, None);
    }

    #[test]
    fn test_emit() {
        let repr = VtgRepr {
            course_cdeg: None,
            course_mag_cdeg: None,
            speed_mm_s: Some(43),
            mode: Some(Mode::Differential),
        };
        let mut out = String::new();
        repr.emit(*b"GN", &mut out).unwrap();
        assert_eq!(
            VtgRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()),
            Ok(repr)
        );
    }

    proptest! {
        #[test]
        fn emit_parse_round_trip(
            course in proptest::option::of(0u32..36_000),
            mag in proptest::option::of(0u32..36_000),
            speed in proptest::option::of(0u32..1_000_000_000),
            mode in proptest::option::of(proptest::sample::select(b"ADEFMNPRS".to_vec())),
        ) {
            let repr = VtgRepr {
                course_cdeg: course,
                course_mag_cdeg: mag,
                speed_mm_s: speed,
                mode: mode.and_then(|m| Mode::parse(&[m]).unwrap()),
            };
            let mut out = String::new();
            repr.emit(*b"GP", &mut out).unwrap();
            prop_assert_eq!(VtgRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()), Ok(repr));
        }
    }
}
