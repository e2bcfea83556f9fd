//! Sensor events put back in the order the board stamped them.
//!
//! The board stamps a scan at its telegram's first byte but sends it once the telegram is
//! whole (15 ms later at 500 kBd, 0.19 s at 38 400 Bd), and a GPS report at its `$` but sends
//! it at the end of the line (0.07 s for a GGA at 9 600 Bd). So a fix can reach the host after
//! a scan stamped later, and a filter that takes events as they arrive must either go back in
//! time or drop one. [`BoardTimeOrder`] holds each event until the newest stamp it has seen is
//! [`window_s`](BoardTimeOrder::window_s) ahead of it, then hands events on in stamp order
//! (arrival order among equal stamps). The order then depends on the stamps alone, not on
//! when the host happened to read each event, so a live run and its replay, or the firmware
//! on the host and on the board, give the filter the same sequence.
//!
//! An event that arrives more than the window behind the newest stamp (a stall longer than
//! the window, or a board that restarted its clock) is handed on at once, to be judged by
//! whoever takes it.

use std::collections::VecDeque;

use super::SensorEvent;

/// The default window, s: longer than a scan takes on the line at 38 400 Bd (0.19 s) and a
/// GPS sentence at 4 800 Bd (0.15 s).
pub const DEFAULT_WINDOW_S: f64 = 0.25;

/// The most events held: when stamps stop advancing (a frozen board clock, a recording whose
/// stamps are all zero), the oldest go on rather than pile up.
pub const MAX_HELD: usize = 1024;

/// A reorder buffer in board time. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct BoardTimeOrder {
    window_s: f64,
    /// Held events, in stamp order.
    pending: VecDeque<SensorEvent>,
    /// The newest stamp seen, s.
    newest_s: f64,
}

impl Default for BoardTimeOrder {
    fn default() -> Self {
        BoardTimeOrder::new(DEFAULT_WINDOW_S)
    }
}

impl BoardTimeOrder {
    /// A buffer that holds events `window_s` behind the newest stamp.
    pub fn new(window_s: f64) -> BoardTimeOrder {
        BoardTimeOrder {
            window_s: window_s.max(0.0),
            pending: VecDeque::new(),
            newest_s: f64::NEG_INFINITY,
        }
    }

    /// How far behind the newest stamp events are held, s.
    pub fn window_s(&self) -> f64 {
        self.window_s
    }

    /// Takes `event`; returns the events now due, oldest first (possibly none).
    pub fn push(&mut self, event: SensorEvent) -> Vec<SensorEvent> {
        let stamp_s = event.board_time_s();
        if stamp_s < self.newest_s - self.window_s {
            // Too late to be put in its place: on at once.
            let mut due = self.due();
            due.push(event);
            return due;
        }
        self.newest_s = self.newest_s.max(stamp_s);
        // After every event with a stamp no later than its own.
        let at = self
            .pending
            .iter()
            .rposition(|held| held.board_time_s() <= stamp_s)
            .map_or(0, |i| i + 1);
        self.pending.insert(at, event);
        let mut due = self.due();
        while self.pending.len() > MAX_HELD {
            due.extend(self.pending.pop_front());
        }
        due
    }

    /// The held events, oldest first, for a caller that merges a new event into one already
    /// held (several reports of one GPS epoch).
    pub fn pending_mut(&mut self) -> impl Iterator<Item = &mut SensorEvent> {
        self.pending.iter_mut()
    }

    /// Every held event, oldest first (at the end of a run).
    pub fn drain(&mut self) -> Vec<SensorEvent> {
        self.pending.drain(..).collect()
    }

    /// Events held now.
    pub fn len(&self) -> usize {
        self.pending.len()
    }

    /// Whether no event is held.
    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }

    fn due(&mut self) -> Vec<SensorEvent> {
        let until_s = self.newest_s - self.window_s;
        let count = self
            .pending
            .iter()
            .take_while(|held| held.board_time_s() <= until_s)
            .count();
        self.pending.drain(..count).collect()
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::link::LaserScan;

    fn empty_scan() -> Arc<LaserScan> {
        Arc::new(LaserScan {
            ranges_m: Vec::new(),
            first_angle_rad: 0.0,
            angle_step_rad: 0.01,
        })
    }

    fn scan(board_time_s: f64) -> SensorEvent {
        SensorEvent::Scan {
            host_time_s: board_time_s,
            board_time_s,
            scan_counter: 0,
            scan: empty_scan(),
        }
    }

    fn times(events: &[SensorEvent]) -> Vec<f64> {
        events.iter().map(SensorEvent::board_time_s).collect()
    }

    #[test]
    fn events_leave_in_stamp_order_once_the_window_passed() {
        let mut order = BoardTimeOrder::new(0.25);
        assert!(order.push(scan(1.0)).is_empty());
        // A report stamped before the scan that arrived first.
        assert!(order.push(scan(0.95)).is_empty());
        assert_eq!(times(&order.push(scan(1.2))), [0.95]);
        assert_eq!(times(&order.push(scan(1.3))), [1.0]);
        assert_eq!(order.len(), 2);
        assert_eq!(times(&order.drain()), [1.2, 1.3]);
        assert!(order.is_empty());
    }

    #[test]
    fn equal_stamps_keep_their_arrival_order() {
        let mut order = BoardTimeOrder::new(0.1);
        let fix_like = |host_time_s: f64| SensorEvent::Scan {
            host_time_s,
            board_time_s: 2.0,
            scan_counter: 0,
            scan: empty_scan(),
        };
        order.push(fix_like(1.0));
        order.push(fix_like(2.0));
        let due = order.push(scan(3.0));
        let hosts: Vec<f64> = due.iter().map(SensorEvent::host_time_s).collect();
        assert_eq!(hosts, [1.0, 2.0]);
    }

    #[test]
    fn an_event_later_than_the_window_goes_on_at_once() {
        let mut order = BoardTimeOrder::new(0.25);
        order.push(scan(10.0));
        // The board restarted its clock.
        assert_eq!(times(&order.push(scan(0.5))), [0.5]);
        assert_eq!(times(&order.drain()), [10.0]);
    }

    #[test]
    fn a_clock_that_stands_still_does_not_pile_events_up() {
        let mut order = BoardTimeOrder::new(0.25);
        let handed_on: usize = (0..MAX_HELD + 10)
            .map(|_| order.push(scan(1.0)).len())
            .sum();
        assert_eq!((handed_on, order.len()), (10, MAX_HELD));
    }

    #[test]
    fn no_window_hands_events_on_as_they_come() {
        let mut order = BoardTimeOrder::new(0.0);
        assert_eq!(times(&order.push(scan(1.0))), [1.0]);
        assert_eq!(times(&order.push(scan(0.9))), [0.9]);
    }
}
