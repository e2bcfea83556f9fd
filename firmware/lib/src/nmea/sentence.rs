//! A zero-copy view over one NMEA 0183 sentence: `$` address `,` fields `*hh`, without the
//! line ending.
//!
//! Contract (as smoltcp's wire views): [`Sentence::new_unchecked`] wraps any bytes;
//! [`Sentence::check_format`] verifies the grammar (leading `$`, printable ASCII, length at
//! most [`MAX_NMEA_LEN`], an address of letters and digits, a `*hh` trailer);
//! [`Sentence::check_checksum`] verifies the XOR checksum; [`Sentence::new_checked`] does both.
//! No accessor panics on any input, checked or not; on an unchecked view they return
//! meaningless but in-bounds results.
//!
//! Checksum (NMEA 0183 §3 of `shared/protocols/nmea0183.md`): the XOR of every byte strictly
//! between `$` and `*`, written as two hexadecimal digits; upper- and lower-case digits are
//! accepted.

use protocol::MAX_NMEA_LEN;

use super::Error;

/// Who sent a sentence: a two-character talker (`GP`, `GN`, …) or, for proprietary sentences
/// (`$P…`), the three-character manufacturer code (`GRM`, `UBX`, `MTK`, …).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Talker {
    /// A standard talker ID as ASCII bytes, e.g. `*b"GN"`.
    Standard([u8; 2]),
    /// A proprietary sentence with its manufacturer code as ASCII bytes, e.g. `*b"GRM"`.
    Proprietary([u8; 3]),
}

/// The sentence formatters this module decodes, and `Other` for the rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SentenceKind {
    /// `$--GGA`: fix data.
    Gga,
    /// `$--RMC`: recommended minimum.
    Rmc,
    /// `$--GLL`: geographic position.
    Gll,
    /// `$--GSA`: DOP and active satellites.
    Gsa,
    /// `$--VTG`: course and speed over ground.
    Vtg,
    /// `$--GST`: pseudorange error statistics.
    Gst,
    /// Any other standard formatter (GSV, ZDA, TXT, …).
    Other,
    /// A proprietary sentence (`$P…`).
    Proprietary,
}

/// A view over one sentence, `$` through the checksum, without CR/LF.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sentence<T: AsRef<[u8]>> {
    buffer: T,
}

/// Length of the `*hh` trailer.
const TRAILER_LEN: usize = 3;

impl<T: AsRef<[u8]>> Sentence<T> {
    /// Wraps `buffer` without any check.
    pub const fn new_unchecked(buffer: T) -> Self {
        Sentence { buffer }
    }

    /// Wraps `buffer` and runs [`check_format`](Self::check_format) and
    /// [`check_checksum`](Self::check_checksum).
    ///
    /// # Errors
    /// As those two functions.
    pub fn new_checked(buffer: T) -> Result<Self, Error> {
        let sentence = Self::new_unchecked(buffer);
        let bytes = sentence.buffer.as_ref();
        // Fast path for the common case (a `*hh` trailer): the printable-ASCII check and the
        // checksum in one pass. Anything unusual takes the step-by-step path, which also
        // picks the right error.
        if let (Some(sent), Some(body)) = (
            sentence.transmitted_checksum(),
            bytes.get(1..bytes.len().saturating_sub(TRAILER_LEN)),
        ) {
            let (xor, all_printable) = body
                .iter()
                .fold((0u8, true), |(xor, ok), &b| (xor ^ b, ok & is_printable(b)));
            if all_printable
                && bytes.len() <= MAX_NMEA_LEN
                && bytes.first() == Some(&b'$')
                && sentence.address_is_valid()
            {
                return if xor == sent {
                    Ok(sentence)
                } else {
                    Err(Error::BadChecksum)
                };
            }
        }
        sentence.check_format()?;
        sentence.check_checksum()?;
        Ok(sentence)
    }

    /// Whether the address is long enough and alphanumeric.
    fn address_is_valid(&self) -> bool {
        let address = self.address();
        let min_len = if address.first() == Some(&b'P') { 4 } else { 3 };
        address.len() >= min_len && address.iter().all(u8::is_ascii_alphanumeric)
    }

    /// Verifies the sentence grammar, everything except the checksum value.
    ///
    /// # Errors
    /// * [`Error::TooLong`] when longer than [`MAX_NMEA_LEN`] bytes;
    /// * [`Error::Malformed`] when the first byte is not `$`, a byte is not printable ASCII,
    ///   the address is too short or not alphanumeric (checked first, so that binary junk
    ///   starting with `$` is malformed rather than unchecksummed), or a `*` is followed by
    ///   something other than exactly two hexadecimal digits;
    /// * [`Error::MissingChecksum`] when there is no `*`, or only a `*` at the very end.
    pub fn check_format(&self) -> Result<(), Error> {
        let bytes = self.buffer.as_ref();
        if bytes.len() > MAX_NMEA_LEN {
            return Err(Error::TooLong);
        }
        if bytes.first() != Some(&b'$') {
            return Err(Error::Malformed);
        }
        if !bytes.iter().all(|&b| is_printable(b)) {
            return Err(Error::Malformed);
        }
        if !self.address_is_valid() {
            return Err(Error::Malformed);
        }
        if self.transmitted_checksum().is_none() {
            // No `*`, or a bare `*` at the end (Garmin `$GPBOD,,T,,M,,*`): no checksum.
            return Err(match bytes.iter().position(|&b| b == b'*') {
                None => Error::MissingChecksum,
                Some(i) if i + 1 == bytes.len() => Error::MissingChecksum,
                Some(_) => Error::Malformed,
            });
        }
        Ok(())
    }

    /// Verifies that the transmitted checksum equals the computed one.
    ///
    /// # Errors
    /// [`Error::MissingChecksum`] when there is no `*hh` trailer, [`Error::BadChecksum`] when
    /// the values differ.
    pub fn check_checksum(&self) -> Result<(), Error> {
        match self.transmitted_checksum() {
            None => Err(Error::MissingChecksum),
            Some(sent) if sent == self.computed_checksum() => Ok(()),
            Some(_) => Err(Error::BadChecksum),
        }
    }

    /// The checksum written in the `*hh` trailer, if the trailer is well-formed.
    pub fn transmitted_checksum(&self) -> Option<u8> {
        let bytes = self.buffer.as_ref();
        let star = bytes.len().checked_sub(TRAILER_LEN)?;
        if bytes.get(star) != Some(&b'*') {
            return None;
        }
        let hi = hex_value(*bytes.get(star + 1)?)?;
        let lo = hex_value(*bytes.get(star + 2)?)?;
        Some(hi << 4 | lo)
    }

    /// The XOR of the bytes of [`body`](Self::body).
    pub fn computed_checksum(&self) -> u8 {
        checksum(self.body())
    }

    /// The bytes strictly between `$` and `*` (the whole rest when there is no trailer).
    pub fn body(&self) -> &[u8] {
        let bytes = self.buffer.as_ref();
        let end = if self.transmitted_checksum().is_some() {
            bytes.len() - TRAILER_LEN
        } else {
            bytes.len()
        };
        bytes.get(1..end).unwrap_or(&[])
    }

    /// The address field: talker and formatter, e.g. `GPGGA` or `PGRME`.
    pub fn address(&self) -> &[u8] {
        let body = self.body();
        let end = body.iter().position(|&b| b == b',').unwrap_or(body.len());
        body.get(..end).unwrap_or(&[])
    }

    /// Whether this is a proprietary sentence (`$P…`).
    pub fn is_proprietary(&self) -> bool {
        self.address().first() == Some(&b'P')
    }

    /// The talker, or the manufacturer of a proprietary sentence (`None` when the address is
    /// too short, which [`check_format`](Self::check_format) rejects).
    pub fn talker(&self) -> Option<Talker> {
        let address = self.address();
        if self.is_proprietary() {
            let code = address.get(1..4)?;
            <[u8; 3]>::try_from(code).ok().map(Talker::Proprietary)
        } else {
            let id = address.get(..2)?;
            <[u8; 2]>::try_from(id).ok().map(Talker::Standard)
        }
    }

    /// The sentence formatter: the address after the talker (`GGA` for `GPGGA`), or after
    /// `P` and the manufacturer code for proprietary sentences (`E` for `PGRME`, empty for
    /// `PUBX`).
    pub fn formatter(&self) -> &[u8] {
        let address = self.address();
        let skip = if self.is_proprietary() { 4 } else { 2 };
        address.get(skip..).unwrap_or(&[])
    }

    /// Which of the decoded sentence types this is.
    pub fn kind(&self) -> SentenceKind {
        let bytes = self.buffer.as_ref();
        if bytes.get(1) == Some(&b'P') {
            return SentenceKind::Proprietary;
        }
        // A standard address is 5 characters: `$ttfff,` or `$ttfff*`.
        let formatter = match (bytes.get(3..6), bytes.get(6)) {
            (Some(formatter), Some(b',' | b'*'))
                if bytes
                    .get(1..3)
                    .is_some_and(|talker| !talker.contains(&b',')) =>
            {
                formatter
            }
            _ => return SentenceKind::Other,
        };
        match formatter {
            b"GGA" => SentenceKind::Gga,
            b"RMC" => SentenceKind::Rmc,
            b"GLL" => SentenceKind::Gll,
            b"GSA" => SentenceKind::Gsa,
            b"VTG" => SentenceKind::Vtg,
            b"GST" => SentenceKind::Gst,
            _ => SentenceKind::Other,
        }
    }

    /// The data fields after the address, split at commas; empty fields are empty slices.
    /// A sentence without fields (`$GPXXX*hh`) yields none.
    pub fn fields(&self) -> Fields<'_> {
        let body = self.body();
        let address_len = self.address().len();
        match body.get(address_len + 1..) {
            Some(rest) if body.get(address_len) == Some(&b',') => Fields { rest: Some(rest) },
            _ => Fields { rest: None },
        }
    }

    /// Splits the data fields into an array: the first `N` fields are stored (the rest of
    /// the array stays empty) and the total number of fields is returned.
    pub fn field_array<const N: usize>(&self) -> ([&[u8]; N], usize) {
        let mut out: [&[u8]; N] = [&[]; N];
        let mut count = 0;
        for field in self.fields() {
            if let Some(slot) = out.get_mut(count) {
                *slot = field;
            }
            count += 1;
        }
        (out, count)
    }

    /// The whole sentence as bytes.
    pub fn as_bytes(&self) -> &[u8] {
        self.buffer.as_ref()
    }

    /// The wrapped buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }
}

/// Iterator over the comma-separated data fields of a [`Sentence`].
#[derive(Debug, Clone)]
pub struct Fields<'a> {
    rest: Option<&'a [u8]>,
}

impl<'a> Iterator for Fields<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        let rest = self.rest?;
        match rest.iter().position(|&b| b == b',') {
            Some(i) => {
                let (field, tail) = rest.split_at(i);
                self.rest = tail.get(1..);
                Some(field)
            }
            None => {
                self.rest = None;
                Some(rest)
            }
        }
    }
}

/// The NMEA checksum of `body`: the XOR of all its bytes.
pub fn checksum(body: &[u8]) -> u8 {
    body.iter().fold(0, |acc, &b| acc ^ b)
}

/// Whether `byte` may appear in a sentence (printable ASCII, `20h`–`7Eh`).
pub const fn is_printable(byte: u8) -> bool {
    matches!(byte, 0x20..=0x7e)
}

/// The value of one hexadecimal digit, either case.
const fn hex_value(digit: u8) -> Option<u8> {
    match digit {
        b'0'..=b'9' => Some(digit - b'0'),
        b'A'..=b'F' => Some(digit - b'A' + 10),
        b'a'..=b'f' => Some(digit - b'a' + 10),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    static GGA_NO_FIX: &[u8] = b"$GPGGA,,,,,,0,,,,,,,,*66";

    #[test]
    fn test_deconstruct() {
        let s = Sentence::new_checked(GGA_NO_FIX).unwrap();
        assert_eq!(s.talker(), Some(Talker::Standard(*b"GP")));
        assert_eq!(s.formatter(), b"GGA");
        assert_eq!(s.kind(), SentenceKind::Gga);
        assert_eq!(s.transmitted_checksum(), Some(0x66));
        assert_eq!(s.computed_checksum(), 0x66);
        let fields: Vec<&[u8]> = s.fields().collect();
        assert_eq!(fields.len(), 14);
        assert_eq!(fields[5], b"0");
        assert!(
            fields
                .iter()
                .enumerate()
                .all(|(i, f)| i == 5 || f.is_empty())
        );
    }

    #[test]
    fn accepts_str_buffers_and_lower_case_hex() {
        let s = Sentence::new_checked("$GNVTG,,,,,,,,,N*2e").unwrap();
        assert_eq!(s.kind(), SentenceKind::Vtg);
    }

    #[test]
    fn proprietary_talker_and_formatter() {
        let body = b"PGRME,15.0,M,45.0,M,25.0,M";
        let line = format!(
            "${}*{:02X}",
            core::str::from_utf8(body).unwrap(),
            checksum(body)
        );
        let s = Sentence::new_checked(line.as_bytes()).unwrap();
        assert_eq!(s.talker(), Some(Talker::Proprietary(*b"GRM")));
        assert_eq!(s.formatter(), b"E");
        assert_eq!(s.kind(), SentenceKind::Proprietary);
        let s = Sentence::new_unchecked("$PUBX,00*33");
        assert_eq!(s.talker(), Some(Talker::Proprietary(*b"UBX")));
        assert_eq!(s.formatter(), b"");
    }

    #[test]
    fn checksum_errors_are_distinguished() {
        assert_eq!(
            Sentence::new_checked("$GPGGA,,,,,,0,,,,,,,,*67").unwrap_err(),
            Error::BadChecksum
        );
        assert_eq!(
            Sentence::new_checked("$GPGGA,,,,,,0,,,,,,,,").unwrap_err(),
            Error::MissingChecksum
        );
        assert_eq!(
            Sentence::new_checked("$GPGGA,,,,,,0,,,,,,,,*6").unwrap_err(),
            Error::Malformed
        );
        assert_eq!(
            Sentence::new_checked("$GPBOD,,T,,M,,*").unwrap_err(),
            Error::MissingChecksum
        );
        assert_eq!(Sentence::new_checked("$tI").unwrap_err(), Error::Malformed);
        assert_eq!(
            Sentence::new_checked("$GPGGA,,,,,,0,,,,,,,,*6G").unwrap_err(),
            Error::Malformed
        );
    }

    #[test]
    fn rejects_bad_grammar() {
        for bad in [
            &b""[..],
            b"$",
            b"*00",
            b"GPGGA,1*00",
            b"$G*47",
            b"$GP-GA,*00",
            b"$GPGGA,\x1b[0m*00",
        ] {
            let err = Sentence::new_checked(bad).unwrap_err();
            assert!(
                matches!(err, Error::Malformed | Error::MissingChecksum),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn test_impossible_len() {
        let mut long = vec![b'$'];
        long.extend_from_slice(b"GPTXT,");
        long.resize(MAX_NMEA_LEN + 1 - 3, b'A');
        long.extend_from_slice(b"*00");
        assert_eq!(
            Sentence::new_checked(&long[..]).unwrap_err(),
            Error::TooLong
        );
    }

    #[test]
    fn fields_of_sentence_without_data() {
        let s = Sentence::new_unchecked("$GPXXX*00");
        assert_eq!(s.fields().count(), 0);
        let s = Sentence::new_unchecked("$GPXXX,*00");
        assert_eq!(s.fields().collect::<Vec<_>>(), vec![&b""[..]]);
    }

    #[test]
    fn field_array_counts_all_fields() {
        let s = Sentence::new_unchecked("$GPXXX,a,b,c*00");
        let (f, n) = s.field_array::<2>();
        assert_eq!(n, 3);
        assert_eq!(f, [&b"a"[..], b"b"]);
    }

    proptest::proptest! {
        /// The one-pass check of `new_checked` agrees with the step-by-step checks, and
        /// `kind` agrees with `formatter` on every valid sentence.
        #[test]
        fn fast_path_agrees(body in proptest::collection::vec(proptest::sample::select(b"GPAR*,$1\x01".to_vec()), 0..12), sum in proptest::prelude::any::<u8>(), star in proptest::prelude::any::<bool>()) {
            let mut line = b"$GP".to_vec();
            line.extend_from_slice(&body);
            if star {
                line.extend_from_slice(format!("*{sum:02X}").as_bytes());
            }
            let s = Sentence::new_unchecked(&line[..]);
            let slow = s.check_format().and_then(|()| s.check_checksum());
            proptest::prop_assert_eq!(Sentence::new_checked(&line[..]).map(|_| ()), slow);
            if slow.is_ok() {
                let by_formatter = match (s.is_proprietary(), s.formatter()) {
                    (true, _) => SentenceKind::Proprietary,
                    (false, b"GGA") => SentenceKind::Gga,
                    (false, b"RMC") => SentenceKind::Rmc,
                    _ => SentenceKind::Other,
                };
                proptest::prop_assert_eq!(s.kind(), by_formatter);
            }
        }
    }

    #[test]
    fn accessors_never_panic_on_garbage() {
        for junk in [
            &b""[..],
            b"$",
            b"$*",
            b"*",
            b"$P",
            b"$P*zz",
            b",,,*",
            b"$,*00",
        ] {
            let s = Sentence::new_unchecked(junk);
            let _ = (
                s.talker(),
                s.formatter(),
                s.kind(),
                s.body(),
                s.check_checksum(),
            );
            let _ = s.fields().count();
        }
    }
}
