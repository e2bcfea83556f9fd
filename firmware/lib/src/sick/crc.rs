//! The SICK LMS2xx telegram checksum ("CRC16", Telegram Listing §9; protocol notes §3).
//!
//! Not a textbook CRC-16: the 16-bit register is shifted once per byte (XOR `8005h` when the
//! bit shifted out is set), then the word made of the previous and the current byte is XORed
//! in. The checksum covers every byte from STX through the last data byte and is sent low
//! byte first. There is no "residue zero" property: a receiver recomputes the value over the
//! `L + 4` covered bytes and compares it with the two transmitted bytes.

/// The generator constant XORed in when the shifted-out bit is set.
const GENERATOR: u16 = 0x8005;

/// An incremental SICK checksum, fed one byte at a time as bytes arrive.
///
/// ```
/// use firmware::sick::SickCrc;
/// let mut crc = SickCrc::new();
/// for byte in [0x02, 0x00, 0x01, 0x00, 0x31] {
///     crc.update(byte);
/// }
/// assert_eq!(crc.value(), 0x1215);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SickCrc {
    register: u16,
    previous: u8,
}

impl SickCrc {
    /// A checksum over no bytes yet.
    pub const fn new() -> Self {
        SickCrc {
            register: 0,
            previous: 0,
        }
    }

    /// Feeds the next byte of the telegram.
    #[inline(always)]
    pub fn update(&mut self, byte: u8) {
        self.register = step(self.register, self.previous, byte);
        self.previous = byte;
    }

    /// Feeds several bytes in order.
    #[inline]
    pub fn update_slice(&mut self, bytes: &[u8]) {
        let mut register = self.register;
        let mut previous = self.previous;
        for &byte in bytes {
            register = step(register, previous, byte);
            previous = byte;
        }
        self.register = register;
        self.previous = previous;
    }

    /// The checksum of the bytes fed so far.
    pub const fn value(&self) -> u16 {
        self.register
    }
}

/// One step of the register: shift (with the generator), then XOR in `previous:byte`.
#[inline(always)]
const fn step(register: u16, previous: u8, byte: u8) -> u16 {
    let shifted = if register & 0x8000 != 0 {
        (register << 1) ^ GENERATOR
    } else {
        register << 1
    };
    shifted ^ (((previous as u16) << 8) | byte as u16)
}

/// `T[h] = h·x¹⁶ mod P`: the reduction of a register multiplied by x⁸ (`P = x¹⁶ + x¹⁵ + x² + 1`).
const TIMES_X8: [u16; 256] = {
    let mut table = [0u16; 256];
    let mut h = 0;
    while h < 256 {
        let mut r = (h as u16) << 8;
        let mut k = 0;
        while k < 8 {
            r = step(r, 0, 0);
            k += 1;
        }
        table[h] = r;
        h += 1;
    }
    table
};

/// `c·x⁸ mod P`.
#[inline(always)]
fn times_x8(c: u16) -> u16 {
    (c << 8) ^ TIMES_X8[usize::from(c >> 8)]
}

/// `c·x + d mod P`: one step of the single-byte recurrence.
#[inline(always)]
const fn times_x_plus(c: u16, d: u8) -> u16 {
    step(c, 0, d)
}

/// `Σ dᵢ·x^(8-i)` for the 8 bytes of `word` (d₁ = lowest byte): degree < 16, no reduction.
#[inline(always)]
fn fold8(word: u64) -> u16 {
    const BYTES: u64 = 0x00FF_00FF_00FF_00FF;
    const PAIRS: u64 = 0x0000_FFFF_0000_FFFF;
    let pairs = ((word & BYTES) << 1) ^ ((word >> 8) & BYTES);
    let quads = ((pairs & PAIRS) << 2) ^ ((pairs >> 16) & PAIRS);
    (((quads & 0xFFFF_FFFF) << 4) ^ (quads >> 32)) as u16
}

/// The SICK checksum of `bytes` (STX through the last data byte of a telegram).
///
/// Computed eight bytes at a time: with `C(n) = x·C(n-1) + d(n) mod P`, the register after
/// byte n is `C(n) + x⁸·C(n-1)`, and eight steps of `C` are one table lookup plus a shifted
/// XOR of the bytes. Equal to feeding [`SickCrc`] byte by byte.
///
/// ```
/// assert_eq!(firmware::sick::crc16(&[0x02, 0x00, 0x01, 0x00, 0x31]), 0x1215);
/// ```
#[inline]
pub fn crc16(bytes: &[u8]) -> u16 {
    let Some((&last, head)) = bytes.split_last() else {
        return 0;
    };
    // C over all bytes but the last.
    let mut c = 0u16;
    let mut blocks = head.chunks_exact(8);
    for block in &mut blocks {
        let mut word = [0u8; 8];
        word.copy_from_slice(block);
        c = times_x8(c) ^ fold8(u64::from_le_bytes(word));
    }
    for &d in blocks.remainder() {
        c = times_x_plus(c, d);
    }
    times_x_plus(c, last) ^ times_x8(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sick::test_data::{EXAMPLE_TELEGRAMS, hex};

    #[test]
    fn worked_trace() {
        let mut crc = SickCrc::new();
        let trace = [
            (0x02, 0x0002),
            (0x00, 0x0204),
            (0x01, 0x0409),
            (0x00, 0x0912),
            (0x31, 0x1215),
        ];
        for (byte, expected) in trace {
            crc.update(byte);
            assert_eq!(crc.value(), expected, "after {byte:02x}");
        }
    }

    #[test]
    fn example_telegrams_verify() {
        for text in EXAMPLE_TELEGRAMS {
            let bytes = hex(text);
            let (covered, wire) = bytes.split_at(bytes.len() - 2);
            let transmitted = u16::from_le_bytes([wire[0], wire[1]]);
            assert_eq!(crc16(covered), transmitted, "{text}");
        }
    }

    #[test]
    fn misprinted_power_on_example_does_not_verify() {
        // Telegram Listing Table 7-5 prints `63 56`; its contents give `63 5E`.
        let bytes =
            hex("02 80 17 00 90 4C 4D 53 32 30 30 3B 33 30 31 30 36 33 3B 56 30 32 2E 31 30 20 10");
        assert_eq!(crc16(&bytes), 0x5E63);
    }

    #[test]
    fn incremental_equals_whole() {
        let bytes = hex(EXAMPLE_TELEGRAMS[3]);
        let mut crc = SickCrc::new();
        let (a, b) = bytes.split_at(5);
        crc.update_slice(a);
        for &byte in b {
            crc.update(byte);
        }
        assert_eq!(crc.value(), crc16(&bytes));
    }

    #[test]
    fn empty_is_zero() {
        assert_eq!(crc16(&[]), 0);
    }

    proptest::proptest! {
        #[test]
        fn block_algorithm_equals_bytewise(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..100)) {
            let mut crc = SickCrc::new();
            for &byte in &bytes {
                crc.update(byte);
            }
            proptest::prop_assert_eq!(crc16(&bytes), crc.value());
        }
    }
}
