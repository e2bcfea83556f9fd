//! A scripted LMS200 for the bring-up tests: it decodes requests with [`Request::parse`] and
//! answers with bytes built by [`Reply::emit`] and [`ScanRepr::emit`], at its own baud rate
//! (a host at another rate hears nothing and is not heard).

use heapless::Vec as HVec;
use protocol::RangeUnit;

use super::command::{DEFAULT_PASSWORD, LmsBaud, OperatingMode, Request};
use super::config::ConfigBlock;
use super::reply::Reply;
use super::scan::ScanRepr;
use super::status_reply::{OPERATING_MODE_ON_REQUEST, OPERATING_MODE_STREAMING, StatusReply};
use super::telegram::{ACK, NAK, Telegram};

/// The fake sensor's state and script.
pub(crate) struct FakeLms {
    pub powered: bool,
    pub baud: u32,
    pub permanent_baud: bool,
    pub streaming: bool,
    pub installation: bool,
    pub config: ConfigBlock,
    pub angle_deg: u16,
    pub resolution_cdeg: u16,
    pub refuse_variant: bool,
    /// Answer the next requests with NAK.
    pub nak_next: u32,
    /// Ignore the next `n` requests with this command byte.
    pub ignore_code: Option<(u8, u32)>,
    pub naks_sent: u32,
    /// Requests not answered (wrong rate, powered off, scripted).
    pub ignored: u32,
    pub eeprom_writes: u32,
    /// Every request understood, in order.
    pub log: Vec<Request>,
}

impl FakeLms {
    /// A sensor as delivered: 9 600 Bd, not streaming, cm, default mode, 180° at 1°.
    pub fn new() -> FakeLms {
        let mut block = [0u8; 34];
        block[2] = 0x46;
        FakeLms {
            powered: true,
            baud: 9_600,
            permanent_baud: false,
            streaming: false,
            installation: false,
            config: ConfigBlock::from_bytes(&block).unwrap(),
            angle_deg: 180,
            resolution_cdeg: 100,
            refuse_variant: false,
            nak_next: 0,
            ignore_code: None,
            naks_sent: 0,
            ignored: 0,
            eeprom_writes: 0,
            log: Vec::new(),
        }
    }

    /// Resets as after a power cycle; returns the `90h` message it sends.
    pub fn power_on(&mut self) -> Vec<u8> {
        if !self.permanent_baud {
            self.baud = 9_600;
        }
        self.streaming = false;
        self.installation = false;
        let text = HVec::from_slice(b"LMS200;301063;V02.06 ").unwrap();
        emit(&Reply::PowerOn { text, status: 0x10 })
    }

    /// `n` scans if streaming and heard at `host_baud`.
    pub fn stream(&self, n: usize, host_baud: u32) -> Vec<u8> {
        if !self.powered || !self.streaming || host_baud != self.baud {
            return Vec::new();
        }
        (0..n).flat_map(|_| self.scan()).collect()
    }

    fn scan(&self) -> Vec<u8> {
        let n = self.angle_deg * 100 / self.resolution_cdeg + 1;
        let scan = ScanRepr {
            unit: self.config.unit().unwrap_or(RangeUnit::Cm),
            partial_raster: None,
            values: (0..n).map(|i| 1000 + i).collect(),
            indices: None,
            status: 0x10,
        };
        let mut bytes = vec![0u8; scan.buffer_len()];
        scan.emit(&mut Telegram::new_unchecked(&mut bytes[..]))
            .unwrap();
        bytes
    }

    /// Takes a request sent at `host_baud`; returns what the sensor sends back.
    pub fn receive(&mut self, bytes: &[u8], host_baud: u32) -> Vec<u8> {
        if !self.powered || host_baud != self.baud {
            self.ignored += 1;
            return Vec::new();
        }
        let Ok(telegram) = Telegram::new_checked(bytes) else {
            return Vec::new();
        };
        if telegram.check_crc().is_err() {
            return vec![NAK];
        }
        let mut out = Vec::new();
        if self.streaming {
            // A scan already in flight.
            out.extend(self.scan());
        }
        let Ok(request) = Request::parse(&telegram) else {
            out.push(ACK);
            out.extend(emit(&Reply::Rejected { status: 0x10 }));
            return out;
        };
        self.log.push(request);
        if self.nak_next > 0 {
            self.nak_next -= 1;
            self.naks_sent += 1;
            out.push(NAK);
            return out;
        }
        if let Some((code, n)) = self.ignore_code {
            if code == request.command() && n > 0 {
                self.ignore_code = Some((code, n - 1));
                self.ignored += 1;
                return out;
            }
        }
        out.push(ACK);
        let mut new_baud = None;
        let reply = match request {
            Request::SetMode(mode) => {
                let result = match mode {
                    OperatingMode::Installation { password } => {
                        self.installation = password == DEFAULT_PASSWORD;
                        u8::from(!self.installation)
                    }
                    OperatingMode::OnRequest => {
                        self.streaming = false;
                        self.installation = false;
                        0
                    }
                    OperatingMode::StreamAll => {
                        self.streaming = true;
                        0
                    }
                    OperatingMode::Baud(baud) => {
                        new_baud = Some(baud.baud());
                        0
                    }
                };
                Some(Reply::ModeSwitch {
                    result,
                    status: 0x10,
                })
            }
            Request::Status => Some(Reply::Status(self.status())),
            Request::Type => Some(Reply::Type {
                text: HVec::from_slice(b"LMS200;301063;V02.06 ").unwrap(),
                status: 0x10,
            }),
            Request::ReadConfig => Some(Reply::Config {
                block: self.config,
                status: 0x10,
            }),
            Request::WriteConfig(block) => {
                if self.installation {
                    self.config = block;
                    self.eeprom_writes += 1;
                    Some(Reply::ConfigWritten {
                        accepted: true,
                        block,
                        status: 0x10,
                    })
                } else {
                    Some(Reply::Rejected { status: 0x10 })
                }
            }
            Request::SetVariant {
                angle_deg,
                resolution_cdeg,
            } => {
                let supported = matches!(
                    (angle_deg, resolution_cdeg),
                    (180, 100) | (180, 50) | (100, 100) | (100, 50) | (100, 25)
                );
                let accepted = supported && !self.refuse_variant;
                if accepted {
                    self.angle_deg = angle_deg;
                    self.resolution_cdeg = resolution_cdeg;
                }
                Some(Reply::Variant {
                    accepted,
                    angle_deg: self.angle_deg,
                    resolution_cdeg: self.resolution_cdeg,
                    status: 0x10,
                })
            }
            Request::OneScan => {
                out.extend(self.scan());
                None
            }
            Request::Reset => {
                out.extend(emit(&Reply::ResetAck { status: 0x10 }));
                let power_on = self.power_on();
                if self.baud == host_baud {
                    out.extend(power_on);
                }
                None
            }
        };
        if let Some(reply) = reply {
            out.extend(emit(&reply));
        }
        if let Some(baud) = new_baud {
            self.baud = baud;
        } else if self.streaming {
            out.extend(self.scan());
        }
        out
    }

    fn status(&self) -> StatusReply {
        let baud = LmsBaud::from_baud(self.baud).unwrap();
        StatusReply {
            version: *b"V02.06 ",
            operating_mode: if self.streaming {
                OPERATING_MODE_STREAMING
            } else {
                OPERATING_MODE_ON_REQUEST
            },
            device_status: 0,
            measuring_mode: self.config.measuring_mode(),
            angle_deg: self.angle_deg,
            resolution_cdeg: self.resolution_cdeg,
            baud_code: baud.status_code(),
            permanent_baud: self.permanent_baud,
            address: 0,
            unit_byte: self.config.as_bytes()[6],
            status: 0x10,
        }
    }
}

fn emit(reply: &Reply) -> Vec<u8> {
    let mut bytes = vec![0u8; reply.buffer_len()];
    reply
        .emit(&mut Telegram::new_unchecked(&mut bytes[..]))
        .unwrap();
    bytes
}
