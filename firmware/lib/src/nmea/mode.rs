//! The NMEA 2.3+ mode indicator letter of RMC, GLL and VTG (§7 of
//! `shared/protocols/nmea0183.md`) and the fix quality it implies.

use protocol::FixQuality;

use super::Error;

/// Positioning mode indicator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// `A`: autonomous.
    Autonomous,
    /// `D`: differential.
    Differential,
    /// `E`: estimated (dead reckoning).
    Estimated,
    /// `F`: RTK float.
    RtkFloat,
    /// `M`: manual input.
    Manual,
    /// `N`: data not valid.
    NotValid,
    /// `P`: precise.
    Precise,
    /// `R`: RTK with fixed integers.
    RtkFixed,
    /// `S`: simulator.
    Simulator,
}

impl Mode {
    /// Parses the mode field; empty is `None`.
    ///
    /// # Errors
    /// [`Error::Malformed`] for anything but one of the letters `ADEFMNPRS`.
    pub fn parse(field: &[u8]) -> Result<Option<Self>, Error> {
        Ok(Some(match field {
            [] => return Ok(None),
            b"A" => Mode::Autonomous,
            b"D" => Mode::Differential,
            b"E" => Mode::Estimated,
            b"F" => Mode::RtkFloat,
            b"M" => Mode::Manual,
            b"N" => Mode::NotValid,
            b"P" => Mode::Precise,
            b"R" => Mode::RtkFixed,
            b"S" => Mode::Simulator,
            _ => return Err(Error::Malformed),
        }))
    }

    /// The letter as sent.
    pub const fn letter(self) -> u8 {
        match self {
            Mode::Autonomous => b'A',
            Mode::Differential => b'D',
            Mode::Estimated => b'E',
            Mode::RtkFloat => b'F',
            Mode::Manual => b'M',
            Mode::NotValid => b'N',
            Mode::Precise => b'P',
            Mode::RtkFixed => b'R',
            Mode::Simulator => b'S',
        }
    }

    /// The fix quality this mode stands for (`N` is [`FixQuality::Invalid`]).
    pub const fn fix_quality(self) -> FixQuality {
        match self {
            Mode::Autonomous => FixQuality::Gps,
            Mode::Differential => FixQuality::Dgps,
            Mode::Estimated => FixQuality::Estimated,
            Mode::RtkFloat => FixQuality::RtkFloat,
            Mode::Manual => FixQuality::Manual,
            Mode::NotValid => FixQuality::Invalid,
            Mode::Precise => FixQuality::Pps,
            Mode::RtkFixed => FixQuality::RtkFixed,
            Mode::Simulator => FixQuality::Simulator,
        }
    }
}

/// The fix quality of a sentence with an `A`/`V` status (RMC, GLL) and an optional mode:
/// status `V` or mode `N` is invalid; status `A` without a mode (NMEA before 2.3) is an
/// autonomous fix; otherwise the mode decides. A missing status counts as `A`.
pub fn status_quality(valid: Option<bool>, mode: Option<Mode>) -> FixQuality {
    match (valid, mode) {
        (Some(false), _) => FixQuality::Invalid,
        (_, Some(mode)) => mode.fix_quality(),
        (_, None) => FixQuality::Gps,
    }
}

/// Parses an `A`/`V` status field: `Some(true)` for `A` (valid), `Some(false)` for `V`,
/// `None` when empty.
///
/// # Errors
/// [`Error::Malformed`] for any other content.
pub fn parse_status(field: &[u8]) -> Result<Option<bool>, Error> {
    match field {
        [] => Ok(None),
        b"A" => Ok(Some(true)),
        b"V" => Ok(Some(false)),
        _ => Err(Error::Malformed),
    }
}

/// The status letter for [`parse_status`]'s value.
pub const fn status_letter(valid: Option<bool>) -> Option<u8> {
    match valid {
        Some(true) => Some(b'A'),
        Some(false) => Some(b'V'),
        None => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letters_round_trip() {
        for letter in *b"ADEFMNPRS" {
            let mode = Mode::parse(&[letter]).unwrap().unwrap();
            assert_eq!(mode.letter(), letter);
        }
        assert_eq!(Mode::parse(b""), Ok(None));
        assert_eq!(Mode::parse(b"X"), Err(Error::Malformed));
        assert_eq!(Mode::parse(b"AA"), Err(Error::Malformed));
    }

    #[test]
    fn no_fix_rule() {
        assert_eq!(
            status_quality(Some(false), Some(Mode::Autonomous)),
            FixQuality::Invalid
        );
        assert_eq!(
            status_quality(Some(true), Some(Mode::NotValid)),
            FixQuality::Invalid
        );
        assert_eq!(status_quality(Some(true), None), FixQuality::Gps);
        assert_eq!(
            status_quality(Some(true), Some(Mode::RtkFixed)),
            FixQuality::RtkFixed
        );
        assert_eq!(
            status_quality(Some(false), Some(Mode::Simulator)),
            FixQuality::Invalid
        );
    }
}
