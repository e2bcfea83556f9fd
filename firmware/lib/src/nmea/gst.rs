//! `$--GST`: pseudorange error statistics (§5.5 of `shared/protocols/nmea0183.md`).
//!
//! ```text
//! $--GST,hhmmss.ss,rms,smaj,smin,orient,sd_lat,sd_lon,sd_alt*hh
//! ```
//!
//! Exactly 8 fields. Metres are kept as millimetres and the orientation as hundredths of a
//! degree, rounded half away from zero; without a fix the numeric fields are empty. Sigmas
//! beyond `u32::MAX` mm (4 295 km; receivers without a fix print placeholders such as
//! `5773795`) saturate at `u32::MAX`: no information.

use core::fmt::{self, Write};

use protocol::{GstSigmas, TimeOfDay};

use super::emit::{write_opt, write_sentence, write_time};
use super::fields::{parse_course_cdeg, parse_fixed, parse_time};
use super::{Error, Sentence, SentenceKind};

/// Field positions, counted from 0 after the address.
mod field {
    pub const TIME: usize = 0;
    pub const RMS: usize = 1;
    pub const SEMI_MAJOR: usize = 2;
    pub const SEMI_MINOR: usize = 3;
    pub const ORIENTATION: usize = 4;
    pub const LAT_SIGMA: usize = 5;
    pub const LON_SIGMA: usize = 6;
    pub const ALT_SIGMA: usize = 7;
    pub const COUNT: usize = 8;
}

/// The content of a GST sentence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GstRepr {
    /// UTC time of the fix the statistics belong to.
    pub time: Option<TimeOfDay>,
    /// The statistics.
    pub sigmas: GstSigmas,
}

impl GstRepr {
    /// Decodes a GST sentence from any talker. The view should have passed
    /// [`Sentence::new_checked`]; the checksum is not verified again.
    ///
    /// # Errors
    /// [`Error::WrongFormatter`] for another sentence type, [`Error::Malformed`] for a wrong
    /// field count or any field that does not decode.
    pub fn parse<T: AsRef<[u8]>>(sentence: &Sentence<T>) -> Result<Self, Error> {
        if sentence.kind() != SentenceKind::Gst {
            return Err(Error::WrongFormatter);
        }
        let (f, count) = sentence.field_array::<{ field::COUNT }>();
        if count != field::COUNT {
            return Err(Error::Malformed);
        }
        let mm = |i: usize| parse_sigma_mm(f[i]);
        Ok(GstRepr {
            time: parse_time(f[field::TIME])?,
            sigmas: GstSigmas {
                rms_mm: mm(field::RMS)?,
                semi_major_mm: mm(field::SEMI_MAJOR)?,
                semi_minor_mm: mm(field::SEMI_MINOR)?,
                orientation_cdeg: parse_course_cdeg(f[field::ORIENTATION])?,
                lat_sigma_mm: mm(field::LAT_SIGMA)?,
                lon_sigma_mm: mm(field::LON_SIGMA)?,
                alt_sigma_mm: mm(field::ALT_SIGMA)?,
            },
        })
    }

    /// Writes the sentence with `talker`.
    ///
    /// # Errors
    /// When `out` fails or the time is out of range.
    pub fn emit<W: Write>(&self, talker: [u8; 2], out: &mut W) -> fmt::Result {
        let [a, b] = talker;
        let s = &self.sigmas;
        write_sentence(out, &[a, b, b'G', b'S', b'T'], |w| {
            write_time(w, self.time)?;
            write_opt(w, s.rms_mm, 3)?;
            write_opt(w, s.semi_major_mm, 3)?;
            write_opt(w, s.semi_minor_mm, 3)?;
            write_opt(w, s.orientation_cdeg, 2)?;
            write_opt(w, s.lat_sigma_mm, 3)?;
            write_opt(w, s.lon_sigma_mm, 3)?;
            write_opt(w, s.alt_sigma_mm, 3)
        })
    }
}

/// Parses a sigma in metres into mm, saturating at `u32::MAX`.
fn parse_sigma_mm(field: &[u8]) -> Result<Option<u32>, Error> {
    match parse_fixed(field, 3) {
        Ok(None) => Ok(None),
        Ok(Some(mm)) if mm < 0 => Err(Error::Malformed),
        Ok(Some(mm)) => Ok(Some(u32::try_from(mm).unwrap_or(u32::MAX))),
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    static SENTENCE: &str = "$GNGST,223746.00,837,2.5,2.4,127,0.98,1.0,3.0*75";

    fn repr() -> GstRepr {
        GstRepr {
            time: Some(TimeOfDay {
                hour: 22,
                minute: 37,
                second: 46,
                micros: 0,
            }),
            sigmas: GstSigmas {
                rms_mm: Some(837_000),
                semi_major_mm: Some(2_500),
                semi_minor_mm: Some(2_400),
                orientation_cdeg: Some(12_700),
                lat_sigma_mm: Some(980),
                lon_sigma_mm: Some(1_000),
                alt_sigma_mm: Some(3_000),
            },
        }
    }

    #[test]
    fn test_parse() {
        assert_eq!(
            GstRepr::parse(&Sentence::new_checked(SENTENCE).unwrap()),
            Ok(repr())
        );
    }

    #[test]
    fn test_emit() {
        let mut out = String::new();
        repr().emit(*b"GN", &mut out).unwrap();
        assert_eq!(
            GstRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()),
            Ok(repr())
        );
    }

    #[test]
    fn empty_fields_without_fix() {
        let mut out = String::new();
        write_sentence(&mut out, b"GPGST", |w| w.write_str(",120000.00,,,,,,,")).unwrap();
        let gst = GstRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()).unwrap();
        assert_eq!(gst.sigmas, GstSigmas::default());
    }

    #[test]
    fn placeholder_sigmas_saturate() {
        let gst = GstRepr::parse(
            &Sentence::new_checked("$GNGST,181604.00,0.0000,,,,5773795,5773795,5773794*4F")
                .unwrap(),
        )
        .unwrap();
        assert_eq!(gst.sigmas.rms_mm, Some(0));
        assert_eq!(gst.sigmas.lat_sigma_mm, Some(u32::MAX));
    }

    proptest! {
        #[test]
        fn emit_parse_round_trip(v in proptest::option::of(any::<u32>()), o in proptest::option::of(0u32..36_000)) {
            let repr = GstRepr {
                time: None,
                sigmas: GstSigmas {
                    rms_mm: v,
                    semi_major_mm: v,
                    semi_minor_mm: None,
                    orientation_cdeg: o,
                    lat_sigma_mm: v,
                    lon_sigma_mm: v,
                    alt_sigma_mm: None,
                },
            };
            let mut out = String::new();
            repr.emit(*b"GP", &mut out).unwrap();
            prop_assert_eq!(GstRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()), Ok(repr));
        }
    }
}
