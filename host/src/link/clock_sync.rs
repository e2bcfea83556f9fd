//! Board clock → host clock.
//!
//! Each time-sync round trip gives a sample: the host sent a ping at `t_send`, the board
//! stamped it `t_board`, the host received the acknowledgement at `t_recv`. The board time
//! corresponds to host time `(t_send + t_recv) / 2` within ± half the round trip. The mapping
//! is a line `host = offset + (1 + drift) · board`, fitted by least squares to the samples
//! with the smallest round trips in a sliding window (the ones least disturbed by queueing).

use std::collections::VecDeque;

/// The time the fitted samples must span before a drift is estimated, s.
pub const MIN_DRIFT_SPAN_S: f64 = 60.0;

/// One round trip.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    board_s: f64,
    host_s: f64,
    rtt_s: f64,
}

/// Options of [`ClockSync`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockSyncOptions {
    /// Samples kept.
    pub window: usize,
    /// Share of the window (the fastest round trips) used for the fit, 0–1.
    pub best_fraction: f64,
}

impl Default for ClockSyncOptions {
    fn default() -> Self {
        ClockSyncOptions {
            window: 64,
            best_fraction: 0.5,
        }
    }
}

/// Maps board time (µs since boot) to host time (s).
#[derive(Debug, Clone)]
pub struct ClockSync {
    options: ClockSyncOptions,
    samples: VecDeque<Sample>,
    /// host_s = offset_s + scale · board_s
    offset_s: f64,
    scale: f64,
}

impl Default for ClockSync {
    fn default() -> Self {
        Self::new(ClockSyncOptions::default())
    }
}

impl ClockSync {
    /// No samples yet.
    pub fn new(options: ClockSyncOptions) -> Self {
        ClockSync {
            options,
            samples: VecDeque::new(),
            offset_s: 0.0,
            scale: 1.0,
        }
    }

    /// Whether at least one sample has been taken.
    pub fn is_synchronised(&self) -> bool {
        !self.samples.is_empty()
    }

    /// Adds a round trip: ping sent at host `send_s`, stamped `board_us` by the board,
    /// acknowledgement received at host `recv_s`. Samples with a negative round trip are ignored.
    pub fn add_round_trip(&mut self, send_s: f64, board_us: u64, recv_s: f64) {
        let rtt_s = recv_s - send_s;
        if rtt_s.is_nan() || rtt_s < 0.0 {
            return;
        }
        if self.samples.len() == self.options.window {
            self.samples.pop_front();
        }
        self.samples.push_back(Sample {
            board_s: board_us as f64 * 1e-6,
            host_s: 0.5 * (send_s + recv_s),
            rtt_s,
        });
        self.refit();
    }

    /// Adds a one-way sample (a heartbeat received at host `recv_s`): an upper bound on the
    /// host time of `board_us`, used only until round trips exist.
    pub fn add_one_way(&mut self, board_us: u64, recv_s: f64) {
        let board_s = board_us as f64 * 1e-6;
        let has_round_trips = self.samples.iter().any(|s| s.rtt_s > 0.0);
        if !has_round_trips && (self.samples.is_empty() || recv_s - board_s < self.offset_s) {
            self.samples.clear();
            self.samples.push_back(Sample {
                board_s,
                host_s: recv_s,
                rtt_s: 0.0,
            });
            self.offset_s = recv_s - board_s;
            self.scale = 1.0;
        }
    }

    /// Host time (s) of board time `board_us`.
    pub fn to_host_s(&self, board_us: u64) -> f64 {
        self.offset_s + self.scale * (board_us as f64 * 1e-6)
    }

    /// The fitted drift of the board clock relative to the host's, in parts per million.
    pub fn drift_ppm(&self) -> f64 {
        (self.scale - 1.0) * 1e6
    }

    fn refit(&mut self) {
        let mut best: Vec<Sample> = self.samples.iter().copied().collect();
        best.sort_by(|a, b| a.rtt_s.total_cmp(&b.rtt_s));
        let keep =
            ((best.len() as f64 * self.options.best_fraction).ceil() as usize).clamp(1, best.len());
        best.truncate(keep);
        let n = best.len() as f64;
        let mean_b = best.iter().map(|s| s.board_s).sum::<f64>() / n;
        let mean_h = best.iter().map(|s| s.host_s).sum::<f64>() / n;
        let sxx: f64 = best.iter().map(|s| (s.board_s - mean_b).powi(2)).sum();
        let sxy: f64 = best
            .iter()
            .map(|s| (s.board_s - mean_b) * (s.host_s - mean_h))
            .sum();
        // A drift estimate needs a long baseline: with millisecond jitter over a few seconds
        // it would be off by hundreds of ppm. Until the samples span a minute, assume none.
        let first_s = self.samples.front().map_or(0.0, |s| s.board_s);
        let last_s = self.samples.back().map_or(0.0, |s| s.board_s);
        self.scale = if last_s - first_s >= MIN_DRIFT_SPAN_S && sxx > 0.0 {
            (sxy / sxx).clamp(1.0 - 1e-3, 1.0 + 1e-3)
        } else {
            1.0
        };
        self.offset_s = mean_h - self.scale * mean_b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_offset_and_drift_despite_slow_round_trips() {
        let mut sync = ClockSync::default();
        // Board clock runs 50 ppm fast; host = 1000 + board / (1 + 50e-6).
        let truth = |board_s: f64| 1000.0 + board_s / (1.0 + 50e-6);
        for i in 0..120u64 {
            let board_us = i * 1_000_000;
            let h = truth(board_us as f64 * 1e-6);
            // Every third round trip is delayed asymmetrically by 20 ms.
            let (send, recv) = if i % 3 == 0 {
                (h - 0.001, h + 0.021)
            } else {
                (h - 0.001, h + 0.001)
            };
            sync.add_round_trip(send, board_us, recv);
        }
        let t = 90_500_000u64;
        assert!((sync.to_host_s(t) - truth(t as f64 * 1e-6)).abs() < 1e-4);
        assert!(
            (sync.drift_ppm() + 50.0).abs() < 5.0,
            "{}",
            sync.drift_ppm()
        );
    }

    #[test]
    fn one_way_samples_keep_the_earliest_arrival() {
        let mut sync = ClockSync::default();
        sync.add_one_way(1_000_000, 101.0 + 0.010);
        sync.add_one_way(2_000_000, 102.0 + 0.002);
        sync.add_one_way(3_000_000, 103.0 + 0.030);
        assert!((sync.to_host_s(0) - 100.002).abs() < 1e-9);
    }
}
