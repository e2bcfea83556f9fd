//! Why bytes are not a usable SICK LMS2xx telegram or reply (protocol notes §2, §7).

use core::fmt;

/// Why a buffer was rejected by [`Telegram`](super::Telegram) or by one of the `Repr` parsers.
///
/// A small `Copy` enum, so that a receiver can count each kind of failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// The buffer is shorter than the header or than the length field announces.
    Truncated,
    /// The first byte is not STX (`02h`).
    BadStx,
    /// The length field is outside `1..=808` (or below what the telegram kind needs).
    BadLength,
    /// The transmitted checksum differs from the one computed over the telegram.
    BadCrc,
    /// The telegram carries another command or reply code than the `Repr` decodes.
    WrongCode,
    /// A field is inconsistent (e.g. the value count does not match the length).
    Malformed,
    /// The telegram is well formed but uses a feature this code does not handle (reserved
    /// count-word bits, reserved unit).
    Unsupported,
    /// The buffer given to an `emit` is smaller than `buffer_len()`.
    BufferTooSmall,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Error::Truncated => "telegram truncated",
            Error::BadStx => "telegram does not start with STX",
            Error::BadLength => "telegram length field out of range",
            Error::BadCrc => "telegram checksum mismatch",
            Error::WrongCode => "unexpected command or reply code",
            Error::Malformed => "malformed telegram field",
            Error::Unsupported => "unsupported telegram feature",
            Error::BufferTooSmall => "buffer too small for the telegram",
        })
    }
}

impl core::error::Error for Error {}

/// Result of the SICK telegram functions.
pub type Result<T> = core::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_human_readable() {
        assert_eq!(Error::BadCrc.to_string(), "telegram checksum mismatch");
        assert_eq!(Error::Truncated.to_string(), "telegram truncated");
    }
}
