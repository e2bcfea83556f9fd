//! `$--GSA`: DOP and active satellites (§5.3 of `shared/protocols/nmea0183.md`).
//!
//! ```text
//! $--GSA,a,m,p1,…,p12,pdop,hdop,vdop[,sys]*hh
//! ```
//!
//! Accepted field counts: 17 (classic), 18 (NMEA 4.10 system ID), and 29/30 for receivers
//! that send 24 satellite slots. Satellite IDs are kept in slot order without the empty
//! slots.

use core::fmt::{self, Write};

use heapless::Vec;

use super::emit::{write_char_field, write_opt, write_sentence};
use super::fields::{parse_fixed_unsigned, parse_uint};
use super::{Error, Sentence, SentenceKind};

/// The most satellite slots a GSA may carry.
pub const MAX_GSA_SATS: usize = 24;

/// Field positions, counted from 0 after the address.
mod field {
    pub const SELECTION: usize = 0;
    pub const FIX_TYPE: usize = 1;
    pub const FIRST_SAT: usize = 2;
    /// Fields besides the satellite slots: selection, fix type, PDOP, HDOP, VDOP.
    pub const FIXED_COUNT: usize = 5;
    pub const MAX_COUNT: usize = FIXED_COUNT + super::MAX_GSA_SATS + 1;
}

/// Whether the receiver chose 2D/3D itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Selection {
    /// `M`: forced to 2D or 3D.
    Manual,
    /// `A`: automatic.
    Automatic,
}

/// The fix type field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GsaFixType {
    /// `1`: no fix.
    NoFix,
    /// `2`: 2D fix.
    Fix2d,
    /// `3`: 3D fix.
    Fix3d,
    /// `E`: dead reckoning (old u-blox).
    DeadReckoning,
}

/// The content of a GSA sentence.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GsaRepr {
    /// Manual or automatic 2D/3D selection.
    pub selection: Option<Selection>,
    /// Fix type.
    pub fix_type: Option<GsaFixType>,
    /// IDs of the satellites used, in slot order, empty slots left out.
    pub sat_ids: Vec<u16, MAX_GSA_SATS>,
    /// Position dilution of precision, hundredths.
    pub pdop_centi: Option<u16>,
    /// Horizontal dilution of precision, hundredths.
    pub hdop_centi: Option<u16>,
    /// Vertical dilution of precision, hundredths.
    pub vdop_centi: Option<u16>,
    /// NMEA 4.10 GNSS system ID (1 GPS, 2 GLONASS, 3 Galileo, 4 BeiDou, 5 QZSS, 6 NavIC).
    pub system_id: Option<u8>,
}

impl GsaRepr {
    /// Decodes a GSA sentence from any talker. The view should have passed
    /// [`Sentence::new_checked`]; the checksum is not verified again.
    ///
    /// # Errors
    /// [`Error::WrongFormatter`] for another sentence type, [`Error::Malformed`] for a wrong
    /// field count or any field that does not decode.
    pub fn parse<T: AsRef<[u8]>>(sentence: &Sentence<T>) -> Result<Self, Error> {
        if sentence.kind() != SentenceKind::Gsa {
            return Err(Error::WrongFormatter);
        }
        let (f, count) = sentence.field_array::<{ field::MAX_COUNT }>();
        let (slots, has_system) = match count.checked_sub(field::FIXED_COUNT) {
            Some(12) => (12, false),
            Some(13) => (12, true),
            Some(24) => (24, false),
            Some(25) => (24, true),
            _ => return Err(Error::Malformed),
        };
        let selection = match f[field::SELECTION] {
            b"" => None,
            b"M" => Some(Selection::Manual),
            b"A" => Some(Selection::Automatic),
            _ => return Err(Error::Malformed),
        };
        let fix_type = match f[field::FIX_TYPE] {
            b"" => None,
            b"1" => Some(GsaFixType::NoFix),
            b"2" => Some(GsaFixType::Fix2d),
            b"3" => Some(GsaFixType::Fix3d),
            b"E" => Some(GsaFixType::DeadReckoning),
            _ => return Err(Error::Malformed),
        };
        let mut sat_ids = Vec::new();
        let sat_fields = f
            .get(field::FIRST_SAT..field::FIRST_SAT + slots)
            .unwrap_or(&[]);
        for text in sat_fields {
            if let Some(id) = parse_uint(text)? {
                let id = u16::try_from(id).map_err(|_| Error::Malformed)?;
                sat_ids.push(id).map_err(|_| Error::Malformed)?;
            }
        }
        let dop = |i: usize| {
            parse_fixed_unsigned::<u16>(
                f.get(field::FIRST_SAT + slots + i).copied().unwrap_or(&[]),
                2,
            )
        };
        let system_id = if has_system {
            parse_fixed_unsigned::<u8>(
                f.get(field::FIRST_SAT + slots + 3).copied().unwrap_or(&[]),
                0,
            )?
        } else {
            None
        };
        Ok(GsaRepr {
            selection,
            fix_type,
            sat_ids,
            pdop_centi: dop(0)?,
            hdop_centi: dop(1)?,
            vdop_centi: dop(2)?,
            system_id,
        })
    }

    /// Writes the sentence with `talker`: 12 satellite slots (24 when more than 12 IDs),
    /// plus the system ID field when there is one.
    ///
    /// # Errors
    /// When `out` fails.
    pub fn emit<W: Write>(&self, talker: [u8; 2], out: &mut W) -> fmt::Result {
        let [a, b] = talker;
        let slots = if self.sat_ids.len() > 12 { 24 } else { 12 };
        write_sentence(out, &[a, b, b'G', b'S', b'A'], |w| {
            write_char_field(
                w,
                self.selection.map(|s| match s {
                    Selection::Manual => b'M',
                    Selection::Automatic => b'A',
                }),
            )?;
            write_char_field(
                w,
                self.fix_type.map(|t| match t {
                    GsaFixType::NoFix => b'1',
                    GsaFixType::Fix2d => b'2',
                    GsaFixType::Fix3d => b'3',
                    GsaFixType::DeadReckoning => b'E',
                }),
            )?;
            for slot in 0..slots {
                match self.sat_ids.get(slot) {
                    Some(id) => write!(w, ",{id:02}")?,
                    None => w.write_char(',')?,
                }
            }
            write_opt(w, self.pdop_centi, 2)?;
            write_opt(w, self.hdop_centi, 2)?;
            write_opt(w, self.vdop_centi, 2)?;
            if self.system_id.is_some() {
                write_opt(w, self.system_id, 0)?;
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    static SENTENCE: &str = "$GNGSA,A,3,29,20,18,16,51,13,44,26,,,,,1.04,0.56,0.88,1*02";

    fn repr() -> GsaRepr {
        GsaRepr {
            selection: Some(Selection::Automatic),
            fix_type: Some(GsaFixType::Fix3d),
            sat_ids: Vec::from_slice(&[29, 20, 18, 16, 51, 13, 44, 26]).unwrap(),
            pdop_centi: Some(104),
            hdop_centi: Some(56),
            vdop_centi: Some(88),
            system_id: Some(1),
        }
    }

    #[test]
    fn test_parse() {
        assert_eq!(
            GsaRepr::parse(&Sentence::new_checked(SENTENCE).unwrap()),
            Ok(repr())
        );
    }

    #[test]
    fn test_emit() {
        let mut out = String::new();
        repr().emit(*b"GN", &mut out).unwrap();
        assert_eq!(out.trim_end(), SENTENCE);
    }

    #[test]
    fn no_fix_and_classic_layout() {
        let gsa = GsaRepr::parse(
            &Sentence::new_checked("$GNGSA,A,1,,,,,,,,,,,,,99.99,99.99,99.99*2E").unwrap(),
        )
        .unwrap();
        assert_eq!(gsa.fix_type, Some(GsaFixType::NoFix));
        assert!(gsa.sat_ids.is_empty());
        assert_eq!(gsa.system_id, None);
        assert_eq!(gsa.pdop_centi, Some(9999));
        let mut out = String::new();
        gsa.emit(*b"GN", &mut out).unwrap();
        assert_eq!(
            out.trim_end(),
            "$GNGSA,A,1,,,,,,,,,,,,,99.99,99.99,99.99*2E"
        );
    }

    #[test]
    fn twenty_four_slots() {
        let ids: Vec<u16, 24> = (1..=20).collect();
        let gsa = GsaRepr {
            sat_ids: ids,
            system_id: None,
            ..repr()
        };
        let mut out = heapless::String::<128>::new();
        gsa.emit(*b"GP", &mut out).unwrap();
        let s = Sentence::new_checked(out.trim_end()).unwrap();
        assert_eq!(s.fields().count(), 29);
        assert_eq!(GsaRepr::parse(&s), Ok(gsa));
    }

    #[test]
    fn rejects_garbage_lengths() {
        let mut out = String::new();
        write_sentence(&mut out, b"GPGSA", |w| w.write_str(",A,1,,,,,,,,,,,,,,")).unwrap();
        assert_eq!(
            GsaRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()),
            Err(Error::Malformed)
        );
    }

    proptest! {
        #[test]
        fn emit_parse_round_trip(
            ids in proptest::collection::vec(0u16..100, 0..=24),
            dops in proptest::option::of(any::<u16>()),
            sys in proptest::option::of(any::<u8>()),
        ) {
            let repr = GsaRepr {
                selection: Some(Selection::Manual),
                fix_type: Some(GsaFixType::DeadReckoning),
                sat_ids: Vec::from_slice(&ids).unwrap(),
                pdop_centi: dops,
                hdop_centi: dops,
                vdop_centi: None,
                system_id: sys,
            };
            let mut out = String::new();
            repr.emit(*b"GA", &mut out).unwrap();
            prop_assert_eq!(GsaRepr::parse(&Sentence::new_checked(out.trim_end()).unwrap()), Ok(repr));
        }
    }
}
