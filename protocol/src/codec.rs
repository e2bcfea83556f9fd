//! Turning messages into wire bytes and a byte stream back into messages.

use crate::frame::{Error as FrameError, Frame, Header, MAX_FRAME_LEN, MAX_WIRE_LEN};
use crate::message::{Error as MessageError, Message};
use crate::{PROTOCOL_VERSION, SeqTracker};

/// Encodes messages into COBS-delimited frames, numbering them.
#[derive(Debug)]
pub struct Encoder {
    next_seq: u16,
    raw: [u8; MAX_FRAME_LEN],
}

impl Default for Encoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Encoder {
    /// An encoder whose first frame has sequence number 0.
    pub const fn new() -> Self {
        Encoder {
            next_seq: 0,
            raw: [0; MAX_FRAME_LEN],
        }
    }

    /// The sequence number the next frame gets.
    pub fn next_seq(&self) -> u16 {
        self.next_seq
    }

    /// Advances the sequence number past `count` frames that were dropped before encoding, so
    /// that the receiver sees the gap and counts them as lost.
    pub fn skip(&mut self, count: u16) {
        self.next_seq = self.next_seq.wrapping_add(count);
    }

    /// Encodes `message` into `out` as one wire frame (COBS, then a 0x00 delimiter) and
    /// returns its bytes. The sequence number advances even if the caller then drops the
    /// frame, so the receiver counts it as lost. An `out` of [`MAX_WIRE_LEN`] bytes always
    /// suffices.
    ///
    /// # Errors
    /// [`MessageError::BufferTooSmall`] if the message or its encoding does not fit.
    pub fn encode<'o>(
        &mut self,
        message: &Message,
        out: &'o mut [u8],
    ) -> Result<&'o [u8], MessageError> {
        let seq = self.next_seq;
        let raw_len = message.emit(seq, &mut self.raw)?;
        let raw = &self.raw[..raw_len];
        if out.len() < cobs::max_encoding_length(raw_len) + 1 {
            return Err(MessageError::BufferTooSmall);
        }
        let n = cobs::encode(raw, out);
        out[n] = 0;
        self.next_seq = seq.wrapping_add(1);
        Ok(&out[..=n])
    }
}

/// What a decoder counted. Every byte that reached it is accounted for.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderStats {
    /// Bytes pushed in.
    pub bytes: u64,
    /// Frames decoded into messages.
    pub frames: u64,
    /// Frames whose CRC failed.
    pub crc_errors: u64,
    /// Frames with invalid COBS.
    pub cobs_errors: u64,
    /// Frames longer than [`MAX_WIRE_LEN`].
    pub oversize: u64,
    /// Frames too short to hold a header and CRC (a lone delimiter is not counted).
    pub truncated: u64,
    /// Frames from another protocol version, skipped.
    pub unsupported_version: u64,
    /// Frames of a kind this version does not know, skipped.
    pub unknown_kind: u64,
    /// Frames whose payload did not decode.
    pub malformed: u64,
    /// Frames missing according to the sequence numbers.
    pub lost: u64,
}

/// One decoded frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Received {
    /// The frame header.
    pub header: Header,
    /// Frames lost just before this one (a sequence gap).
    pub lost_before: u16,
    /// The message.
    pub message: Message,
}

/// Why a frame was not delivered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeError {
    /// Framing, CRC or version problem.
    Frame(FrameError),
    /// Payload problem.
    Message(MessageError),
}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DecodeError::Frame(e) => e.fmt(f),
            DecodeError::Message(e) => e.fmt(f),
        }
    }
}

/// Reassembles frames from a byte stream. Bytes may arrive in any chunking; a corrupted frame
/// costs only itself, since the next 0x00 starts a fresh one.
#[derive(Debug)]
pub struct Decoder {
    buf: [u8; MAX_WIRE_LEN],
    len: usize,
    overflowed: bool,
    seq: SeqTracker,
    stats: DecoderStats,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder waiting for the first frame.
    pub const fn new() -> Self {
        Decoder {
            buf: [0; MAX_WIRE_LEN],
            len: 0,
            overflowed: false,
            seq: SeqTracker::new(),
            stats: DecoderStats {
                bytes: 0,
                frames: 0,
                crc_errors: 0,
                cobs_errors: 0,
                oversize: 0,
                truncated: 0,
                unsupported_version: 0,
                unknown_kind: 0,
                malformed: 0,
                lost: 0,
            },
        }
    }

    /// The counters so far.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Forgets a partial frame and the expected sequence number, keeping the counters (after a
    /// reconnect).
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflowed = false;
        self.seq.resync();
    }

    /// Feeds one byte. Returns `Some` when the byte ended a frame: the message, or why the
    /// frame was dropped (already counted in [`Decoder::stats`]).
    pub fn push(&mut self, byte: u8) -> Option<Result<Received, DecodeError>> {
        self.stats.bytes += 1;
        if byte != 0 {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
            }
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        if core::mem::replace(&mut self.overflowed, false) {
            self.stats.oversize += 1;
            return Some(Err(DecodeError::Frame(FrameError::Oversize)));
        }
        if len == 0 {
            // Back-to-back delimiters: harmless, used to flush a link.
            return None;
        }
        Some(self.finish(len))
    }

    /// Feeds a chunk of bytes, calling `on_message` for each decoded message. Errors are only
    /// counted.
    pub fn feed(&mut self, bytes: &[u8], mut on_message: impl FnMut(Received)) {
        for &b in bytes {
            if let Some(Ok(received)) = self.push(b) {
                on_message(received);
            }
        }
    }

    fn finish(&mut self, len: usize) -> Result<Received, DecodeError> {
        let raw_len = match cobs::decode_in_place(&mut self.buf[..len]) {
            Ok(n) => n,
            Err(_) => {
                self.stats.cobs_errors += 1;
                return Err(DecodeError::Frame(FrameError::BadCobs));
            }
        };
        let frame = match Frame::new_checked(&self.buf[..raw_len]) {
            Ok(frame) => frame,
            Err(e) => {
                self.stats.truncated += 1;
                return Err(DecodeError::Frame(e));
            }
        };
        if let Err(e) = frame.check_crc() {
            self.stats.crc_errors += 1;
            return Err(DecodeError::Frame(e));
        }
        let header = frame.header();
        // A valid frame of any version or kind still tells us its sequence number.
        let lost_before = self.seq.observe(header.seq);
        self.stats.lost += u64::from(lost_before);
        if header.version != PROTOCOL_VERSION {
            self.stats.unsupported_version += 1;
            return Err(DecodeError::Frame(FrameError::UnsupportedVersion(
                header.version,
            )));
        }
        match Message::parse(&frame) {
            Ok(message) => {
                self.stats.frames += 1;
                Ok(Received {
                    header,
                    lost_before,
                    message,
                })
            }
            Err(e) => {
                match e {
                    MessageError::UnknownKind(_) => self.stats.unknown_kind += 1,
                    _ => self.stats.malformed += 1,
                }
                Err(DecodeError::Message(e))
            }
        }
    }
}
