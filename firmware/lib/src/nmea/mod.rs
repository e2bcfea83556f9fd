//! NMEA 0183 from a GNSS receiver: line assembly, checksum, the sentences the board decodes
//! and the fix reports it sends to the host. `no_std`, no allocation, no floating point.
//!
//! Layers, after smoltcp's wire module (`shared/STYLE.md`), each usable on its own:
//!
//! 1. [`LineAssembler`] ([`line`](mod@line)): serial bytes → complete lines, resynchronising on every
//!    `$`, bounded by [`protocol::MAX_NMEA_LEN`], dropping and counting truncated, overlong
//!    and binary-polluted lines, stamping each line with the time its `$` arrived.
//! 2. [`Sentence`] ([`sentence`]): a view over one line with
//!    [`check_format`](Sentence::check_format) / [`check_checksum`](Sentence::check_checksum),
//!    talker, formatter and a field iterator that keeps empty fields.
//! 3. One `Repr` per sentence type, decoding from any talker and writing a complete sentence
//!    back ([`GgaRepr`], [`RmcRepr`], [`GllRepr`], [`GsaRepr`], [`VtgRepr`], [`GstRepr`]);
//!    `emit` followed by `parse` gives the same `Repr`. The field decoders ([`fields`]) and
//!    encoders ([`emit`]) are integer-only; latitude/longitude convert exactly to
//!    nanodegrees (§8 of `shared/protocols/nmea0183.md`).
//! 4. [`GpsReceiver`] ([`receiver`]): bytes → [`protocol::GpsFixMsg`] for every GGA, RMC
//!    and GLL with a valid checksum, merged with the epoch's date, speed/course and GST
//!    sigmas; the no-fix rule; the accepted sentences for passthrough; [`NmeaStats`].
//!
//! ```
//! use firmware::nmea::{GgaRepr, Sentence};
//!
//! let sentence = Sentence::new_checked(
//!     "$GNGGA,132819.60,4134.49795459,N,09345.03431408,W,2,10,0.9,278.161,M,-31.442,M,6.6,0133*6A",
//! )?;
//! let gga = GgaRepr::parse(&sentence)?;
//! assert_eq!(gga.fix_position().map(|p| p.lat_ndeg), Some(41_574_965_910));
//! # Ok::<(), firmware::nmea::Error>(())
//! ```

pub mod emit;
mod error;
pub mod fields;
mod gga;
mod gll;
mod gsa;
mod gst;
pub mod line;
mod mode;
pub mod receiver;
mod rmc;
pub mod sentence;
mod vtg;

pub use error::Error;
pub use gga::GgaRepr;
pub use gll::GllRepr;
pub use gsa::{GsaFixType, GsaRepr, MAX_GSA_SATS, Selection};
pub use gst::GstRepr;
pub use line::{Line, LineAssembler, LineStats};
pub use mode::Mode;
pub use receiver::{GST_MAX_AGE_US, GpsReceiver, NmeaStats, ReceivedSentence};
pub use rmc::RmcRepr;
pub use sentence::{Fields, Sentence, SentenceKind, Talker, checksum};
pub use vtg::VtgRepr;
