//! Interpreting LMS2xx range words: distance bits, flag bits and "no return" codes, which
//! depend on the measuring mode (configuration byte 5) and the unit (protocol notes §7.3).
//!
//! | mode | distance mask | upper bits |
//! |---|---|---|
//! | `00h`, `01h`, `02h` | `1FFFh` (8 m / 80 m) | field/dazzle flags or reflector level |
//! | `03h`, `04h` | `3FFFh` (16 m) | reflector level or field flags |
//! | `05h`, `06h` | `7FFFh` (32 m) | reflector bit or field A |
//! | `0Fh` | `FFFFh` | none |
//! | `3Fh` | — | energy values, not distances |
//!
//! A masked value of `mask - 8` (`…F7h`) or more is a "no return" code (no echo, dazzling,
//! overflow, …); the distance is then unknown.

use crate::RangeUnit;

/// The measuring mode of the sensor: how its range words are coded (configuration byte 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeasuringMode(pub u8);

impl MeasuringMode {
    /// The factory default: 8 m (mm) / 80 m (cm), field A, field B and dazzle flags.
    pub const DEFAULT: MeasuringMode = MeasuringMode(0x00);

    /// The mask of the distance bits, or `None` for the energy mode `3Fh` and modes this code
    /// does not know.
    pub const fn distance_mask(self) -> Option<u16> {
        match self.0 {
            0x00..=0x02 => Some(0x1FFF),
            0x03 | 0x04 => Some(0x3FFF),
            0x05 | 0x06 => Some(0x7FFF),
            0x0F => Some(0xFFFF),
            _ => None,
        }
    }
}

/// Turns raw range words into distances for one measuring mode and unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RangeDecoder {
    mask: u16,
    unit: RangeUnit,
}

impl RangeDecoder {
    /// A decoder for `mode` and `unit`; `None` when the mode carries no distances.
    pub const fn new(mode: MeasuringMode, unit: RangeUnit) -> Option<RangeDecoder> {
        match mode.distance_mask() {
            Some(mask) => Some(RangeDecoder { mask, unit }),
            None => None,
        }
    }

    /// A decoder with an explicit distance mask (e.g. `7FFFh` when the mode is unknown but
    /// the data shows 32 m distances).
    pub const fn with_mask(mask: u16, unit: RangeUnit) -> RangeDecoder {
        RangeDecoder { mask, unit }
    }

    /// The distance bits mask.
    pub const fn mask(&self) -> u16 {
        self.mask
    }

    /// The distance bits of `word`, in the telegram's unit.
    #[inline]
    pub const fn distance(&self, word: u16) -> u16 {
        word & self.mask
    }

    /// The bits above the distance (field flags, reflector level, dazzle), shifted down.
    #[inline]
    pub const fn flags(&self, word: u16) -> u16 {
        match self.mask {
            0xFFFF => 0,
            mask => (word & !mask) >> mask.count_ones(),
        }
    }

    /// Whether `word` holds a "no return" code (masked value `…F7h` or more).
    #[inline]
    pub const fn is_no_return(&self, word: u16) -> bool {
        self.distance(word) >= self.mask - 8
    }

    /// The distance of `word` in millimetres, or `None` for a "no return" code.
    #[inline]
    pub const fn range_mm(&self, word: u16) -> Option<u32> {
        if self.is_no_return(word) {
            return None;
        }
        let distance = self.distance(word) as u32;
        Some(match self.unit {
            RangeUnit::Mm => distance,
            RangeUnit::Cm => distance * 10,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_per_mode() {
        let mask = |m| MeasuringMode(m).distance_mask();
        assert_eq!(mask(0x00), Some(0x1FFF));
        assert_eq!(mask(0x02), Some(0x1FFF));
        assert_eq!(mask(0x04), Some(0x3FFF));
        assert_eq!(mask(0x05), Some(0x7FFF));
        assert_eq!(mask(0x06), Some(0x7FFF));
        assert_eq!(mask(0x0F), Some(0xFFFF));
        assert_eq!(mask(0x3F), None);
        assert_eq!(mask(0x07), None);
    }

    #[test]
    fn default_mode_flags_and_range() {
        let d = RangeDecoder::new(MeasuringMode::DEFAULT, RangeUnit::Mm).unwrap();
        // Field A flag (bit 13) on a 1000 mm return.
        assert_eq!(d.range_mm(0x2000 | 1000), Some(1000));
        assert_eq!(d.flags(0x2000 | 1000), 0b001);
        assert_eq!(d.flags(0x8000), 0b100);
        assert_eq!(d.range_mm(0x1FFF), None);
        assert_eq!(d.range_mm(0x1FF7), None);
        assert_eq!(d.range_mm(0x1FF6), Some(0x1FF6));
    }

    #[test]
    fn centimetres_are_scaled() {
        let d = RangeDecoder::new(MeasuringMode(0x00), RangeUnit::Cm).unwrap();
        assert_eq!(d.range_mm(250), Some(2500));
        assert_eq!(d.range_mm(8191), None);
    }

    #[test]
    fn sixteen_metre_no_return() {
        let d = RangeDecoder::new(MeasuringMode(0x04), RangeUnit::Mm).unwrap();
        assert_eq!(d.range_mm(0x3FFF), None);
        assert_eq!(d.range_mm(0x4000 | 5237), Some(5237));
        assert_eq!(d.flags(0x4000 | 5237), 0b01);
    }

    #[test]
    fn full_word_mode() {
        let d = RangeDecoder::new(MeasuringMode(0x0F), RangeUnit::Mm).unwrap();
        assert_eq!(d.range_mm(0xF000), Some(0xF000));
        assert_eq!(d.flags(0xF000), 0);
        assert!(d.is_no_return(0xFFFF));
    }
}
