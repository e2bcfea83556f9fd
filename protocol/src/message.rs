//! The high-level representation of every message, parsed from and emitted into a [`Frame`].

use core::fmt;

use serde::{Serialize, de::DeserializeOwned};

use crate::frame::{self, Frame, Header};
use crate::{
    AckMsg, ConfigureLaserCmd, GpsFixMsg, HeartbeatMsg, Kind, LogMsg, NmeaMsg, PROTOCOL_VERSION,
    PpsMsg, RequestStatusCmd, ScanMsg, SetStreamingCmd, StatusMsg, TimeSyncPingCmd,
};

/// What can be wrong with a frame's payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// The kind byte names no message this version knows.
    UnknownKind(u8),
    /// The payload does not decode as the kind's message, or has bytes left over.
    Malformed,
    /// The buffer is too small for the message.
    BufferTooSmall,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::UnknownKind(k) => write!(f, "unknown message kind 0x{k:02x}"),
            Error::Malformed => f.write_str("malformed payload"),
            Error::BufferTooSmall => f.write_str("buffer too small for the message"),
        }
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for Error {}

/// Every message of the protocol, in both directions.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(clippy::large_enum_variant)] // Scans dominate the traffic; boxing is not an option in no_std.
pub enum Message {
    /// Board → host: a laser scan.
    Scan(ScanMsg),
    /// Board → host: a GPS fix report.
    GpsFix(GpsFixMsg),
    /// Board → host: a raw NMEA sentence.
    Nmea(NmeaMsg),
    /// Board → host: status and counters.
    Status(StatusMsg),
    /// Board → host: heartbeat.
    Heartbeat(HeartbeatMsg),
    /// Board → host: log event.
    Log(LogMsg),
    /// Board → host: command acknowledgement.
    Ack(AckMsg),
    /// Board → host: a PPS edge.
    Pps(PpsMsg),
    /// Host → board: configure the laser.
    ConfigureLaser(ConfigureLaserCmd),
    /// Host → board: start or stop streaming.
    SetStreaming(SetStreamingCmd),
    /// Host → board: request status.
    RequestStatus(RequestStatusCmd),
    /// Host → board: time-sync ping.
    TimeSyncPing(TimeSyncPingCmd),
}

fn decode<T: DeserializeOwned>(payload: &[u8]) -> Result<T, Error> {
    match postcard::take_from_bytes::<T>(payload) {
        Ok((value, [])) => Ok(value),
        _ => Err(Error::Malformed),
    }
}

fn encode<T: Serialize>(value: &T, payload: &mut [u8]) -> Result<usize, Error> {
    postcard::to_slice(value, payload)
        .map(|used| used.len())
        .map_err(|_| Error::BufferTooSmall)
}

fn encoded_len<T: Serialize>(value: &T) -> usize {
    // Serialising into the size-counting flavor cannot fail for our types: they contain no
    // maps or sequences of unknown length.
    postcard::serialize_with_flavor(value, postcard::ser_flavors::Size::default())
        .unwrap_or(usize::MAX)
}

macro_rules! dispatch {
    ($self:expr, $value:ident => $body:expr) => {
        match $self {
            Message::Scan($value) => $body,
            Message::GpsFix($value) => $body,
            Message::Nmea($value) => $body,
            Message::Status($value) => $body,
            Message::Heartbeat($value) => $body,
            Message::Log($value) => $body,
            Message::Ack($value) => $body,
            Message::Pps($value) => $body,
            Message::ConfigureLaser($value) => $body,
            Message::SetStreaming($value) => $body,
            Message::RequestStatus($value) => $body,
            Message::TimeSyncPing($value) => $body,
        }
    };
}

impl Message {
    /// The kind byte this message travels under.
    pub fn kind(&self) -> Kind {
        match self {
            Message::Scan(_) => Kind::Scan,
            Message::GpsFix(_) => Kind::GpsFix,
            Message::Nmea(_) => Kind::Nmea,
            Message::Status(_) => Kind::Status,
            Message::Heartbeat(_) => Kind::Heartbeat,
            Message::Log(_) => Kind::Log,
            Message::Ack(_) => Kind::Ack,
            Message::Pps(_) => Kind::Pps,
            Message::ConfigureLaser(_) => Kind::ConfigureLaser,
            Message::SetStreaming(_) => Kind::SetStreaming,
            Message::RequestStatus(_) => Kind::RequestStatus,
            Message::TimeSyncPing(_) => Kind::TimeSyncPing,
        }
    }

    /// Parses the payload of a frame according to its kind. The caller checks the CRC and
    /// the version first (the [`crate::Decoder`] does).
    ///
    /// # Errors
    /// [`Error::UnknownKind`] for a kind this version does not know, [`Error::Malformed`] for a
    /// payload that is not exactly one message of the kind.
    pub fn parse<T: AsRef<[u8]>>(frame: &Frame<T>) -> Result<Message, Error> {
        let p = frame.payload();
        Ok(match frame.kind() {
            Kind::Scan => Message::Scan(decode(p)?),
            Kind::GpsFix => Message::GpsFix(decode(p)?),
            Kind::Nmea => Message::Nmea(decode(p)?),
            Kind::Status => Message::Status(decode(p)?),
            Kind::Heartbeat => Message::Heartbeat(decode(p)?),
            Kind::Log => Message::Log(decode(p)?),
            Kind::Ack => Message::Ack(decode(p)?),
            Kind::Pps => Message::Pps(decode(p)?),
            Kind::ConfigureLaser => Message::ConfigureLaser(decode(p)?),
            Kind::SetStreaming => Message::SetStreaming(decode(p)?),
            Kind::RequestStatus => Message::RequestStatus(decode(p)?),
            Kind::TimeSyncPing => Message::TimeSyncPing(decode(p)?),
            Kind::Unknown(k) => return Err(Error::UnknownKind(k)),
        })
    }

    /// The payload length of this message.
    pub fn payload_len(&self) -> usize {
        dispatch!(self, m => encoded_len(m))
    }

    /// The raw frame length this message needs ([`crate::FRAME_OVERHEAD`] plus the payload).
    pub fn buffer_len(&self) -> usize {
        frame::frame_len(self.payload_len())
    }

    /// Writes header, payload and CRC into the start of `buffer` and returns the frame length.
    /// Never panics; a buffer of at least [`Message::buffer_len`] bytes always suffices.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] if `buffer` cannot hold the frame.
    pub fn emit(&self, seq: u16, buffer: &mut [u8]) -> Result<usize, Error> {
        if buffer.len() < frame::FRAME_OVERHEAD {
            return Err(Error::BufferTooSmall);
        }
        let end = buffer.len() - frame::CRC_LEN;
        let payload_area = &mut buffer[frame::PAYLOAD_START..end];
        let payload_len = dispatch!(self, m => encode(m, payload_area))?;
        let len = frame::frame_len(payload_len);
        let mut frame = Frame::new_unchecked(&mut buffer[..len]);
        frame.set_header(Header {
            version: PROTOCOL_VERSION,
            kind: self.kind(),
            seq,
        });
        frame.fill_crc();
        Ok(len)
    }
}
