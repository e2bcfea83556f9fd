//! Checks that the length-prefixed fields of an MCAP record fit inside the record, before the
//! MCAP library parses it.
//!
//! The library (`mcap` through `binrw`) reserves the length a string field claims, up to
//! 4 GiB, before it reads the string, and finds only afterwards that the record is too short.
//! A damaged length would cost a 4 GiB allocation, which a computer without overcommit
//! refuses by aborting. The reader checks every record it parses against its layout first.

use std::fmt;

/// One field of a record's layout (the MCAP specification's field types).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Field {
    /// A fixed-size field (`uint16`, `uint32`, `uint64`, `Timestamp`) of this many bytes.
    Fixed(usize),
    /// A `String`: a `uint32` byte length, then that many bytes.
    String,
    /// A `Map<String, String>`: a `uint32` byte length, then key and value strings.
    StringMap,
}

/// The Header record: profile, library.
pub(super) const HEADER: &[Field] = &[Field::String, Field::String];

/// The Channel record: id, schema id, topic, message encoding, metadata.
pub(super) const CHANNEL: &[Field] = &[
    Field::Fixed(2),
    Field::Fixed(2),
    Field::String,
    Field::String,
    Field::StringMap,
];

/// The Chunk record up to its records: message start and end times, uncompressed size,
/// uncompressed CRC, compression.
pub(super) const CHUNK: &[Field] = &[
    Field::Fixed(8),
    Field::Fixed(8),
    Field::Fixed(8),
    Field::Fixed(4),
    Field::String,
];

/// A field that claims more bytes than are left of what holds it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldOverrun {
    /// Which field, counted from 0 in the record's layout.
    pub field_index: usize,
    /// The length the field claims, bytes.
    pub claimed_bytes: u64,
    /// The bytes left in the record (or in the map, for a string inside a map).
    pub available_bytes: u64,
}

impl fmt::Display for FieldOverrun {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "field {} claims {} bytes where {} are left",
            self.field_index, self.claimed_bytes, self.available_bytes
        )
    }
}

/// Checks `record` (a record's body, without opcode and length) against `layout`, reading
/// it as the library's parser does.
///
/// Only lengths are checked: a record too short for a fixed-size field or a length prefix
/// passes, and the library's parser refuses it without reserving anything.
pub(super) fn check_fields(record: &[u8], layout: &[Field]) -> Result<(), FieldOverrun> {
    let mut rest = record;
    for (field_index, field) in layout.iter().enumerate() {
        let overrun = |claimed_bytes: u32, available_bytes: usize| FieldOverrun {
            field_index,
            claimed_bytes: u64::from(claimed_bytes),
            available_bytes: available_bytes as u64,
        };
        match field {
            Field::Fixed(bytes) => match rest.get(*bytes..) {
                Some(after) => rest = after,
                None => return Ok(()),
            },
            Field::String => match take_prefixed(rest) {
                Prefixed::Fits { after, .. } => rest = after,
                Prefixed::Overruns { claimed, available } => {
                    return Err(overrun(claimed, available));
                }
                Prefixed::Short => return Ok(()),
            },
            Field::StringMap => {
                let Some((length, after)) = rest.split_first_chunk::<4>() else {
                    return Ok(());
                };
                let map_bytes = u32::from_le_bytes(*length);
                if usize::try_from(map_bytes).is_ok_and(|n| n > after.len()) {
                    return Err(overrun(map_bytes, after.len()));
                }
                // The parser reads a key and a value while it has read fewer than the map's
                // bytes, each from the rest of the record (not only from the map's bytes).
                rest = after;
                let mut read = 0usize;
                while read < map_bytes as usize {
                    for _key_then_value in 0..2 {
                        match take_prefixed(rest) {
                            Prefixed::Fits { field, after } => {
                                read += 4 + field.len();
                                rest = after;
                            }
                            Prefixed::Overruns { claimed, available } => {
                                return Err(overrun(claimed, available));
                            }
                            Prefixed::Short => return Ok(()),
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

/// A `uint32` length and that many bytes from the front of some bytes.
enum Prefixed<'a> {
    /// The field fits: its bytes and what follows.
    Fits { field: &'a [u8], after: &'a [u8] },
    /// The length runs past the end: what it claims and the bytes there are after it.
    Overruns { claimed: u32, available: usize },
    /// Not even the length is there.
    Short,
}

fn take_prefixed(bytes: &[u8]) -> Prefixed<'_> {
    let Some((length, rest)) = bytes.split_first_chunk::<4>() else {
        return Prefixed::Short;
    };
    let claimed = u32::from_le_bytes(*length);
    match usize::try_from(claimed) {
        Ok(n) if n <= rest.len() => {
            let (field, after) = rest.split_at(n);
            Prefixed::Fits { field, after }
        }
        _ => Prefixed::Overruns {
            claimed,
            available: rest.len(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A channel record as the MCAP writer lays it out.
    fn channel(topic: &str, metadata: &[(&str, &str)]) -> Vec<u8> {
        let string = |s: &str| {
            let mut out = (s.len() as u32).to_le_bytes().to_vec();
            out.extend(s.as_bytes());
            out
        };
        let mut map = Vec::new();
        for (k, v) in metadata {
            map.extend(string(k));
            map.extend(string(v));
        }
        let mut record = vec![7, 0, 1, 0];
        record.extend(string(topic));
        record.extend(string("json"));
        record.extend((map.len() as u32).to_le_bytes());
        record.extend(map);
        record
    }

    #[test]
    fn well_formed_records_pass_and_parse() {
        for record in [channel("/board/scan", &[]), channel("/a", &[("k", "v")])] {
            assert_eq!(check_fields(&record, CHANNEL), Ok(()));
            let parsed = mcap::parse_record(mcap::records::op::CHANNEL, &record).unwrap();
            assert!(matches!(parsed, mcap::records::Record::Channel(_)));
        }
    }

    #[test]
    fn a_string_longer_than_its_record_is_refused() {
        let mut record = channel("/board/scan", &[]);
        // The topic's length: 2³² − 1.
        record[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        let available = (record.len() - 8) as u64;
        assert_eq!(
            check_fields(&record, CHANNEL),
            Err(FieldOverrun {
                field_index: 2,
                claimed_bytes: u64::from(u32::MAX),
                available_bytes: available,
            })
        );
    }

    #[test]
    fn a_string_of_a_map_longer_than_the_record_is_refused() {
        let mut record = channel("/a", &[("key", "value")]);
        // The map holds 16 bytes: the key's length, "key", the value's length, "value". The
        // key now claims 13 of the 12 left after its length.
        let key_length = record.len() - 16;
        record[key_length..key_length + 4].copy_from_slice(&13u32.to_le_bytes());
        let err = check_fields(&record, CHANNEL).unwrap_err();
        assert_eq!((err.field_index, err.claimed_bytes), (4, 13));
        assert_eq!(err.available_bytes, 12);
    }

    #[test]
    fn a_map_is_read_past_its_end_as_the_parser_reads_it() {
        // A 4-byte map holding an empty key: the parser then reads the value's length from
        // the bytes after the map, here 2³² − 1.
        let mut record = vec![1, 0, 0, 0];
        record.extend(0u32.to_le_bytes()); // topic ""
        record.extend(0u32.to_le_bytes()); // encoding ""
        record.extend(4u32.to_le_bytes()); // map of 4 bytes
        record.extend(0u32.to_le_bytes()); // key ""
        record.extend(u32::MAX.to_le_bytes()); // the value, after the map
        let err = check_fields(&record, CHANNEL).unwrap_err();
        assert_eq!(
            (err.field_index, err.claimed_bytes),
            (4, u64::from(u32::MAX))
        );

        // A value whose length straddles the map's end and the record's last bytes.
        let mut record = vec![1, 0, 0, 0];
        record.extend(0u32.to_le_bytes());
        record.extend(0u32.to_le_bytes());
        record.extend(6u32.to_le_bytes()); // map of 6 bytes
        record.extend(0u32.to_le_bytes()); // key ""
        record.extend([0xFF, 0xFF, 0xFF, 0x7F]); // 2 bytes in the map, 2 after
        let err = check_fields(&record, CHANNEL).unwrap_err();
        assert_eq!(err.claimed_bytes, 0x7FFF_FFFF);
    }

    #[test]
    fn a_record_too_short_for_a_fixed_field_is_left_to_the_parser() {
        assert_eq!(check_fields(&[1], CHANNEL), Ok(()));
        assert_eq!(check_fields(&[], HEADER), Ok(()));
        assert!(mcap::parse_record(mcap::records::op::CHANNEL, &[1]).is_err());
    }
}
