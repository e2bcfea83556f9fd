//! The measured-value reply `B0h` (protocol notes §7; Telegram Listing "Response B0h").
//!
//! ```text
//! data offset  0..2         2 .. 2+2N           (2+2N, 3+2N)          last
//!              count word   N range words (LE)  scan index, telegram   status
//!                                               index (only when the
//!                                               real-time indices are on)
//! ```
//!
//! The count word holds N (bits 0–9), a reserved bit 10, the partial-scan raster (bits
//! 11–12) and flag (bit 13) and the unit (bits 14–15: `00` cm, `01` mm). Whether the
//! real-time indices are present is decided by the length field: `L = 2N + 4` without them,
//! `2N + 6` with them. Range words are kept raw; [`super::RangeDecoder`] interprets them.
//!
//! Contract: [`ScanRepr::parse`] never panics; [`ScanRepr::emit`] never panics on a buffer of
//! [`ScanRepr::buffer_len`] bytes. `parse` does not verify the checksum: the
//! [`super::Receiver`] already did; call [`super::Telegram::check_crc`] for other sources.

use heapless::Vec;
use protocol::{MAX_SCAN_VALUES, RangeUnit, ScanMsg};

use super::error::{Error, Result};
use super::telegram::{REPLY_ADDRESS, Telegram, telegram_len};

/// Reply code of the measured-value telegram.
pub const SCAN_REPLY: u8 = 0xB0;

mod field {
    pub type Field = core::ops::Range<usize>;

    /// Offsets inside the telegram's data (after the `B0h` byte).
    pub const COUNT: Field = 0..2;
    pub const VALUES_START: usize = 2;

    /// Count-word bits.
    pub const COUNT_N: u16 = 0x03FF;
    pub const COUNT_RESERVED: u16 = 0x0400;
    pub const COUNT_RASTER: u16 = 0x1800;
    pub const COUNT_RASTER_SHIFT: u32 = 11;
    pub const COUNT_PARTIAL: u16 = 0x2000;
    pub const COUNT_UNIT: u16 = 0xC000;
    pub const COUNT_UNIT_MM: u16 = 0x4000;
}

/// Length field of a scan telegram: code, count word, values, indices, status.
const fn len_field(values: usize, indices: bool) -> usize {
    2 * values + if indices { 6 } else { 4 }
}

/// A decoded `B0h` measured-value telegram.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScanRepr {
    /// Unit of the distance bits (count-word bits 14–15).
    pub unit: RangeUnit,
    /// For a partial scan (interlaced mode, count-word bit 13), its raster 0–3: the scan
    /// starts at x.00°, x.25°, x.50° or x.75°. `None` for a complete scan.
    pub partial_raster: Option<u8>,
    /// The raw 16-bit range words in ascending angle order.
    pub values: Vec<u16, MAX_SCAN_VALUES>,
    /// (scan index, telegram index) when the real-time indices are enabled.
    pub indices: Option<(u8, u8)>,
    /// The status byte (§8).
    pub status: u8,
}

impl ScanRepr {
    /// Decodes a `B0h` telegram.
    ///
    /// # Errors
    /// [`Error::WrongCode`] for another reply; [`Error::Truncated`]/[`Error::BadLength`] from
    /// [`Telegram::check_len`]; [`Error::Unsupported`] for a set reserved count-word bit 10,
    /// the reserved unit `1x` or raster bits on a complete scan; [`Error::Malformed`] when N
    /// exceeds 401 or the length field is neither `2N + 4` nor `2N + 6`.
    pub fn parse<T: AsRef<[u8]>>(telegram: &Telegram<T>) -> Result<ScanRepr> {
        telegram.check_len()?;
        if telegram.command() != SCAN_REPLY {
            return Err(Error::WrongCode);
        }
        let data = telegram.data();
        let count_word = match data.get(field::COUNT) {
            Some(b) => u16::from_le_bytes([b[0], b[1]]),
            None => return Err(Error::Malformed),
        };
        let (unit, partial_raster, n) = decode_count_word(count_word)?;
        if n > MAX_SCAN_VALUES {
            return Err(Error::Malformed);
        }
        let len = usize::from(telegram.length());
        let indices_present = if len == len_field(n, false) {
            false
        } else if len == len_field(n, true) {
            true
        } else {
            return Err(Error::Malformed);
        };
        // The length field matched, so `data` holds exactly count, values, indices, status.
        let words_end = field::VALUES_START + 2 * n;
        let (words, rest) = match data.get(field::VALUES_START..).map(|d| d.split_at(2 * n)) {
            Some(split) if data.len() > words_end => split,
            _ => return Err(Error::Malformed),
        };
        let mut values = Vec::new();
        values.resize_default(n).map_err(|_| Error::Malformed)?;
        for (value, bytes) in values.iter_mut().zip(words.chunks_exact(2)) {
            *value = u16::from_le_bytes([bytes[0], bytes[1]]);
        }
        let (indices, status) = match (indices_present, rest) {
            (false, [status]) => (None, *status),
            (true, [scan, telegram, status]) => (Some((*scan, *telegram)), *status),
            _ => return Err(Error::Malformed),
        };
        Ok(ScanRepr {
            unit,
            partial_raster,
            values,
            indices,
            status,
        })
    }

    /// The count word this scan is sent with.
    pub fn count_word(&self) -> u16 {
        let mut word = self.values.len() as u16 & field::COUNT_N;
        if let Some(raster) = self.partial_raster {
            word |= field::COUNT_PARTIAL
                | ((u16::from(raster) << field::COUNT_RASTER_SHIFT) & field::COUNT_RASTER);
        }
        if self.unit == RangeUnit::Mm {
            word |= field::COUNT_UNIT_MM;
        }
        word
    }

    /// Size in bytes of the whole telegram [`Self::emit`] writes.
    pub fn buffer_len(&self) -> usize {
        telegram_len(len_field(self.values.len(), self.indices.is_some()) as u16)
    }

    /// Writes the telegram (address `80h`, checksum included) into `telegram`.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] when the buffer is shorter than [`Self::buffer_len`].
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, telegram: &mut Telegram<T>) -> Result<()> {
        if telegram.as_ref().len() < self.buffer_len() {
            return Err(Error::BufferTooSmall);
        }
        let n = self.values.len();
        telegram.set_header(
            REPLY_ADDRESS,
            SCAN_REPLY,
            len_field(n, self.indices.is_some()) - 1,
        );
        let data = telegram.data_mut();
        data[field::COUNT].copy_from_slice(&self.count_word().to_le_bytes());
        let words_end = field::VALUES_START + 2 * n;
        for (bytes, value) in data[field::VALUES_START..words_end]
            .chunks_exact_mut(2)
            .zip(&self.values)
        {
            bytes.copy_from_slice(&value.to_le_bytes());
        }
        let mut at = words_end;
        if let Some((scan, index)) = self.indices {
            data[at] = scan;
            data[at + 1] = index;
            at += 2;
        }
        data[at] = self.status;
        telegram.fill_crc();
        Ok(())
    }

    /// The scan as the message the board forwards to the host.
    ///
    /// `stamp_us` is the board time of the telegram's first byte, `scan_counter` the number
    /// of scans forwarded so far; the angles come from the configured variant (start 0 for
    /// 180°, 4 000 for 100°; step 25, 50 or 100).
    pub fn to_msg(
        &self,
        stamp_us: u64,
        scan_counter: u32,
        start_angle_cdeg: u16,
        step_angle_cdeg: u16,
    ) -> ScanMsg {
        ScanMsg {
            stamp_us,
            scan_counter,
            start_angle_cdeg,
            step_angle_cdeg,
            unit: self.unit,
            count_word: self.count_word(),
            values: self.values.clone(),
            status: self.status,
            sensor_indices: self.indices,
        }
    }
}

/// Splits a count word into unit, partial-scan raster and N.
fn decode_count_word(word: u16) -> Result<(RangeUnit, Option<u8>, usize)> {
    if word & field::COUNT_RESERVED != 0 {
        return Err(Error::Unsupported);
    }
    let unit = match word & field::COUNT_UNIT {
        0 => RangeUnit::Cm,
        field::COUNT_UNIT_MM => RangeUnit::Mm,
        _ => return Err(Error::Unsupported),
    };
    let raster = ((word & field::COUNT_RASTER) >> field::COUNT_RASTER_SHIFT) as u8;
    let partial_raster = if word & field::COUNT_PARTIAL != 0 {
        Some(raster)
    } else if raster != 0 {
        return Err(Error::Unsupported);
    } else {
        None
    };
    Ok((unit, partial_raster, usize::from(word & field::COUNT_N)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sick::RangeDecoder;
    use crate::sick::telegram::MAX_TELEGRAM_LEN;
    use crate::sick::test_data::real_b0;

    /// Synthetic `B0h` of §11: 3 values in mm (1000, 2000, 1FFFh = no echo), status 10h.
    static TELEGRAM_BYTES: [u8; 16] = [
        0x02, 0x80, 0x0A, 0x00, 0xB0, 0x03, 0x40, 0xE8, 0x03, 0xD0, 0x07, 0xFF, 0x1F, 0x10, 0x16,
        0xB1,
    ];

    fn repr() -> ScanRepr {
        ScanRepr {
            unit: RangeUnit::Mm,
            partial_raster: None,
            values: Vec::from_slice(&[1000, 2000, 0x1FFF]).unwrap(),
            indices: None,
            status: 0x10,
        }
    }

    #[test]
    fn test_deconstruct() {
        let telegram = Telegram::new_checked(&TELEGRAM_BYTES[..]).unwrap();
        assert_eq!(telegram.check_crc(), Ok(()));
        assert_eq!(telegram.command(), SCAN_REPLY);
        assert_eq!(telegram.length(), 10);
        assert_eq!(telegram.status(), Some(0x10));
    }

    #[test]
    fn test_parse() {
        let telegram = Telegram::new_checked(&TELEGRAM_BYTES[..]).unwrap();
        let scan = ScanRepr::parse(&telegram).unwrap();
        assert_eq!(scan, repr());
        assert_eq!(scan.count_word(), 0x4003);
    }

    #[test]
    fn test_construct() {
        let repr = repr();
        assert_eq!(repr.buffer_len(), TELEGRAM_BYTES.len());
        let mut bytes = [0u8; 16];
        repr.emit(&mut Telegram::new_unchecked(&mut bytes[..]))
            .unwrap();
        assert_eq!(bytes, TELEGRAM_BYTES);
    }

    #[test]
    fn test_emit() {
        let mut repr = repr();
        repr.indices = Some((7, 200));
        repr.partial_raster = Some(2);
        repr.unit = RangeUnit::Cm;
        let mut bytes = [0u8; 18];
        assert_eq!(repr.buffer_len(), 18);
        repr.emit(&mut Telegram::new_unchecked(&mut bytes[..]))
            .unwrap();
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(telegram.check_crc(), Ok(()));
        assert_eq!(telegram.length(), 12);
        assert_eq!(ScanRepr::parse(&telegram).unwrap(), repr);
    }

    #[test]
    fn emit_into_small_buffer_fails() {
        let mut bytes = [0u8; 15];
        let result = repr().emit(&mut Telegram::new_unchecked(&mut bytes[..]));
        assert_eq!(result, Err(Error::BufferTooSmall));
    }

    #[test]
    fn test_impossible_len() {
        // Length field 12 (as with indices) but only three values and no indices: 2N+4=10.
        let mut bytes = [0u8; 20];
        bytes[..16].copy_from_slice(&TELEGRAM_BYTES);
        let mut telegram = Telegram::new_unchecked(&mut bytes[..]);
        telegram.set_length(11);
        telegram.fill_crc();
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(ScanRepr::parse(&telegram), Err(Error::Malformed));
        // N above 401.
        let mut bytes = [0u8; MAX_TELEGRAM_LEN];
        let mut telegram = Telegram::new_unchecked(&mut bytes[..]);
        telegram.set_header(REPLY_ADDRESS, SCAN_REPLY, 2 * 402 + 3);
        telegram.data_mut()[..2].copy_from_slice(&(0x4000u16 | 402).to_le_bytes());
        assert_eq!(
            ScanRepr::parse(&Telegram::new_unchecked(&bytes[..])),
            Err(Error::Malformed)
        );
        // Length field 2: no room for the count word.
        let bytes = [0x02, 0x80, 0x02, 0x00, 0xB0, 0x10, 0, 0];
        assert_eq!(
            ScanRepr::parse(&Telegram::new_unchecked(&bytes[..])),
            Err(Error::Malformed)
        );
    }

    #[test]
    fn reserved_count_bits_rejected() {
        for (word, err) in [
            (0x4403u16, Error::Unsupported), // bit 10
            (0x8003, Error::Unsupported),    // unit 10
            (0xC003, Error::Unsupported),    // unit 11
            (0x4803, Error::Unsupported),    // raster without the partial flag
        ] {
            let mut bytes = TELEGRAM_BYTES;
            bytes[5..7].copy_from_slice(&word.to_le_bytes());
            let telegram = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(ScanRepr::parse(&telegram), Err(err), "{word:04x}");
        }
    }

    #[test]
    fn wrong_code_rejected() {
        let bytes = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(ScanRepr::parse(&telegram), Err(Error::WrongCode));
    }

    #[test]
    fn to_msg_carries_everything() {
        let msg = repr().to_msg(1234, 5, 0, 50);
        assert_eq!(msg.count_word, 0x4003);
        assert_eq!(msg.values.as_slice(), &[1000, 2000, 0x1FFF]);
        assert_eq!(
            (msg.stamp_us, msg.scan_counter, msg.step_angle_cdeg),
            (1234, 5, 50)
        );
        assert_eq!(msg.unit, RangeUnit::Mm);
        assert_eq!(msg.status, 0x10);
        assert_eq!(msg.sensor_indices, None);
    }

    #[test]
    fn synthetic_ranges() {
        let telegram = Telegram::new_checked(&TELEGRAM_BYTES[..]).unwrap();
        let scan = ScanRepr::parse(&telegram).unwrap();
        let decoder = RangeDecoder::new(crate::sick::MeasuringMode::DEFAULT, scan.unit).unwrap();
        let ranges: std::vec::Vec<_> = scan.values.iter().map(|&w| decoder.range_mm(w)).collect();
        assert_eq!(ranges, [Some(1000), Some(2000), None]);
    }

    #[test]
    fn real_361_value_scan() {
        let Some(bytes) = real_b0("real_361_value_scan") else {
            return;
        };
        assert_eq!(bytes.len(), 732);
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(telegram.check_crc(), Ok(()));
        let scan = ScanRepr::parse(&telegram).unwrap();
        assert_eq!(scan.values.len(), 361);
        assert_eq!(scan.count_word(), 0x4169);
        assert_eq!(scan.unit, RangeUnit::Mm);
        assert_eq!((scan.indices, scan.status), (None, 0x10));
        let decoder = RangeDecoder::with_mask(0x7FFF, scan.unit);
        let ranges: std::vec::Vec<_> = scan.values.iter().map(|&w| decoder.range_mm(w)).collect();
        assert_eq!(&ranges[..3], &[Some(2251), Some(2251), Some(2242)]);
        assert_eq!(ranges[180], Some(3289));
        let mut out = [0u8; 732];
        scan.emit(&mut Telegram::new_unchecked(&mut out[..]))
            .unwrap();
        assert_eq!(&out[..], &bytes[..]);
    }
}
