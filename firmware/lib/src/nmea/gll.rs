//! `$--GLL`: geographic position, latitude/longitude (§5.6 of
//! `shared/protocols/nmea0183.md`).
//!
//! ```text
//! $--GLL,ddmm.mm,N,dddmm.mm,E,hhmmss.ss,A,m*hh
//! ```
//!
//! Accepted field counts: 4 (NMEA 1.5: position only), 6 (time and status), 7 (NMEA 2.3+
//! mode). Without a fix (status `V`, mode `N`), a position that does not decode reads as
//! `None`.

use core::fmt::{self, Write};

use protocol::{FixQuality, Position, TimeOfDay};

use super::emit::{write_char_field, write_latitude, write_longitude, write_sentence, write_time};
use super::fields::parse_time;
use super::gga::parse_position;
use super::mode::{parse_status, status_letter, status_quality};
use super::{Error, Mode, Sentence, SentenceKind};

/// Field positions, counted from 0 after the address.
mod field {
    pub const LAT: usize = 0;
    pub const LAT_HEMI: usize = 1;
    pub const LON: usize = 2;
    pub const LON_HEMI: usize = 3;
    pub const TIME: usize = 4;
    pub const STATUS: usize = 5;
    pub const MODE: usize = 6;
    /// The accepted field counts.
    pub const COUNTS: [usize; 3] = [4, 6, 7];
    pub const MAX_COUNT: usize = 7;
}

/// The content of a GLL sentence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GllRepr {
    /// Position as sent, whatever the status (see [`GllRepr::fix_position`]).
    pub position: Option<Position>,
    /// UTC time of the position.
    pub time: Option<TimeOfDay>,
    /// Status: `Some(true)` for `A` (valid), `Some(false)` for `V`.
    pub valid: Option<bool>,
    /// Mode indicator (NMEA 2.3+).
    pub mode: Option<Mode>,
}

impl GllRepr {
    /// Decodes a GLL sentence from any talker. The view should have passed
    /// [`Sentence::new_checked`]; the checksum is not verified again.
    ///
    /// # Errors
    /// [`Error::WrongFormatter`] for another sentence type, [`Error::Malformed`] for a wrong
    /// field count or any field that does not decode.
    pub fn parse<T: AsRef<[u8]>>(sentence: &Sentence<T>) -> Result<Self, Error> {
        if sentence.kind() != SentenceKind::Gll {
            return Err(Error::WrongFormatter);
        }
        let (f, count) = sentence.field_array::<{ field::MAX_COUNT }>();
        if !field::COUNTS.contains(&count) {
            return Err(Error::Malformed);
        }
        let valid = parse_status(f[field::STATUS])?;
        let mode = Mode::parse(f[field::MODE])?;
        Ok(GllRepr {
            position: parse_position(
                (f[field::LAT], f[field::LAT_HEMI]),
                (f[field::LON], f[field::LON_HEMI]),
                status_quality(valid, mode) == FixQuality::Invalid,
            )?,
            time: parse_time(f[field::TIME])?,
            valid,
            mode,
        })
    }

    /// The fix quality the status and mode imply (§9: status `V` or mode `N` is invalid; a
    /// GLL without status counts as valid).
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

    /// Writes the sentence with `talker`: 7 fields with a mode, otherwise 6.
    ///
    /// # Errors
    /// When `out` fails or a value cannot be expressed (see [`super::emit`]).
    pub fn emit<W: Write>(&self, talker: [u8; 2], out: &mut W) -> fmt::Result {
        let [a, b] = talker;
        write_sentence(out, &[a, b, b'G', b'L', b'L'], |w| {
            write_latitude(w, self.position.map(|p| p.lat_ndeg))?;
            write_longitude(w, self.position.map(|p| p.lon_ndeg))?;
            write_time(w, self.time)?;
            write_char_field(w, status_letter(self.valid))?;
            if let Some(mode) = self.mode {
                write_char_field(w, Some(mode.letter()))?;
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    static SENTENCE: &str = "$GNGLL,3806.62966,N,12237.61384,W,223746.00,A,D*6B";

    fn repr() -> GllRepr {
        GllRepr {
            position: Some(Position {
                lat_ndeg: 38_110_494_333,
                lon_ndeg: -122_626_897_333,
            }),
            time: Some(TimeOfDay {
                hour: 22,
                minute: 37,
                second: 46,
                micros: 0,
            }),
            valid: Some(true),
            mode: Some(Mode::Differential),
        }
    }

    #[test]
    fn test_parse() {
        let gll = GllRepr::parse(&Sentence::new_checked(SENTENCE).unwrap()).unwrap();
        assert_eq!(gll, repr());
        assert_eq!(gll.quality(), FixQuality::Dgps);
    }

    #[test]
    fn test_emit() {
        let mut out = String::new();
        repr().emit(*b"GN", &mut out).unwrap();
        assert_eq!(
            GllRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()),
            Ok(repr())
        );
    }

    #[test]
    fn status_v_has_no_fix() {
        let mut out = String::new();
        GllRepr {
            valid: Some(false),
            ..repr()
        }
        .emit(*b"GP", &mut out)
        .unwrap();
        let gll = GllRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()).unwrap();
        assert_eq!(gll.fix_position(), None);
        assert_eq!(gll.quality(), FixQuality::Invalid);
    }

    #[test]
    fn old_four_field_gll() {
        let mut out = String::new();
        write_sentence(&mut out, b"GPGLL", |w| w.write_str(",4916.45,N,12311.12,W")).unwrap();
        let gll = GllRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()).unwrap();
        assert_eq!(gll.time, None);
        assert_eq!(gll.fix_position().unwrap().lat_ndeg, 49_274_166_667);
    }

    proptest! {
        #[test]
        fn emit_parse_round_trip(
            p in proptest::option::of((-90_000_000_000i64..=90_000_000_000, -180_000_000_000i64..=180_000_000_000)),
            t in proptest::option::of((0u8..24, 0u8..60, 0u8..=60, 0u32..1_000_000)),
            valid in proptest::option::of(any::<bool>()),
            mode in proptest::option::of(proptest::sample::select(b"ADEFMNPRS".to_vec())),
        ) {
            let repr = GllRepr {
                position: p.map(|(lat_ndeg, lon_ndeg)| Position { lat_ndeg, lon_ndeg }),
                time: t.map(|(hour, minute, second, micros)| TimeOfDay { hour, minute, second, micros }),
                valid,
                mode: mode.and_then(|m| Mode::parse(&[m]).unwrap()),
            };
            let mut out = String::new();
            repr.emit(*b"GL", &mut out).unwrap();
            prop_assert_eq!(GllRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()), Ok(repr));
        }
    }
}
