//! Why a line is not a usable NMEA sentence.

use core::fmt;

/// Why a line was rejected by [`Sentence`](super::Sentence) or a sentence `Repr`.
///
/// A small `Copy` enum, so that a receiver can count each kind of failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// The sentence has no `*hh` checksum (allowed by the standard for some sentences; the
    /// firmware decodes only checksummed sentences).
    MissingChecksum,
    /// The transmitted checksum differs from the XOR of the bytes between `$` and `*`.
    BadChecksum,
    /// The text does not follow the sentence grammar, or a field is out of range.
    Malformed,
    /// The sentence is longer than [`protocol::MAX_NMEA_LEN`].
    TooLong,
    /// The sentence formatter is not the one the `Repr` decodes (e.g. RMC given to the GGA
    /// parser).
    WrongFormatter,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Error::MissingChecksum => "sentence has no checksum",
            Error::BadChecksum => "checksum mismatch",
            Error::Malformed => "malformed sentence",
            Error::TooLong => "sentence too long",
            Error::WrongFormatter => "unexpected sentence formatter",
        })
    }
}

impl core::error::Error for Error {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_human_readable() {
        assert_eq!(Error::BadChecksum.to_string(), "checksum mismatch");
        assert_eq!(
            Error::MissingChecksum.to_string(),
            "sentence has no checksum"
        );
    }
}
