//! Replays a raw serial capture: a file holding exactly the bytes one side sent (such as
//! `shared/datasets/benchmark/lms200/*.lms-to-host.bin`, rebuilt from the AtlasBuggy LMS200
//! session logs), sent back to back at a given baud rate, 10 bit times per byte (8N1), from
//! a given start time. The capture holds no timing of its own, so the pacing is that of a
//! line that never idles; pauses of the original session are not reproduced.
//!
//! Like the emulators, it is a pure state machine: [`CaptureReplay::poll_output_runs`] hands
//! out the bytes that have left the line by a time, [`CaptureReplay::next_output_us`] says
//! when the next one does.

use std::path::Path;

use super::error::LogError;
use crate::emulators::tx_line::byte_offset_us;
use crate::emulators::{RecordedScan, TxLine, TxRun};

/// Bytes that left the line together, and when the last of them had.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TimedRun {
    /// When the last byte's stop bit has left, µs.
    pub end_us: u64,
    /// The bytes.
    pub bytes: Vec<u8>,
}

/// A capture being replayed. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct CaptureReplay {
    bytes: Vec<u8>,
    baud: u32,
    start_us: u64,
    line: TxLine,
    sent: usize,
}

impl CaptureReplay {
    /// Replays `bytes` at `baud` from `start_us` on.
    pub fn new(bytes: Vec<u8>, baud: u32, start_us: u64) -> CaptureReplay {
        let baud = baud.max(1);
        let mut line = TxLine::new();
        line.push(start_us, baud, bytes.clone(), false);
        CaptureReplay {
            bytes,
            baud,
            start_us,
            line,
            sent: 0,
        }
    }

    /// Replays the capture file at `path` at `baud` from `start_us` on.
    ///
    /// # Errors
    /// [`LogError::Io`] when the file cannot be read.
    pub fn read(
        path: impl AsRef<Path>,
        baud: u32,
        start_us: u64,
    ) -> Result<CaptureReplay, LogError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| LogError::io(path, e))?;
        Ok(CaptureReplay::new(bytes, baud, start_us))
    }

    /// The whole capture.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The baud rate.
    pub fn baud(&self) -> u32 {
        self.baud
    }

    /// When byte `index` has left the line, µs (`None` past the end).
    pub fn byte_end_us(&self, index: usize) -> Option<u64> {
        (index < self.bytes.len())
            .then(|| self.start_us + byte_offset_us(index as u64 + 1, self.baud))
    }

    /// When the last byte has left the line, µs (`start_us` for an empty capture).
    pub fn end_us(&self) -> u64 {
        self.bytes
            .len()
            .checked_sub(1)
            .and_then(|last| self.byte_end_us(last))
            .unwrap_or(self.start_us)
    }

    /// The bytes that have left the line by `now_us` and were not handed out yet.
    pub fn poll_output_runs(&mut self, now_us: u64) -> Vec<TxRun> {
        let mut out = Vec::new();
        self.line.transmit_until(now_us, &mut out);
        self.sent += out.iter().map(|run| run.bytes.len()).sum::<usize>();
        out
    }

    /// As [`Self::poll_output_runs`], as one byte vector.
    pub fn poll_output(&mut self, now_us: u64) -> Vec<u8> {
        self.poll_output_runs(now_us)
            .into_iter()
            .flat_map(|run| run.bytes)
            .collect()
    }

    /// When the next byte leaves the line, if any is left.
    pub fn next_output_us(&self) -> Option<u64> {
        self.line.next_byte_end_us()
    }

    /// Whether every byte has been handed out.
    pub fn is_finished(&self) -> bool {
        self.sent == self.bytes.len()
    }

    /// The whole capture cut into runs of the bytes that leave within each `period_us`
    /// window (`[start, start + period)`, …), without touching the replay's state. Empty
    /// windows give no run.
    pub fn timed_runs(&self, period_us: u64) -> Vec<TimedRun> {
        let period_us = period_us.max(1);
        let mut runs: Vec<TimedRun> = Vec::new();
        let mut window = None;
        for (index, &byte) in self.bytes.iter().enumerate() {
            let end_us = self.start_us + byte_offset_us(index as u64 + 1, self.baud);
            let this_window = (end_us - self.start_us) / period_us;
            match runs.last_mut() {
                Some(run) if window == Some(this_window) => {
                    run.bytes.push(byte);
                    run.end_us = end_us;
                }
                _ => runs.push(TimedRun {
                    end_us,
                    bytes: vec![byte],
                }),
            }
            window = Some(this_window);
        }
        runs
    }
}

/// The scan telegrams of a raw sensor → host capture, to stream verbatim in place of the
/// emulated sensor's own scans ([`Lms2xx::replay`](crate::emulators::Lms2xx::replay)): each
/// `B0h` telegram (framed by STX, address and length; the CRC is not checked, so scans damaged
/// before they were recorded go out damaged), in order. Replies to the recording host's
/// requests and bytes outside telegrams are left out: the emulated sensor answers the
/// firmware's own requests. Timestamps are when each telegram's last byte left a line at
/// `baud` that never idles, from 0.
pub fn capture_scans(bytes: &[u8], baud: u32) -> Vec<RecordedScan> {
    use crate::run::tap::{HEADER_LEN, SCAN_CODE};
    let mut scans = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        if bytes[at] != firmware::sick::telegram::STX {
            at += 1;
            continue;
        }
        let Some(&[lo, hi]) = bytes.get(at + 2..at + HEADER_LEN) else {
            break;
        };
        let end = at + HEADER_LEN + usize::from(u16::from_le_bytes([lo, hi])) + 2;
        let Some(telegram) = bytes.get(at..end) else {
            break;
        };
        if telegram.get(HEADER_LEN) == Some(&SCAN_CODE) {
            scans.push(RecordedScan {
                timestamp_s: byte_offset_us(end as u64, baud.max(1)) as f64 * 1e-6,
                first_beam_rad: 0.0,
                resolution_rad: 0.0,
                ranges_m: Vec::new(),
                no_return_from_m: None,
                telegram: Some(telegram.to_vec()),
            });
        }
        at = end;
    }
    scans
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::sick::{Event, Receiver, Telegram};

    #[test]
    fn paced_at_the_baud_rate() {
        let mut replay = CaptureReplay::new(vec![1, 2, 3, 4], 9_600, 1_000);
        assert_eq!(replay.next_output_us(), Some(1_000 + 1_042));
        assert_eq!(replay.end_us(), 1_000 + 4_167);
        assert!(replay.poll_output(2_041).is_empty());
        assert_eq!(replay.poll_output(3_084), [1, 2]);
        assert!(!replay.is_finished());
        let runs = replay.poll_output_runs(10_000);
        assert_eq!(
            runs,
            [TxRun {
                baud: 9_600,
                bytes: vec![3, 4]
            }]
        );
        assert!(replay.is_finished());
        assert_eq!(replay.next_output_us(), None);
        let runs = replay.timed_runs(2_500);
        assert_eq!(runs.len(), 2);
        assert_eq!((runs[0].bytes.len(), runs[0].end_us), (2, 1_000 + 2_084));
        assert_eq!(CaptureReplay::new(Vec::new(), 9_600, 5).end_us(), 5);
    }

    #[test]
    fn atlasbuggy_capture_replays_byte_exactly() {
        let Some(path) = datasets::require(
            "benchmark/lms200/2017_Aug_04_23-25-00.lms-to-host.bin",
            "atlasbuggy_capture_replays_byte_exactly",
        ) else {
            return;
        };
        let mut replay = CaptureReplay::read(&path, 38_400, 0).unwrap();
        assert_eq!(replay.bytes().len(), 12_932);
        // 12 932 bytes at 3 840 bytes/s.
        assert_eq!(replay.end_us(), 3_367_709);
        let mut receiver = Receiver::new();
        let (mut bytes, mut scans) = (Vec::new(), 0);
        let mut now_us = 0;
        while !replay.is_finished() {
            now_us += 10_000;
            for byte in replay.poll_output(now_us) {
                bytes.push(byte);
                if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                    scans += usize::from(telegram.command() == 0xB0);
                }
            }
        }
        assert_eq!(bytes, std::fs::read(&path).unwrap());
        // As many CRC-valid scans as the session's scans.jsonl lists.
        assert_eq!(scans, 17);
    }

    #[test]
    fn capture_scans_keep_damaged_scans_and_drop_replies() {
        let Some(path) = datasets::require(
            "benchmark/lms200/2017_Aug_05_19-07-55.lms-to-host.bin",
            "capture_scans_keep_damaged_scans_and_drop_replies",
        ) else {
            return;
        };
        let bytes = std::fs::read(&path).unwrap();
        let scans = capture_scans(&bytes, 38_400);
        // One scan telegram, read out of step when it was recorded: its CRC fails.
        assert_eq!(scans.len(), 1);
        let telegram = scans[0].telegram.as_deref().unwrap();
        assert_eq!((telegram.len(), telegram[4]), (732, 0xB0));
        let crc_ok = |t: &[u8]| Telegram::new_checked(t).is_ok_and(|t| t.check_crc().is_ok());
        assert!(!crc_ok(telegram));
        assert!(bytes.ends_with(telegram));
        // A clean session: every scan, each intact.
        let Some(path) = datasets::require(
            "benchmark/lms200/2017_Aug_04_23-25-00.lms-to-host.bin",
            "capture_scans_keep_damaged_scans_and_drop_replies",
        ) else {
            return;
        };
        let scans = capture_scans(&std::fs::read(&path).unwrap(), 38_400);
        assert_eq!(scans.len(), 17);
        assert!(scans.iter().all(|s| crc_ok(s.telegram.as_deref().unwrap())));
        assert!(
            scans
                .windows(2)
                .all(|w| w[0].timestamp_s < w[1].timestamp_s)
        );
    }
}
