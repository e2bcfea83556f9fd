//! Host → LMS2xx requests used by the bring-up and by sensor emulators (protocol notes §6;
//! Telegram Listing §7): reset `10h`, mode switch `20h` (installation mode, streaming on/off,
//! baud rate), one scan `30h 01h`, status `31h`, type `3Ah`, variant `3Bh`, read and write
//! configuration `74h`/`77h`.
//!
//! [`Request::emit`] builds the telegram (address `00h`, checksum included);
//! [`Request::parse`] decodes one, for the emulator side. The reply to a request carries
//! [`Request::reply_code`].

use super::config::ConfigBlock;
use super::error::{Error, Result};
use super::telegram::{HOST_ADDRESS, Telegram, telegram_len};

/// Default password of the installation mode.
pub const DEFAULT_PASSWORD: [u8; 8] = *b"SICK_LMS";
/// The longest request built here (`77h` with a 34-byte block), in bytes.
pub const MAX_REQUEST_LEN: usize = 41;

mod code {
    pub const RESET: u8 = 0x10;
    pub const MODE: u8 = 0x20;
    pub const SCAN: u8 = 0x30;
    pub const STATUS: u8 = 0x31;
    pub const TYPE: u8 = 0x3A;
    pub const VARIANT: u8 = 0x3B;
    pub const READ_CONFIG: u8 = 0x74;
    pub const WRITE_CONFIG: u8 = 0x77;

    /// Sub-command of `30h`: one complete scan.
    pub const SCAN_ONE: u8 = 0x01;

    /// Sub-commands of `20h`.
    pub const MODE_INSTALLATION: u8 = 0x00;
    pub const MODE_STREAM: u8 = 0x24;
    pub const MODE_ON_REQUEST: u8 = 0x25;

    /// Reply code of `10h` (not `90h`, which is the power-on message).
    pub const RESET_REPLY: u8 = 0x91;
    pub const REPLY_BIT: u8 = 0x80;
}

/// A baud rate the LMS2xx can talk at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LmsBaud {
    /// 9 600 Bd, the power-on default.
    B9600,
    /// 19 200 Bd.
    B19200,
    /// 38 400 Bd.
    B38400,
    /// 500 000 Bd (RS-422 only).
    B500000,
}

impl LmsBaud {
    /// Every rate, in the order a baud search tries them after the preferred one.
    pub const ALL: [LmsBaud; 4] = [
        LmsBaud::B9600,
        LmsBaud::B19200,
        LmsBaud::B38400,
        LmsBaud::B500000,
    ];

    /// The rate in baud.
    pub const fn baud(self) -> u32 {
        match self {
            LmsBaud::B9600 => 9_600,
            LmsBaud::B19200 => 19_200,
            LmsBaud::B38400 => 38_400,
            LmsBaud::B500000 => 500_000,
        }
    }

    /// The rate for `baud`, if the LMS supports it.
    pub const fn from_baud(baud: u32) -> Option<LmsBaud> {
        match baud {
            9_600 => Some(LmsBaud::B9600),
            19_200 => Some(LmsBaud::B19200),
            38_400 => Some(LmsBaud::B38400),
            500_000 => Some(LmsBaud::B500000),
            _ => None,
        }
    }

    /// The sub-command of `20h` that selects this rate.
    pub const fn mode_byte(self) -> u8 {
        match self {
            LmsBaud::B9600 => 0x42,
            LmsBaud::B19200 => 0x41,
            LmsBaud::B38400 => 0x40,
            LmsBaud::B500000 => 0x48,
        }
    }

    /// The rate selected by the `20h` sub-command `byte`.
    pub const fn from_mode_byte(byte: u8) -> Option<LmsBaud> {
        match byte {
            0x42 => Some(LmsBaud::B9600),
            0x41 => Some(LmsBaud::B19200),
            0x40 => Some(LmsBaud::B38400),
            0x48 => Some(LmsBaud::B500000),
            _ => None,
        }
    }

    /// The code the status reply `B1h` reports for this rate.
    pub const fn status_code(self) -> u16 {
        match self {
            LmsBaud::B9600 => 0x8067,
            LmsBaud::B19200 => 0x8033,
            LmsBaud::B38400 => 0x8019,
            LmsBaud::B500000 => 0x8001,
        }
    }

    /// The rate for a `B1h` baud code.
    pub const fn from_status_code(code: u16) -> Option<LmsBaud> {
        match code {
            0x8067 => Some(LmsBaud::B9600),
            0x8033 => Some(LmsBaud::B19200),
            0x8019 => Some(LmsBaud::B38400),
            0x8001 => Some(LmsBaud::B500000),
            _ => None,
        }
    }
}

/// The operating modes of command `20h` this code uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OperatingMode {
    /// `20 00` + password: installation mode, needed before writing the configuration.
    Installation {
        /// The 8-byte password ([`DEFAULT_PASSWORD`] on delivery).
        password: [u8; 8],
    },
    /// `20 24`: stream every scan continuously ("start streaming").
    StreamAll,
    /// `20 25`: measured values only on request ("stop streaming"), the power-on mode.
    OnRequest,
    /// `20 40`/`41`/`42`/`48`: switch the baud rate (the reply comes at the old rate).
    Baud(LmsBaud),
}

impl OperatingMode {
    /// The sub-command byte.
    pub const fn mode_byte(&self) -> u8 {
        match self {
            OperatingMode::Installation { .. } => code::MODE_INSTALLATION,
            OperatingMode::StreamAll => code::MODE_STREAM,
            OperatingMode::OnRequest => code::MODE_ON_REQUEST,
            OperatingMode::Baud(baud) => baud.mode_byte(),
        }
    }
}

/// A request from the host to the LMS.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Request {
    /// `10h`: software reset (reply `91h`, then `90h`).
    Reset,
    /// `20h`: switch the operating mode (reply `A0h`).
    SetMode(OperatingMode),
    /// `30h 01h`: send one complete scan now (reply `B0h`).
    OneScan,
    /// `31h`: status (reply `B1h`).
    Status,
    /// `3Ah`: type string (reply `BAh`).
    Type,
    /// `3Bh`: scan angle and angular resolution (reply `BBh`).
    SetVariant {
        /// Scan angle, 100 or 180.
        angle_deg: u16,
        /// Angular resolution in hundredths of a degree: 25, 50 or 100.
        resolution_cdeg: u16,
    },
    /// `74h`: read the configuration (reply `F4h`).
    ReadConfig,
    /// `77h`: write the configuration (reply `F7h`; needs installation mode).
    WriteConfig(ConfigBlock),
}

impl Request {
    /// The command byte.
    pub const fn command(&self) -> u8 {
        match self {
            Request::Reset => code::RESET,
            Request::SetMode(_) => code::MODE,
            Request::OneScan => code::SCAN,
            Request::Status => code::STATUS,
            Request::Type => code::TYPE,
            Request::SetVariant { .. } => code::VARIANT,
            Request::ReadConfig => code::READ_CONFIG,
            Request::WriteConfig(_) => code::WRITE_CONFIG,
        }
    }

    /// The code of the reply the LMS sends to this request.
    pub const fn reply_code(&self) -> u8 {
        match self {
            Request::Reset => code::RESET_REPLY,
            other => other.command() | code::REPLY_BIT,
        }
    }

    /// Number of data bytes after the command byte.
    fn data_len(&self) -> usize {
        match self {
            Request::Reset | Request::Status | Request::Type | Request::ReadConfig => 0,
            Request::SetMode(OperatingMode::Installation { .. }) => 9,
            Request::SetMode(_) | Request::OneScan => 1,
            Request::SetVariant { .. } => 4,
            Request::WriteConfig(block) => block.as_bytes().len(),
        }
    }

    /// Size in bytes of the telegram [`Self::emit`] writes.
    pub fn buffer_len(&self) -> usize {
        telegram_len(self.data_len() as u16 + 1)
    }

    /// Writes the request telegram (address `00h`, checksum included).
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] when the buffer is shorter than [`Self::buffer_len`].
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, telegram: &mut Telegram<T>) -> Result<()> {
        if telegram.as_ref().len() < self.buffer_len() {
            return Err(Error::BufferTooSmall);
        }
        telegram.set_header(HOST_ADDRESS, self.command(), self.data_len());
        let data = telegram.data_mut();
        match self {
            Request::Reset | Request::Status | Request::Type | Request::ReadConfig => {}
            Request::SetMode(mode) => {
                data[0] = mode.mode_byte();
                if let OperatingMode::Installation { password } = mode {
                    data[1..9].copy_from_slice(password);
                }
            }
            Request::OneScan => data[0] = code::SCAN_ONE,
            Request::SetVariant {
                angle_deg,
                resolution_cdeg,
            } => {
                data[0..2].copy_from_slice(&angle_deg.to_le_bytes());
                data[2..4].copy_from_slice(&resolution_cdeg.to_le_bytes());
            }
            Request::WriteConfig(block) => data.copy_from_slice(block.as_bytes()),
        }
        telegram.fill_crc();
        Ok(())
    }

    /// The request as bytes ready to send.
    pub fn to_bytes(&self) -> RequestBytes {
        let mut bytes = RequestBytes {
            buf: [0; MAX_REQUEST_LEN],
            len: 0,
        };
        let len = self.buffer_len();
        // `buffer_len` is at most MAX_REQUEST_LEN (the 34-byte `77h`), so emit cannot fail.
        if self
            .emit(&mut Telegram::new_unchecked(&mut bytes.buf[..]))
            .is_ok()
        {
            bytes.len = len as u8;
        }
        bytes
    }

    /// Decodes a request telegram (the emulator side). The checksum is not verified.
    ///
    /// # Errors
    /// [`Error::Truncated`]/[`Error::BadLength`] from [`Telegram::check_len`];
    /// [`Error::Unsupported`] for a command or mode this code does not build;
    /// [`Error::Malformed`] when the data length does not fit the command.
    pub fn parse<T: AsRef<[u8]>>(telegram: &Telegram<T>) -> Result<Request> {
        telegram.check_len()?;
        let data = telegram.data();
        let request = match (telegram.command(), data) {
            (code::RESET, []) => Request::Reset,
            (code::STATUS, []) => Request::Status,
            (code::TYPE, []) => Request::Type,
            (code::READ_CONFIG, []) => Request::ReadConfig,
            (code::SCAN, [code::SCAN_ONE]) => Request::OneScan,
            (code::VARIANT, [a0, a1, r0, r1]) => Request::SetVariant {
                angle_deg: u16::from_le_bytes([*a0, *a1]),
                resolution_cdeg: u16::from_le_bytes([*r0, *r1]),
            },
            (code::WRITE_CONFIG, block) => Request::WriteConfig(ConfigBlock::from_bytes(block)?),
            (code::MODE, [code::MODE_INSTALLATION, password @ ..]) => {
                let password = password.try_into().map_err(|_| Error::Malformed)?;
                Request::SetMode(OperatingMode::Installation { password })
            }
            (code::MODE, [code::MODE_STREAM]) => Request::SetMode(OperatingMode::StreamAll),
            (code::MODE, [code::MODE_ON_REQUEST]) => Request::SetMode(OperatingMode::OnRequest),
            (code::MODE, [byte]) => match LmsBaud::from_mode_byte(*byte) {
                Some(baud) => Request::SetMode(OperatingMode::Baud(baud)),
                None => return Err(Error::Unsupported),
            },
            (
                code::RESET
                | code::STATUS
                | code::TYPE
                | code::READ_CONFIG
                | code::SCAN
                | code::VARIANT,
                _,
            ) => return Err(Error::Malformed),
            _ => return Err(Error::Unsupported),
        };
        Ok(request)
    }
}

/// A request telegram in a fixed buffer, as [`Request::to_bytes`] builds it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RequestBytes {
    buf: [u8; MAX_REQUEST_LEN],
    len: u8,
}

impl RequestBytes {
    /// The telegram's bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf[..usize::from(self.len)]
    }
}

impl AsRef<[u8]> for RequestBytes {
    fn as_ref(&self) -> &[u8] {
        self.as_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sick::test_data::{hex, public_examples};

    /// Installation mode with the default password (§11).
    static TELEGRAM_BYTES: [u8; 16] = [
        0x02, 0x00, 0x0A, 0x00, 0x20, 0x00, 0x53, 0x49, 0x43, 0x4B, 0x5F, 0x4C, 0x4D, 0x53, 0xBE,
        0xC5,
    ];

    const INSTALLATION: Request = Request::SetMode(OperatingMode::Installation {
        password: DEFAULT_PASSWORD,
    });

    fn golden() -> Vec<(Request, &'static str)> {
        let variant = |angle_deg, resolution_cdeg| Request::SetVariant {
            angle_deg,
            resolution_cdeg,
        };
        vec![
            (Request::Status, "02 00 01 00 31 15 12"),
            (Request::Type, "02 00 01 00 3A 1E 12"),
            (Request::ReadConfig, "02 00 01 00 74 50 12"),
            (
                INSTALLATION,
                "02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 53 BE C5",
            ),
            (
                Request::SetMode(OperatingMode::Baud(LmsBaud::B9600)),
                "02 00 02 00 20 42 52 08",
            ),
            (
                Request::SetMode(OperatingMode::Baud(LmsBaud::B19200)),
                "02 00 02 00 20 41 51 08",
            ),
            (
                Request::SetMode(OperatingMode::Baud(LmsBaud::B38400)),
                "02 00 02 00 20 40 50 08",
            ),
            (
                Request::SetMode(OperatingMode::Baud(LmsBaud::B500000)),
                "02 00 02 00 20 48 58 08",
            ),
            (variant(180, 100), "02 00 05 00 3B B4 00 64 00 97 49"),
            (variant(180, 50), "02 00 05 00 3B B4 00 32 00 3B 1F"),
            (variant(100, 25), "02 00 05 00 3B 64 00 19 00 E7 72"),
            (variant(100, 50), "02 00 05 00 3B 64 00 32 00 B1 59"),
            (variant(100, 100), "02 00 05 00 3B 64 00 64 00 1D 0F"),
            (
                Request::SetMode(OperatingMode::StreamAll),
                "02 00 02 00 20 24 34 08",
            ),
            (
                Request::SetMode(OperatingMode::OnRequest),
                "02 00 02 00 20 25 35 08",
            ),
            (Request::OneScan, "02 00 02 00 30 01 31 18"),
            (Request::Reset, "02 00 01 00 10 34 12"),
        ]
    }

    #[test]
    fn test_deconstruct() {
        let telegram = Telegram::new_checked(&TELEGRAM_BYTES[..]).unwrap();
        assert_eq!(telegram.command(), 0x20);
        assert_eq!(telegram.data()[0], 0x00);
        assert_eq!(&telegram.data()[1..], b"SICK_LMS");
    }

    #[test]
    fn test_construct() {
        let mut bytes = [0u8; 16];
        INSTALLATION
            .emit(&mut Telegram::new_unchecked(&mut bytes[..]))
            .unwrap();
        assert_eq!(bytes, TELEGRAM_BYTES);
    }

    #[test]
    fn test_parse() {
        let telegram = Telegram::new_checked(&TELEGRAM_BYTES[..]).unwrap();
        assert_eq!(Request::parse(&telegram), Ok(INSTALLATION));
    }

    #[test]
    fn test_emit() {
        for (request, text) in golden() {
            assert_eq!(request.to_bytes().as_bytes(), &hex(text)[..], "{request:?}");
            assert_eq!(request.buffer_len(), hex(text).len());
            let bytes = hex(text);
            let telegram = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(Request::parse(&telegram), Ok(request), "{text}");
        }
    }

    #[test]
    fn write_config_round_trip() {
        let block = ConfigBlock::from_bytes(&[7u8; 34]).unwrap();
        let request = Request::WriteConfig(block);
        let bytes = request.to_bytes();
        assert_eq!(bytes.as_bytes().len(), MAX_REQUEST_LEN);
        let telegram = Telegram::new_checked(bytes.as_bytes()).unwrap();
        assert_eq!(telegram.check_crc(), Ok(()));
        assert_eq!(Request::parse(&telegram), Ok(request));
        assert_eq!(request.reply_code(), 0xF7);
    }

    #[test]
    fn reply_codes() {
        assert_eq!(Request::Status.reply_code(), 0xB1);
        assert_eq!(Request::Reset.reply_code(), 0x91);
        assert_eq!(
            Request::SetMode(OperatingMode::StreamAll).reply_code(),
            0xA0
        );
        assert_eq!(Request::ReadConfig.reply_code(), 0xF4);
    }

    #[test]
    fn public_example_requests() {
        let Some(examples) = public_examples("public_example_requests") else {
            return;
        };
        let mut parsed = 0;
        for (name, bytes) in examples.iter().filter(|(name, _)| name.starts_with("cmd_")) {
            let telegram = Telegram::new_checked(&bytes[..]).unwrap();
            assert_eq!(telegram.check_crc(), Ok(()), "{name}");
            match Request::parse(&telegram) {
                Ok(request) => {
                    assert_eq!(request.to_bytes().as_bytes(), &bytes[..], "{name}");
                    parsed += 1;
                }
                // Sub-range streaming, test password, field and segment commands are not built.
                Err(Error::Unsupported) => {}
                Err(e) => panic!("{name}: {e}"),
            }
        }
        assert_eq!(parsed, 16);
    }

    #[test]
    fn test_impossible_len() {
        let bytes = hex("02 00 03 00 31 00 00 00 00");
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(Request::parse(&telegram), Err(Error::Malformed));
        let bytes = hex("02 00 05 00 20 00 53 49 43 00 00");
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(Request::parse(&telegram), Err(Error::Malformed));
        let bytes = hex("02 00 02 00 20 99 00 00");
        let telegram = Telegram::new_checked(&bytes[..]).unwrap();
        assert_eq!(Request::parse(&telegram), Err(Error::Unsupported));
        let mut small = [0u8; 10];
        let result = INSTALLATION.emit(&mut Telegram::new_unchecked(&mut small[..]));
        assert_eq!(result, Err(Error::BufferTooSmall));
    }

    #[test]
    fn baud_codes_round_trip() {
        for baud in LmsBaud::ALL {
            assert_eq!(LmsBaud::from_baud(baud.baud()), Some(baud));
            assert_eq!(LmsBaud::from_mode_byte(baud.mode_byte()), Some(baud));
            assert_eq!(LmsBaud::from_status_code(baud.status_code()), Some(baud));
        }
        assert_eq!(LmsBaud::from_baud(115_200), None);
    }
}
