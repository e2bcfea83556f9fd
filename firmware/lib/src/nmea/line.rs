//! Line assembly: serial bytes in, complete candidate sentences out.
//!
//! Rules (§2 of `shared/protocols/nmea0183.md`):
//!
//! * A line starts at `$` and ends at CR or LF; CR LF, CR CR LF and bare LF all work, since
//!   bytes between lines are ignored.
//! * Every `$` starts a new line. A `$` before the current line ended means that line was
//!   cut short: it is dropped and counted in [`LineStats::truncated`].
//! * A line is at most [`MAX_NMEA_LEN`] bytes, `$` included, line ending excluded. Longer
//!   lines are dropped and counted in [`LineStats::too_long`].
//! * A byte that is not printable ASCII (`20h`–`7Eh`) inside a line (binary messages
//!   interleaved in the stream) drops the line; counted in [`LineStats::non_printable`].
//! * Bytes outside a line are skipped without a count (the gaps between sentences, binary
//!   messages, comments of a log are not this layer's concern).
//!
//! Lines are returned as borrowed slices: straight out of the caller's input when a whole
//! line sits in one push (no copy), otherwise out of the assembler's own
//! [`MAX_NMEA_LEN`]-byte buffer. Every line carries the `now_us` passed with the push that
//! delivered its `$`. Never panics, whatever the input.

use protocol::MAX_NMEA_LEN;

use super::sentence::is_printable;

/// One complete line, `$` through the last byte before CR/LF.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Line<'a> {
    /// The bytes; printable ASCII, starting with `$`, at most [`MAX_NMEA_LEN`] long.
    pub bytes: &'a [u8],
    /// The `now_us` given with the bytes that contained the `$`.
    pub stamp_us: u64,
}

/// Counters of the line layer. All counts wrap at 2³².
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LineStats {
    /// Bytes pushed.
    pub bytes: u32,
    /// Complete lines delivered.
    pub lines: u32,
    /// Lines dropped because a `$` arrived before their end.
    pub truncated: u32,
    /// Lines dropped because they exceeded [`MAX_NMEA_LEN`].
    pub too_long: u32,
    /// Lines dropped because of a non-printable byte.
    pub non_printable: u32,
}

/// Splits a byte stream into NMEA lines (see the module documentation for the rules).
#[derive(Debug, Clone)]
pub struct LineAssembler {
    /// The partial line, when a line spans pushes.
    buf: [u8; MAX_NMEA_LEN],
    /// Bytes used in `buf`.
    len: usize,
    /// Whether `buf` holds the start of a line still waiting for its end.
    in_line: bool,
    /// Timestamp of the current line's `$`.
    stamp_us: u64,
    stats: LineStats,
}

impl Default for LineAssembler {
    fn default() -> Self {
        Self::new()
    }
}

/// What ended a run of ordinary line bytes.
enum Stop {
    /// CR or LF: the line is complete.
    End,
    /// `$`: a new line starts here.
    Dollar,
    /// Another non-printable byte.
    Binary,
}

/// Finds the first byte that is not an ordinary line byte.
#[inline]
fn find_stop(bytes: &[u8]) -> Option<(usize, Stop)> {
    let i = find_special(bytes)?;
    let stop = match bytes.get(i) {
        Some(b'\r' | b'\n') => Stop::End,
        Some(b'$') => Stop::Dollar,
        _ => Stop::Binary,
    };
    Some((i, stop))
}

/// `0x01` in every byte of a word.
const ONES: u64 = u64::from_ne_bytes([0x01; 8]);
/// `0x80` in every byte of a word.
const HIGHS: u64 = u64::from_ne_bytes([0x80; 8]);

/// Whether any byte of `word` is `$`, below `20h` or above `7Eh` (may flag false positives
/// only in words that also hold a true one, which the byte loop then sorts out).
#[inline]
const fn has_special(word: u64) -> bool {
    let below_space = word.wrapping_sub(ONES * 0x20) & !word;
    let dollar = word ^ (ONES * b'$' as u64);
    let is_dollar = dollar.wrapping_sub(ONES) & !dollar;
    let del = word ^ (ONES * 0x7f);
    let is_del = del.wrapping_sub(ONES) & !del;
    (below_space | is_dollar | is_del | word) & HIGHS != 0
}

/// Index of the first `$` or non-printable byte: eight bytes at a time, then byte by byte
/// within the word that holds it.
#[inline]
fn find_special(bytes: &[u8]) -> Option<usize> {
    let is_special = |b: u8| b == b'$' || !is_printable(b);
    let mut offset = 0;
    let mut words = bytes.chunks_exact(8);
    for word in words.by_ref() {
        let mut array = [0u8; 8];
        array.copy_from_slice(word);
        if has_special(u64::from_ne_bytes(array)) {
            if let Some(i) = word.iter().position(|&b| is_special(b)) {
                return Some(offset + i);
            }
        }
        offset += 8;
    }
    words
        .remainder()
        .iter()
        .position(|&b| is_special(b))
        .map(|i| offset + i)
}

impl LineAssembler {
    /// An assembler waiting for the first `$`.
    pub const fn new() -> Self {
        LineAssembler {
            buf: [0; MAX_NMEA_LEN],
            len: 0,
            in_line: false,
            stamp_us: 0,
            stats: LineStats {
                bytes: 0,
                lines: 0,
                truncated: 0,
                too_long: 0,
                non_printable: 0,
            },
        }
    }

    /// The counters so far.
    pub const fn stats(&self) -> LineStats {
        self.stats
    }

    /// Whether a line has started and not yet ended.
    pub const fn in_line(&self) -> bool {
        self.in_line
    }

    /// Drops any partial line (e.g. after a UART overrun) without counting it.
    pub fn reset(&mut self) {
        self.in_line = false;
        self.len = 0;
    }

    /// Consumes bytes from the front of `input` until a line is complete and returns it, or
    /// consumes all of `input` and returns `None`. `now_us` is the time the bytes arrived;
    /// it stamps any line whose `$` is among them. Call repeatedly until it returns `None`:
    ///
    /// ```
    /// # use firmware::nmea::LineAssembler;
    /// let mut assembler = LineAssembler::new();
    /// let mut rest: &[u8] = b"$GPGGA,,,,,,0,,,,,,,,*66\r\n$GPRMC,";
    /// let mut lines = 0;
    /// while let Some(line) = assembler.next_line(&mut rest, 1_000) {
    ///     assert_eq!(line.stamp_us, 1_000);
    ///     lines += 1;
    /// }
    /// assert_eq!(lines, 1);
    /// assert!(assembler.in_line());
    /// ```
    pub fn next_line<'s, 'b: 's>(
        &'s mut self,
        input: &mut &'b [u8],
        now_us: u64,
    ) -> Option<Line<'s>> {
        loop {
            let data: &'b [u8] = input;
            if data.is_empty() {
                return None;
            }
            if self.in_line {
                let Some((i, stop)) = find_stop(data) else {
                    self.stats.bytes = self.stats.bytes.wrapping_add(len_u32(data));
                    *input = &[];
                    self.append(data);
                    return None;
                };
                let (run, rest) = data.split_at(i);
                self.stats.bytes = self.stats.bytes.wrapping_add(len_u32(run));
                self.append(run);
                *input = rest;
                if !self.in_line {
                    // Too long: dropped and counted by `append`; the stop byte is handled
                    // in the idle state (a `$` starts the next line).
                    continue;
                }
                self.in_line = false;
                match stop {
                    Stop::Dollar => self.stats.truncated = self.stats.truncated.wrapping_add(1),
                    Stop::Binary | Stop::End => {
                        self.consume_one(input);
                        if matches!(stop, Stop::End) {
                            self.stats.lines = self.stats.lines.wrapping_add(1);
                            let bytes = self.buf.get(..self.len).unwrap_or(&[]);
                            return Some(Line {
                                bytes,
                                stamp_us: self.stamp_us,
                            });
                        }
                        self.stats.non_printable = self.stats.non_printable.wrapping_add(1);
                    }
                }
                continue;
            }
            // Idle: skip to the next `$`.
            let Some(start) = data.iter().position(|&b| b == b'$') else {
                self.stats.bytes = self.stats.bytes.wrapping_add(len_u32(data));
                *input = &[];
                return None;
            };
            let (skipped, line_and_rest) = data.split_at(start);
            self.stats.bytes = self.stats.bytes.wrapping_add(len_u32(skipped));
            self.stamp_us = now_us;
            let after_dollar = line_and_rest.get(1..).unwrap_or(&[]);
            let Some((i, stop)) = find_stop(after_dollar) else {
                // The line continues in a later push.
                self.stats.bytes = self.stats.bytes.wrapping_add(len_u32(line_and_rest));
                *input = &[];
                self.len = 0;
                self.in_line = true;
                self.append(line_and_rest);
                return None;
            };
            let (line, rest) = line_and_rest.split_at(i + 1);
            self.stats.bytes = self.stats.bytes.wrapping_add(len_u32(line));
            *input = rest;
            if line.len() > MAX_NMEA_LEN {
                self.stats.too_long = self.stats.too_long.wrapping_add(1);
                continue;
            }
            match stop {
                Stop::Dollar => self.stats.truncated = self.stats.truncated.wrapping_add(1),
                Stop::Binary => {
                    self.consume_one(input);
                    self.stats.non_printable = self.stats.non_printable.wrapping_add(1);
                }
                Stop::End => {
                    self.consume_one(input);
                    self.stats.lines = self.stats.lines.wrapping_add(1);
                    return Some(Line {
                        bytes: line,
                        stamp_us: now_us,
                    });
                }
            }
        }
    }

    /// Appends `run` to the partial line; drops the line (and counts it) when it would
    /// exceed [`MAX_NMEA_LEN`].
    fn append(&mut self, run: &[u8]) {
        let end = self.len + run.len();
        match self.buf.get_mut(self.len..end) {
            Some(slot) => {
                slot.copy_from_slice(run);
                self.len = end;
            }
            None => {
                self.stats.too_long = self.stats.too_long.wrapping_add(1);
                self.in_line = false;
                self.len = 0;
            }
        }
    }

    /// Consumes the stop byte at the front of `input`.
    fn consume_one(&mut self, input: &mut &[u8]) {
        self.stats.bytes = self.stats.bytes.wrapping_add(1);
        *input = input.get(1..).unwrap_or(&[]);
    }
}

/// A slice length as a wrapping `u32` counter increment.
fn len_u32(bytes: &[u8]) -> u32 {
    // Truncation is intended: the counters wrap.
    bytes.len() as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Feeds `chunks` and collects the lines as strings.
    fn collect(assembler: &mut LineAssembler, chunks: &[&[u8]]) -> Vec<(String, u64)> {
        let mut out = Vec::new();
        for (t, chunk) in chunks.iter().enumerate() {
            let mut rest = *chunk;
            while let Some(line) = assembler.next_line(&mut rest, t as u64) {
                out.push((
                    String::from_utf8(line.bytes.to_vec()).unwrap(),
                    line.stamp_us,
                ));
            }
            assert!(rest.is_empty());
        }
        out
    }

    #[test]
    fn line_endings() {
        let mut a = LineAssembler::new();
        let lines = collect(&mut a, &[b"$A,1*00\r\n$B,2*00\r\r\n$C,3*00\n$D,4*00\r"]);
        let texts: Vec<&str> = lines.iter().map(|(s, _)| s.as_str()).collect();
        assert_eq!(texts, ["$A,1*00", "$B,2*00", "$C,3*00", "$D,4*00"]);
        assert_eq!(a.stats().lines, 4);
        assert_eq!(a.stats().bytes, 35);
    }

    #[test]
    fn lines_split_across_pushes_keep_the_dollar_time() {
        let mut a = LineAssembler::new();
        let lines = collect(&mut a, &[b"junk$GPG", b"GA,1", b"*00\r", b"\n$X*00\n"]);
        assert_eq!(lines, [("$GPGGA,1*00".into(), 0), ("$X*00".into(), 3)]);
        // Byte by byte.
        let stream = b"\r\n$GPGGA,1*00\r\n";
        let chunks: Vec<&[u8]> = stream.chunks(1).collect();
        let lines = collect(&mut a, &chunks);
        assert_eq!(lines, [("$GPGGA,1*00".into(), 2)]);
    }

    #[test]
    fn dollar_inside_a_line_truncates_it() {
        let mut a = LineAssembler::new();
        let lines = collect(
            &mut a,
            &[b"$GPGGA,12$GPGLL,1*00\r\n$GP", b"RMC$GPVTG*00\r\n"],
        );
        let texts: Vec<&str> = lines.iter().map(|(s, _)| s.as_str()).collect();
        assert_eq!(texts, ["$GPGLL,1*00", "$GPVTG*00"]);
        assert_eq!(a.stats().truncated, 2);
    }

    #[test]
    fn binary_bytes_drop_the_line() {
        let mut a = LineAssembler::new();
        let lines = collect(
            &mut a,
            &[
                b"\xb5\x62\x01$GPGGA,\x00\x01*00\r\n$OK*00\r\n",
                b"$A",
                b"\xff\r\n",
            ],
        );
        assert_eq!(lines.len(), 1);
        assert_eq!(a.stats().non_printable, 2);
    }

    #[test]
    fn bound_is_max_nmea_len() {
        let mut ok = vec![b'$'];
        ok.resize(MAX_NMEA_LEN, b'A');
        let mut long = ok.clone();
        long.push(b'A');
        for chunk_len in [1, 7, 500] {
            let mut a = LineAssembler::new();
            let mut stream = Vec::new();
            for line in [&ok, &long, &ok] {
                stream.extend_from_slice(line);
                stream.extend_from_slice(b"\r\n");
            }
            let chunks: Vec<&[u8]> = stream.chunks(chunk_len).collect();
            let lines = collect(&mut a, &chunks);
            assert_eq!(lines.len(), 2, "chunk {chunk_len}");
            assert!(lines.iter().all(|(l, _)| l.len() == MAX_NMEA_LEN));
            assert_eq!(a.stats().too_long, 1);
            assert_eq!(a.stats().bytes, stream.len() as u32);
        }
    }

    #[test]
    fn word_scan_finds_every_special_byte() {
        for special in (0u8..=255).filter(|&b| b == b'$' || !is_printable(b)) {
            for at in 0..20 {
                let mut bytes = vec![b'A'; 20];
                bytes[at] = special;
                assert_eq!(find_special(&bytes), Some(at), "{special:#x} at {at}");
            }
        }
        assert_eq!(find_special(&[b'~'; 19]), None);
        assert_eq!(
            find_special(b" !#%&~0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ"),
            None
        );
    }

    proptest! {
        #[test]
        fn word_scan_matches_byte_scan(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
            let expected = bytes.iter().position(|&b| b == b'$' || !is_printable(b));
            prop_assert_eq!(find_special(&bytes), expected);
        }

        /// Chunking never changes the result, and nothing panics.
        #[test]
        fn chunking_is_transparent(
            bytes in proptest::collection::vec(proptest::sample::select(b"$AB,*0\r\n\x00\xff".to_vec()), 0..400),
            cut in 1usize..50,
        ) {
            let mut whole = LineAssembler::new();
            let expected: Vec<String> = collect(&mut whole, &[&bytes]).into_iter().map(|l| l.0).collect();
            let mut chunked = LineAssembler::new();
            let chunks: Vec<&[u8]> = bytes.chunks(cut).collect();
            let got: Vec<String> = collect(&mut chunked, &chunks).into_iter().map(|l| l.0).collect();
            prop_assert_eq!(&got, &expected);
            prop_assert_eq!(chunked.stats(), whole.stats());
            prop_assert_eq!(whole.stats().bytes as usize, bytes.len());
        }
    }
}
