//! LMS2xx → host replies other than scans (protocol notes §4, §6; Telegram Listing §7):
//! `A0h` mode switch, `BBh` variant, `B1h` status ([`StatusReply`]), `F4h`/`F7h`
//! configuration, `90h` power-on, `BAh` type, `91h` reset confirmation and `92h` "command not
//! allowed".
//!
//! [`Reply::parse`] dispatches on the reply code; [`Reply::emit`] builds the telegram (address
//! `80h`) so that sensor emulators produce their bytes with the same code the firmware
//! parses. Neither verifies the checksum: the [`super::Receiver`] already did.

use heapless::Vec;

use super::config::{CONFIG_LEN, ConfigBlock};
use super::error::{Error, Result};
use super::status_reply::StatusReply;
use super::telegram::{REPLY_ADDRESS, Telegram, telegram_len};

/// The longest type or power-on string kept, in bytes.
pub const MAX_TEXT_LEN: usize = 48;

/// Reply codes.
pub mod code {
    /// Power-on message (unsolicited, after power-on and after a reset).
    pub const POWER_ON: u8 = 0x90;
    /// Confirmation of a software reset `10h`.
    pub const RESET_ACK: u8 = 0x91;
    /// The command is not allowed now ("not acknowledge, incorrect command").
    pub const REJECTED: u8 = 0x92;
    /// Reply to a mode switch `20h`.
    pub const MODE: u8 = 0xA0;
    /// Measured values, reply to `30h` and the streamed scans.
    pub const SCAN: u8 = 0xB0;
    /// Reply to status `31h`.
    pub const STATUS: u8 = 0xB1;
    /// Reply to type `3Ah`.
    pub const TYPE: u8 = 0xBA;
    /// Reply to variant `3Bh`.
    pub const VARIANT: u8 = 0xBB;
    /// Reply to read configuration `74h`.
    pub const CONFIG: u8 = 0xF4;
    /// Reply to write configuration `77h`.
    pub const CONFIG_WRITTEN: u8 = 0xF7;
}

/// Result byte of `A0h`: the mode was switched.
pub const MODE_SWITCHED: u8 = 0x00;
/// First data byte of `BBh`/`F7h`: accepted.
const ACCEPTED: u8 = 0x01;

/// A decoded reply telegram.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reply {
    /// `A0h`: result of a mode switch.
    ModeSwitch {
        /// Result byte: `00h` switched, `01h` refused (wrong password or device fault), other
        /// values are device specific.
        result: u8,
        /// Status byte.
        status: u8,
    },
    /// `BBh`: result of a variant change, with the variant now active.
    Variant {
        /// Whether the requested variant was accepted.
        accepted: bool,
        /// Active scan angle in degrees.
        angle_deg: u16,
        /// Active angular resolution in hundredths of a degree.
        resolution_cdeg: u16,
        /// Status byte.
        status: u8,
    },
    /// `B1h`: the status block.
    Status(StatusReply),
    /// `F4h`: the configuration block.
    Config {
        /// The block (34 bytes, 32 on old firmware).
        block: ConfigBlock,
        /// Status byte.
        status: u8,
    },
    /// `F7h`: result of a configuration write, with the configuration now active.
    ConfigWritten {
        /// Whether the block was accepted.
        accepted: bool,
        /// The active block.
        block: ConfigBlock,
        /// Status byte.
        status: u8,
    },
    /// `90h`: the power-on message with the type and firmware string.
    PowerOn {
        /// ASCII, e.g. `LMS200;301063;V02.06 `.
        text: Vec<u8, MAX_TEXT_LEN>,
        /// Status byte.
        status: u8,
    },
    /// `BAh`: the type string.
    Type {
        /// ASCII, e.g. `LMS200;S18063;V02.19 `.
        text: Vec<u8, MAX_TEXT_LEN>,
        /// Status byte.
        status: u8,
    },
    /// `91h`: the reset was accepted; `90h` follows.
    ResetAck {
        /// Status byte.
        status: u8,
    },
    /// `92h`: the command is not allowed now.
    Rejected {
        /// Status byte.
        status: u8,
    },
}

impl Reply {
    /// Decodes a reply telegram.
    ///
    /// # Errors
    /// [`Error::Truncated`]/[`Error::BadLength`] from [`Telegram::check_len`];
    /// [`Error::WrongCode`] for `B0h` (use [`super::ScanRepr`]) and codes not listed here;
    /// [`Error::Malformed`] when the data do not fit the reply (wrong length, text too long).
    pub fn parse<T: AsRef<[u8]>>(telegram: &Telegram<T>) -> Result<Reply> {
        telegram.check_len()?;
        let Some(status) = telegram.status() else {
            return Err(Error::Malformed);
        };
        let data = telegram.reply_data();
        let reply = match (telegram.command(), data) {
            (code::MODE, [result]) => Reply::ModeSwitch {
                result: *result,
                status,
            },
            (code::VARIANT, [accepted, a0, a1, r0, r1]) => Reply::Variant {
                accepted: *accepted == ACCEPTED,
                angle_deg: u16::from_le_bytes([*a0, *a1]),
                resolution_cdeg: u16::from_le_bytes([*r0, *r1]),
                status,
            },
            (code::STATUS, data) => Reply::Status(StatusReply::parse_data(data, status)?),
            (code::CONFIG, block) => Reply::Config {
                block: ConfigBlock::from_bytes(block)?,
                status,
            },
            (code::CONFIG_WRITTEN, [accepted, block @ ..]) => Reply::ConfigWritten {
                accepted: *accepted == ACCEPTED,
                block: ConfigBlock::from_bytes(block)?,
                status,
            },
            (code::POWER_ON, text) => Reply::PowerOn {
                text: text_of(text)?,
                status,
            },
            (code::TYPE, text) => Reply::Type {
                text: text_of(text)?,
                status,
            },
            (code::RESET_ACK, []) => Reply::ResetAck { status },
            (code::REJECTED, []) => Reply::Rejected { status },
            (
                code::MODE
                | code::VARIANT
                | code::CONFIG_WRITTEN
                | code::RESET_ACK
                | code::REJECTED,
                _,
            ) => return Err(Error::Malformed),
            _ => return Err(Error::WrongCode),
        };
        Ok(reply)
    }

    /// The reply code.
    pub fn code(&self) -> u8 {
        match self {
            Reply::ModeSwitch { .. } => code::MODE,
            Reply::Variant { .. } => code::VARIANT,
            Reply::Status(_) => code::STATUS,
            Reply::Config { .. } => code::CONFIG,
            Reply::ConfigWritten { .. } => code::CONFIG_WRITTEN,
            Reply::PowerOn { .. } => code::POWER_ON,
            Reply::Type { .. } => code::TYPE,
            Reply::ResetAck { .. } => code::RESET_ACK,
            Reply::Rejected { .. } => code::REJECTED,
        }
    }

    /// The status byte.
    pub fn status(&self) -> u8 {
        match self {
            Reply::Status(reply) => reply.status,
            Reply::ModeSwitch { status, .. }
            | Reply::Variant { status, .. }
            | Reply::Config { status, .. }
            | Reply::ConfigWritten { status, .. }
            | Reply::PowerOn { status, .. }
            | Reply::Type { status, .. }
            | Reply::ResetAck { status }
            | Reply::Rejected { status } => *status,
        }
    }

    /// Number of data bytes between the reply code and the status byte.
    fn body_len(&self) -> usize {
        match self {
            Reply::ModeSwitch { .. } => 1,
            Reply::Variant { .. } => 5,
            Reply::Status(_) => StatusReply::DATA_LEN,
            Reply::Config { block, .. } => block.as_bytes().len(),
            Reply::ConfigWritten { block, .. } => 1 + block.as_bytes().len(),
            Reply::PowerOn { text, .. } | Reply::Type { text, .. } => text.len(),
            Reply::ResetAck { .. } | Reply::Rejected { .. } => 0,
        }
    }

    /// Size in bytes of the telegram [`Self::emit`] writes.
    pub fn buffer_len(&self) -> usize {
        telegram_len(self.body_len() as u16 + 2)
    }

    /// Writes the reply telegram (address `80h`, checksum included).
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] when the buffer is shorter than [`Self::buffer_len`].
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, telegram: &mut Telegram<T>) -> Result<()> {
        if telegram.as_ref().len() < self.buffer_len() {
            return Err(Error::BufferTooSmall);
        }
        let body_len = self.body_len();
        telegram.set_header(REPLY_ADDRESS, self.code(), body_len + 1);
        let data = telegram.data_mut();
        let (body, status) = data.split_at_mut(body_len);
        status[0] = self.status();
        match self {
            Reply::ModeSwitch { result, .. } => body[0] = *result,
            Reply::Variant {
                accepted,
                angle_deg,
                resolution_cdeg,
                ..
            } => {
                body[0] = if *accepted { ACCEPTED } else { 0 };
                body[1..3].copy_from_slice(&angle_deg.to_le_bytes());
                body[3..5].copy_from_slice(&resolution_cdeg.to_le_bytes());
            }
            Reply::Status(reply) => reply.emit_data(body),
            Reply::Config { block, .. } => body.copy_from_slice(block.as_bytes()),
            Reply::ConfigWritten {
                accepted, block, ..
            } => {
                body[0] = if *accepted { ACCEPTED } else { 0 };
                body[1..].copy_from_slice(block.as_bytes());
            }
            Reply::PowerOn { text, .. } | Reply::Type { text, .. } => body.copy_from_slice(text),
            Reply::ResetAck { .. } | Reply::Rejected { .. } => {}
        }
        telegram.fill_crc();
        Ok(())
    }
}

/// The longest reply built here (`B1h`), in bytes.
pub const MAX_REPLY_LEN: usize = telegram_len(StatusReply::DATA_LEN as u16 + 2);

const _: () = assert!(MAX_REPLY_LEN >= telegram_len(CONFIG_LEN as u16 + 3));

fn text_of(bytes: &[u8]) -> Result<Vec<u8, MAX_TEXT_LEN>> {
    Vec::from_slice(bytes).map_err(|_| Error::Malformed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sick::test_data::{hex, public_examples};

    /// `BBh` accepted 180°/0.5°, status 10h (§11).
    static TELEGRAM_BYTES: [u8; 13] = [
        0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10, 0x03, 0x9D,
    ];

    fn variant() -> Reply {
        Reply::Variant {
            accepted: true,
            angle_deg: 180,
            resolution_cdeg: 50,
            status: 0x10,
        }
    }

    fn emit_vec(reply: &Reply) -> std::vec::Vec<u8> {
        let mut bytes = vec![0u8; reply.buffer_len()];
        reply
            .emit(&mut Telegram::new_unchecked(&mut bytes[..]))
            .unwrap();
        bytes
    }

    #[test]
    fn test_deconstruct() {
        let telegram = Telegram::new_checked(&TELEGRAM_BYTES[..]).unwrap();
        assert_eq!(telegram.command(), code::VARIANT);
        assert_eq!(telegram.reply_data(), &[0x01, 0xB4, 0x00, 0x32, 0x00]);
        assert_eq!(telegram.status(), Some(0x10));
    }

    #[test]
    fn test_construct() {
        assert_eq!(emit_vec(&variant()), TELEGRAM_BYTES);
    }

    #[test]
    fn test_parse() {
        let telegram = Telegram::new_checked(&TELEGRAM_BYTES[..]).unwrap();
        assert_eq!(Reply::parse(&telegram), Ok(variant()));
    }

    #[test]
    fn test_emit() {
        let block = ConfigBlock::from_bytes(&[3u8; 34]).unwrap();
        let replies = [
            Reply::ModeSwitch {
                result: 0,
                status: 0x10,
            },
            Reply::Config {
                block,
                status: 0x10,
            },
            Reply::ConfigWritten {
                accepted: true,
                block,
                status: 0x11,
            },
            Reply::Type {
                text: Vec::from_slice(b"LMS200;S18063;V02.19 ").unwrap(),
                status: 0x10,
            },
            Reply::ResetAck { status: 0x10 },
            Reply::Rejected { status: 0x10 },
            variant(),
        ];
        for reply in replies {
            let bytes = emit_vec(&reply);
            let telegram = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(telegram.check_crc(), Ok(()));
            assert_eq!(Reply::parse(&telegram), Ok(reply));
        }
    }

    #[test]
    fn example_replies() {
        let cases = [
            (
                "02 80 03 00 A0 00 10 16 0A",
                Reply::ModeSwitch {
                    result: 0,
                    status: 0x10,
                },
            ),
            ("02 80 02 00 92 10 7F 33", Reply::Rejected { status: 0x10 }),
            ("02 80 02 00 91 10 79 30", Reply::ResetAck { status: 0x10 }),
        ];
        for (text, reply) in cases {
            let bytes = hex(text);
            let telegram = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(Reply::parse(&telegram), Ok(reply.clone()), "{text}");
            assert_eq!(emit_vec(&reply), bytes);
        }
    }

    #[test]
    fn power_on_quick_manual_example() {
        let bytes = hex(
            "02 81 17 00 90 4C 4D 53 32 30 30 3B 33 30 31 30 36 33 3B 56 30 32 2E 30 36 20 13 64 5A",
        );
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(telegram.check_crc(), Ok(()));
        let reply = Reply::parse(&telegram).unwrap();
        let Reply::PowerOn { text, status } = &reply else {
            panic!("{reply:?}")
        };
        assert_eq!(&text[..], b"LMS200;301063;V02.06 ");
        assert_eq!(*status, 0x13);
        // Our emitter answers as address 80h; the example came from address 81h.
        let mut emitted = emit_vec(&reply);
        let mut view = Telegram::new_unchecked(&mut emitted[..]);
        view.set_address(0x81);
        view.fill_crc();
        assert_eq!(emitted, bytes);
    }

    #[test]
    fn public_example_replies() {
        let Some(examples) = public_examples("public_example_replies") else {
            return;
        };
        let mut checked = 0;
        for (name, bytes) in examples.iter().filter(|(name, _)| name.starts_with("rsp_")) {
            let telegram = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(telegram.check_crc(), Ok(()), "{name}");
            if telegram.command() == code::SCAN {
                let scan = crate::sick::ScanRepr::parse(&telegram).unwrap();
                let mut emitted = vec![0u8; scan.buffer_len()];
                scan.emit(&mut Telegram::new_unchecked(&mut emitted[..]))
                    .unwrap();
                assert_eq!(emitted, *bytes, "{name}");
                checked += 1;
                continue;
            }
            let reply = Reply::parse(&telegram).unwrap();
            let mut emitted = emit_vec(&reply);
            let mut view = Telegram::new_unchecked(&mut emitted[..]);
            view.set_address(telegram.address());
            view.fill_crc();
            assert_eq!(emitted, *bytes, "{name}");
            checked += 1;
        }
        assert_eq!(checked, 6);
    }

    #[test]
    fn real_session_replies() {
        let Some(path) = datasets::require(
            "benchmark/lms200/2017_Aug_04_23-25-00.lms-to-host.bin",
            "real_session_replies",
        ) else {
            return;
        };
        let bytes = std::fs::read(path).unwrap();
        // The session opens with A0, BA, B1 (status), F4 (config) and F7 replies.
        let mut receiver = crate::sick::Receiver::new();
        let mut seen = std::vec::Vec::new();
        for (i, &byte) in bytes.iter().enumerate() {
            if let Some(crate::sick::Event::Telegram { telegram, .. }) =
                receiver.push(byte, i as u64 * 260)
            {
                if telegram.command() == code::SCAN {
                    continue;
                }
                let reply = Reply::parse(&telegram).unwrap();
                if telegram.command() != code::STATUS {
                    assert_eq!(emit_vec(&reply), telegram.as_bytes(), "{reply:?}");
                }
                seen.push(reply);
            }
        }
        let config = seen.iter().find_map(|r| match r {
            Reply::Config { block, .. } => Some(*block),
            _ => None,
        });
        let config = config.unwrap();
        assert_eq!(config.as_bytes().len(), 34);
        assert_eq!(config.measuring_mode(), crate::sick::MeasuringMode(0x04));
        assert_eq!(config.unit(), Some(protocol::RangeUnit::Mm));
        assert!(
            seen.iter()
                .any(|r| matches!(r, Reply::ConfigWritten { accepted: true, .. }))
        );
        let status = seen.iter().find_map(|r| match r {
            Reply::Status(s) => Some(s.clone()),
            _ => None,
        });
        let status = status.unwrap();
        assert_eq!((status.angle_deg, status.resolution_cdeg), (180, 50));
        assert_eq!(status.baud(), Some(crate::sick::LmsBaud::B38400));
        assert!(
            seen.iter().any(
                |r| matches!(r, Reply::Type { text, .. } if text.starts_with(b"LMS200;S18063"))
            )
        );
    }

    #[test]
    fn test_impossible_len() {
        for text in [
            "02 80 02 00 A0 10 00 00",       // A0 without a result byte
            "02 80 04 00 BB 01 B4 10 00 00", // BB too short
            "02 80 03 00 91 00 10 00 00",    // 91 with data
        ] {
            let bytes = hex(text);
            let telegram = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(Reply::parse(&telegram), Err(Error::Malformed), "{text}");
        }
        let bytes = hex("02 80 04 00 F4 00 00 10 00 00");
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(Reply::parse(&telegram), Err(Error::Malformed));
        let bytes = hex("02 80 02 00 C4 10 00 00");
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(Reply::parse(&telegram), Err(Error::WrongCode));
        let bytes = hex("02 00 01 00 31 15 12");
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(Reply::parse(&telegram), Err(Error::Malformed));
    }
}
