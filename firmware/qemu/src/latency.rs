//! Time from a laser telegram's last byte to its scan frame's first byte on the host link, in
//! core cycles ([`crate::time_driver::cycles`]).
//!
//! The receive interrupt stamps every byte; the laser port notes the stamp of the newest byte
//! the lidar task has read ([`laser_bytes_read`]); the host link notes when a scan frame
//! starts ([`frame_started`]). A sample is the difference. The telegram's last byte is the
//! newest one read when it ends a read, which it does when the line is quiet after it (a
//! streaming LMS leaves about 12 ms between telegrams); bytes read after it and before the
//! frame starts would make a sample too short.

use core::cell::Cell;

use critical_section::Mutex;
use protocol::Kind;

use crate::time_driver;

#[derive(Clone, Copy, Default)]
struct State {
    /// Arrival stamp (low 32 bits of the cycle count) of the newest laser byte read.
    last_laser_byte: Option<u32>,
    max_cycles: u32,
    samples: u32,
}

static STATE: Mutex<Cell<State>> = Mutex::new(Cell::new(State {
    last_laser_byte: None,
    max_cycles: 0,
    samples: 0,
}));

/// The lidar task read bytes, the newest of which arrived at `stamp`.
pub fn laser_bytes_read(stamp: u32) {
    critical_section::with(|cs| {
        let state = STATE.borrow(cs);
        state.set(State {
            last_laser_byte: Some(stamp),
            ..state.get()
        });
    });
}

/// The host link is about to send `wire` (one COBS frame).
pub fn frame_started(wire: &[u8]) {
    if frame_kind(wire) != Some(Kind::Scan) {
        return;
    }
    let now = time_driver::cycles() as u32;
    critical_section::with(|cs| {
        let state = STATE.borrow(cs);
        let mut s = state.get();
        if let Some(stamp) = s.last_laser_byte {
            s.max_cycles = s.max_cycles.max(now.wrapping_sub(stamp));
            s.samples = s.samples.wrapping_add(1);
        }
        state.set(s);
    });
}

/// The longest sample, cycles, and the number of samples.
pub fn worst() -> (u32, u32) {
    critical_section::with(|cs| {
        let s = STATE.borrow(cs).get();
        (s.max_cycles, s.samples)
    })
}

/// The kind of a wire frame: its second byte once COBS-decoded (after the version byte).
fn frame_kind(wire: &[u8]) -> Option<Kind> {
    // COBS: a code byte `c` is followed by `c − 1` data bytes and, unless `c` is 0xFF, stands
    // for a zero after them.
    let mut decoded = [0u8; 2];
    let mut n = 0;
    let mut at = 0;
    while n < decoded.len() {
        let code = usize::from(*wire.get(at)?);
        if code == 0 {
            return None;
        }
        for &byte in wire.get(at + 1..at + code)? {
            if n == decoded.len() {
                break;
            }
            decoded[n] = byte;
            n += 1;
        }
        if code != 0xFF && n < decoded.len() {
            decoded[n] = 0;
            n += 1;
        }
        at += code;
    }
    Some(Kind::from(decoded[1]))
}
