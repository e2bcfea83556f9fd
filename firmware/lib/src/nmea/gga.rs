//! `$--GGA`: global positioning system fix data (§5.1 of `shared/protocols/nmea0183.md`).
//!
//! ```text
//! $--GGA,hhmmss.ss,ddmm.mmmm,N,dddmm.mmmm,E,q,nn,h.h,a.a,M,g.g,M,age,sta*hh
//! ```
//!
//! Accepted field counts: 14 (standard), 13 (station ID missing, Saab R4) and 15 (an extra
//! trailing field, SiRF-TriG); anything else is [`Error::Malformed`]. Every field may be
//! empty. An empty quality field (Firefly firmware bug) reads as `None`. Without a fix
//! (quality 0 or empty), a position that does not decode reads as `None`.

use core::fmt::{self, Write};

use protocol::{FixQuality, Position, TimeOfDay};

use super::emit::{
    write_fixed, write_latitude, write_longitude, write_opt, write_sentence, write_time,
};
use super::fields::{
    parse_fixed_i32, parse_fixed_unsigned, parse_latitude, parse_longitude, parse_time, parse_uint,
};
use super::{Error, Sentence, SentenceKind};

/// Field positions, counted from 0 after the address.
mod field {
    pub const TIME: usize = 0;
    pub const LAT: usize = 1;
    pub const LAT_HEMI: usize = 2;
    pub const LON: usize = 3;
    pub const LON_HEMI: usize = 4;
    pub const QUALITY: usize = 5;
    pub const NUM_SATS: usize = 6;
    pub const HDOP: usize = 7;
    pub const ALT: usize = 8;
    pub const ALT_UNIT: usize = 9;
    pub const GEOID_SEP: usize = 10;
    pub const GEOID_UNIT: usize = 11;
    pub const DGPS_AGE: usize = 12;
    pub const DGPS_STATION: usize = 13;
    /// The fewest and most fields accepted.
    pub const MIN_COUNT: usize = 13;
    pub const MAX_COUNT: usize = 15;
}

/// The content of a GGA sentence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GgaRepr {
    /// UTC time of the fix.
    pub time: Option<TimeOfDay>,
    /// Position as sent, whatever the quality (see [`GgaRepr::fix_position`]).
    pub position: Option<Position>,
    /// Fix quality; `None` when the field is empty.
    pub quality: Option<FixQuality>,
    /// Satellites used.
    pub num_sats: Option<u8>,
    /// Horizontal dilution of precision, hundredths.
    pub hdop_centi: Option<u16>,
    /// Altitude above mean sea level, mm.
    pub alt_msl_mm: Option<i32>,
    /// Geoid separation (geoid above the WGS84 ellipsoid), mm.
    pub geoid_sep_mm: Option<i32>,
    /// Age of the differential corrections, ms.
    pub dgps_age_ms: Option<u32>,
    /// Differential reference station ID.
    pub dgps_station: Option<u16>,
}

impl GgaRepr {
    /// Decodes a GGA sentence from any talker. The view should have passed
    /// [`Sentence::new_checked`]; the checksum is not verified again.
    ///
    /// # Errors
    /// [`Error::WrongFormatter`] for another sentence type, [`Error::Malformed`] for a wrong
    /// field count, an unknown quality digit, a latitude without longitude, or any field
    /// that does not decode.
    pub fn parse<T: AsRef<[u8]>>(sentence: &Sentence<T>) -> Result<Self, Error> {
        if sentence.kind() != SentenceKind::Gga {
            return Err(Error::WrongFormatter);
        }
        let (f, count) = sentence.field_array::<{ field::MAX_COUNT }>();
        if !(field::MIN_COUNT..=field::MAX_COUNT).contains(&count) {
            return Err(Error::Malformed);
        }
        check_unit(f[field::ALT_UNIT])?;
        check_unit(f[field::GEOID_UNIT])?;
        let quality = match parse_uint(f[field::QUALITY])? {
            None => None,
            Some(digit) => Some(
                u8::try_from(digit)
                    .ok()
                    .and_then(FixQuality::from_gga_digit)
                    .ok_or(Error::Malformed)?,
            ),
        };
        let no_fix = matches!(quality, None | Some(FixQuality::Invalid));
        Ok(GgaRepr {
            time: parse_time(f[field::TIME])?,
            position: parse_position(
                (f[field::LAT], f[field::LAT_HEMI]),
                (f[field::LON], f[field::LON_HEMI]),
                no_fix,
            )?,
            quality,
            num_sats: parse_fixed_unsigned(f[field::NUM_SATS], 0)?,
            hdop_centi: parse_fixed_unsigned(f[field::HDOP], 2)?,
            alt_msl_mm: parse_fixed_i32(f[field::ALT], 3)?,
            geoid_sep_mm: parse_fixed_i32(f[field::GEOID_SEP], 3)?,
            dgps_age_ms: parse_fixed_unsigned(f[field::DGPS_AGE], 3)?,
            dgps_station: parse_fixed_unsigned(f[field::DGPS_STATION], 0)?,
        })
    }

    /// The position if the quality says it is a fix: `None` for quality 0 or an empty
    /// quality field (§9 no-fix rule).
    pub fn fix_position(&self) -> Option<Position> {
        match self.quality {
            None | Some(FixQuality::Invalid) => None,
            Some(_) => self.position,
        }
    }

    /// Writes the sentence with `talker` (`*b"GP"`, `*b"GN"`, …): 14 fields, `*hh` and CR LF.
    /// Latitude/longitude carry 4 to 8 minute decimals, exactly representing the
    /// nanodegrees, so that [`GgaRepr::parse`] returns the same value.
    ///
    /// # Errors
    /// When `out` fails or a value cannot be expressed (see [`super::emit`]).
    pub fn emit<W: Write>(&self, talker: [u8; 2], out: &mut W) -> fmt::Result {
        let [a, b] = talker;
        write_sentence(out, &[a, b, b'G', b'G', b'A'], |w| {
            write_time(w, self.time)?;
            write_latitude(w, self.position.map(|p| p.lat_ndeg))?;
            write_longitude(w, self.position.map(|p| p.lon_ndeg))?;
            write_opt(w, self.quality.map(FixQuality::gga_digit), 0)?;
            write_num_sats(w, self.num_sats)?;
            write_opt(w, self.hdop_centi, 2)?;
            write_fixed(w, self.alt_msl_mm.map(i64::from), 3)?;
            w.write_str(",M")?;
            write_fixed(w, self.geoid_sep_mm.map(i64::from), 3)?;
            w.write_str(",M")?;
            write_opt(w, self.dgps_age_ms, 3)?;
            match self.dgps_station {
                Some(station) => write!(w, ",{station:04}"),
                None => w.write_char(','),
            }
        })
    }
}

/// Writes the satellite count with two digits, as receivers do.
fn write_num_sats<W: Write>(w: &mut W, num_sats: Option<u8>) -> fmt::Result {
    match num_sats {
        Some(n) => write!(w, ",{n:02}"),
        None => w.write_char(','),
    }
}

/// Checks a unit field that must be `M` (metres) or empty.
fn check_unit(unit: &[u8]) -> Result<(), Error> {
    match unit {
        b"" | b"M" => Ok(()),
        _ => Err(Error::Malformed),
    }
}

/// Decodes a latitude/longitude pair of fields (value, hemisphere each). Both empty is
/// `None`; one without the other is malformed. In a sentence that says it has no fix
/// (`no_fix`), a position that does not decode is `None` rather than an error: the MTK-3301
/// prints `8960.000000,N` (89°60′) until its first fix.
pub(crate) fn parse_position(
    lat: (&[u8], &[u8]),
    lon: (&[u8], &[u8]),
    no_fix: bool,
) -> Result<Option<Position>, Error> {
    let decoded = match (parse_latitude(lat.0, lat.1), parse_longitude(lon.0, lon.1)) {
        (Ok(Some(lat_ndeg)), Ok(Some(lon_ndeg))) => Ok(Some(Position { lat_ndeg, lon_ndeg })),
        (Ok(None), Ok(None)) => Ok(None),
        (Err(e), _) | (_, Err(e)) => Err(e),
        _ => Err(Error::Malformed),
    };
    match decoded {
        Err(_) if no_fix => Ok(None),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    static SENTENCE: &str = "$GNGGA,132819.60,4134.49795459,N,09345.03431408,W,2,10,0.9,278.161,M,-31.442,M,6.6,0133*6A";

    fn repr() -> GgaRepr {
        GgaRepr {
            time: Some(TimeOfDay {
                hour: 13,
                minute: 28,
                second: 19,
                micros: 600_000,
            }),
            position: Some(Position {
                lat_ndeg: 41_574_965_910,
                lon_ndeg: -93_750_571_901,
            }),
            quality: Some(FixQuality::Dgps),
            num_sats: Some(10),
            hdop_centi: Some(90),
            alt_msl_mm: Some(278_161),
            geoid_sep_mm: Some(-31_442),
            dgps_age_ms: Some(6_600),
            dgps_station: Some(133),
        }
    }

    #[test]
    fn test_parse() {
        let s = Sentence::new_checked(SENTENCE).unwrap();
        assert_eq!(GgaRepr::parse(&s), Ok(repr()));
    }

    #[test]
    fn test_emit() {
        let mut out = String::new();
        repr().emit(*b"GN", &mut out).unwrap();
        assert!(out.ends_with("\r\n"));
        let s = Sentence::new_checked(out.trim_end()).unwrap();
        assert_eq!(GgaRepr::parse(&s), Ok(repr()));
        assert_eq!(
            out,
            "$GNGGA,132819.60,4134.4979546,N,09345.03431406,W,2,10,0.90,278.161,M,-31.442,M,6.600,0133*6E\r\n"
        );
    }

    #[test]
    fn no_fix_sentences() {
        for text in [
            "$GPGGA,,,,,,0,,,,,,,,*66",
            "$GNGGA,181604.00,,,,,0,00,99.99,,,,,,*72",
        ] {
            let gga = GgaRepr::parse(&Sentence::new_checked(text).unwrap()).unwrap();
            assert_eq!(gga.quality, Some(FixQuality::Invalid));
            assert_eq!(gga.fix_position(), None);
        }
    }

    #[test]
    fn undecodable_position_without_fix_is_none() {
        let s = Sentence::new_checked(
            "$GPGGA,235946.005,8960.000000,N,00000.000000,E,0,0,,137.000,M,13.000,M,,*49",
        )
        .unwrap();
        let gga = GgaRepr::parse(&s).unwrap();
        assert_eq!(
            (gga.position, gga.quality),
            (None, Some(FixQuality::Invalid))
        );
        let mut out = String::new();
        write_sentence(&mut out, b"GPGGA", |w| {
            w.write_str(",235946,8960.0,N,00000.0,E,1,04,,,,,,,")
        })
        .unwrap();
        assert_eq!(
            GgaRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()),
            Err(Error::Malformed)
        );
    }

    #[test]
    fn field_count_variants() {
        // 15 fields (SiRF-TriG).
        let s = Sentence::new_checked(
            "$GNGGA,074155.799,3114.8770,N,12135.2463,E,1,05,1.3,156.9,M,8.3,M,,0000,4.9*77",
        )
        .unwrap();
        let gga = GgaRepr::parse(&s).unwrap();
        assert_eq!(gga.fix_position().unwrap().lat_ndeg, 31_247_950_000);
        // 13 fields and an empty quality: parsed, but no fix.
        let mut out = String::new();
        write_sentence(&mut out, b"GPGGA", |w| {
            w.write_str(",120000,4807.038,N,01131.000,E,,08,0.9,545.4,M,46.9,M,")
        })
        .unwrap();
        let gga = GgaRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()).unwrap();
        assert_eq!(gga.quality, None);
        assert!(gga.position.is_some());
        assert_eq!(gga.fix_position(), None);
        // 2D fix with empty altitude (PolaRx2).
        let mut out = String::new();
        write_sentence(&mut out, b"GPGGA", |w| {
            w.write_str(",120000,4807.038,N,01131.000,E,1,03,10.5,,,,,,")
        })
        .unwrap();
        let gga = GgaRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()).unwrap();
        assert_eq!(gga.alt_msl_mm, None);
        assert!(gga.fix_position().is_some());
    }

    #[test]
    fn rejects_wrong_sentences() {
        let rmc = Sentence::new_checked("$GPRMC,,V,,,,,,,,,,N,V*29").unwrap();
        assert_eq!(GgaRepr::parse(&rmc), Err(Error::WrongFormatter));
        let mut out = String::new();
        write_sentence(&mut out, b"GPGGA", |w| {
            w.write_str(",120000,4807.038,N,,,1,08,0.9,545.4,M,46.9,M,,")
        })
        .unwrap();
        assert_eq!(
            GgaRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()),
            Err(Error::Malformed)
        );
        let mut out = String::new();
        write_sentence(&mut out, b"GPGGA", |w| w.write_str(",120000,,,,,9,,,,,,,,")).unwrap();
        assert_eq!(
            GgaRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()),
            Err(Error::Malformed)
        );
    }

    fn arb_repr() -> impl Strategy<Value = GgaRepr> {
        (
            proptest::option::of((0u8..24, 0u8..60, 0u8..=60, 0u32..1_000_000)),
            proptest::option::of((
                -90_000_000_000i64..=90_000_000_000,
                -180_000_000_000i64..=180_000_000_000,
            )),
            proptest::option::of(0u8..=8),
            proptest::option::of(any::<u8>()),
            proptest::option::of(any::<u16>()),
            proptest::option::of(any::<i32>()),
            proptest::option::of(any::<i32>()),
            proptest::option::of(0u32..10_000_000),
            proptest::option::of(0u16..=1023),
        )
            .prop_map(|(t, p, q, n, h, a, g, age, sta)| GgaRepr {
                time: t.map(|(hour, minute, second, micros)| TimeOfDay {
                    hour,
                    minute,
                    second,
                    micros,
                }),
                position: p.map(|(lat_ndeg, lon_ndeg)| Position { lat_ndeg, lon_ndeg }),
                quality: q.and_then(FixQuality::from_gga_digit),
                num_sats: n,
                hdop_centi: h,
                alt_msl_mm: a,
                geoid_sep_mm: g,
                dgps_age_ms: age,
                dgps_station: sta,
            })
    }

    proptest! {
        #[test]
        fn emit_parse_round_trip(repr in arb_repr()) {
            let mut out = heapless::String::<{ protocol::MAX_NMEA_LEN + 2 }>::new();
            repr.emit(*b"GP", &mut out).unwrap();
            let s = Sentence::new_checked(out.trim_end()).unwrap();
            prop_assert_eq!(GgaRepr::parse(&s), Ok(repr));
        }
    }
}
