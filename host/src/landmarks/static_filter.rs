//! Rejecting moving objects: features are tracked in the map frame over time, and a track whose
//! positions drift is flagged as moving.
//!
//! Each call brings the positions (map frame) of the features of one scan. They are associated
//! with the tracks one to one by global nearest neighbour: all observation–track pairs within
//! [`StaticFilterOptions::gate_m`] of a track's latest position, taken in order of distance,
//! each observation and track used once (ties broken by index, so the result is
//! deterministic). An unmatched observation starts a track. A track keeps the positions of the
//! last [`StaticFilterOptions::window_s`] seconds; once their spread (the diagonal of their
//! bounding box) exceeds [`StaticFilterOptions::max_spread_m`] the track is moving, and stays
//! so while it is tracked. A track unseen for [`StaticFilterOptions::forget_after_s`] is
//! dropped.
//!
//! A new track counts as static until it drifts, so a landmark is usable from its first
//! sighting and a mover is caught after travelling `max_spread_m`. The spread also holds the
//! map-frame error of the poses the features were placed with, which `max_spread_m` must
//! exceed. The gate must exceed how far a mover travels between calls, or each of its
//! sightings starts a new track that never drifts.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

/// Most positions a track keeps, whatever the window (bounds memory at high scan rates).
const MAX_POSITIONS_PER_TRACK: usize = 512;

/// How features are tracked and judged.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StaticFilterOptions {
    /// An observation joins a track whose latest position is at most this far, metres; 1.
    pub gate_m: f64,
    /// Positions older than this are forgotten, seconds; 2.
    pub window_s: f64,
    /// A track whose positions in the window spread wider than this is moving, metres; 0.5.
    pub max_spread_m: f64,
    /// A track unseen for this long is dropped, seconds; 5.
    pub forget_after_s: f64,
}

impl Default for StaticFilterOptions {
    /// 1 m gate; moving after 0.5 m of drift within 2 s; tracks dropped after 5 s unseen.
    fn default() -> Self {
        StaticFilterOptions {
            gate_m: 1.0,
            window_s: 2.0,
            max_spread_m: 0.5,
            forget_after_s: 5.0,
        }
    }
}

/// One tracked feature.
#[derive(Clone, Debug)]
struct Track {
    /// `(t_s, position in map)`, oldest first; never empty.
    positions: VecDeque<(f64, [f64; 2])>,
    moving: bool,
}

impl Track {
    fn latest(&self) -> Option<(f64, [f64; 2])> {
        self.positions.back().copied()
    }
}

/// Tracks of features in the map frame that tell static landmarks from moving objects (see
/// the [module documentation](self)).
#[derive(Clone, Debug)]
pub struct StaticFilter {
    options: StaticFilterOptions,
    tracks: Vec<Track>,
    latest_t_s: Option<f64>,
}

impl StaticFilter {
    /// A filter with no tracks.
    pub fn new(options: StaticFilterOptions) -> Self {
        StaticFilter {
            options,
            tracks: Vec::new(),
            latest_t_s: None,
        }
    }

    /// Number of live tracks.
    pub fn num_tracks(&self) -> usize {
        self.tracks.len()
    }

    /// Number of live tracks flagged as moving.
    pub fn num_moving(&self) -> usize {
        self.tracks.iter().filter(|t| t.moving).count()
    }

    /// Records the features of one scan, seen at `t_s` seconds at `positions_in_map`
    /// (metres), and returns for each whether it is static (true) or moving (false).
    ///
    /// A non-finite position is reported as not static and not recorded. A non-finite `t_s`
    /// reports every feature as not static and changes nothing. A `t_s` earlier than the
    /// previous call's (a restarted log) drops all tracks first.
    pub fn classify(&mut self, t_s: f64, positions_in_map: &[[f64; 2]]) -> Vec<bool> {
        if !t_s.is_finite() {
            return vec![false; positions_in_map.len()];
        }
        if self.latest_t_s.is_some_and(|latest_t_s| t_s < latest_t_s) {
            self.tracks.clear();
        }
        self.latest_t_s = Some(t_s);
        let forget_after_s = self.options.forget_after_s;
        self.tracks.retain(|track| {
            track
                .latest()
                .is_some_and(|(seen_s, _)| t_s - seen_s <= forget_after_s)
        });

        // Global nearest neighbour within the gate: every candidate pair, nearest first.
        let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (observation, p) in positions_in_map.iter().enumerate() {
            if !finite(p) {
                continue;
            }
            for (track_index, track) in self.tracks.iter().enumerate() {
                if let Some((_, q)) = track.latest() {
                    let distance_m = (p[0] - q[0]).hypot(p[1] - q[1]);
                    if distance_m <= self.options.gate_m {
                        pairs.push((distance_m, observation, track_index));
                    }
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut track_of: Vec<Option<usize>> = vec![None; positions_in_map.len()];
        let mut track_taken = vec![false; self.tracks.len()];
        for (_, observation, track_index) in pairs {
            if track_of[observation].is_none() && !track_taken[track_index] {
                track_of[observation] = Some(track_index);
                track_taken[track_index] = true;
            }
        }

        // Extend the matched tracks, start new ones, and judge each.
        let mut statics = Vec::with_capacity(positions_in_map.len());
        for (observation, p) in positions_in_map.iter().enumerate() {
            if !finite(p) {
                statics.push(false);
                continue;
            }
            let track_index = match track_of[observation] {
                Some(track_index) => track_index,
                None => {
                    self.tracks.push(Track {
                        positions: VecDeque::new(),
                        moving: false,
                    });
                    self.tracks.len() - 1
                }
            };
            let Some(track) = self.tracks.get_mut(track_index) else {
                statics.push(false);
                continue;
            };
            track.positions.push_back((t_s, *p));
            while track
                .positions
                .front()
                .is_some_and(|(seen_s, _)| t_s - seen_s > self.options.window_s)
                || track.positions.len() > MAX_POSITIONS_PER_TRACK
            {
                track.positions.pop_front();
            }
            if spread_m(&track.positions) > self.options.max_spread_m {
                track.moving = true;
            }
            statics.push(!track.moving);
        }
        statics
    }
}

/// Diagonal of the bounding box of `positions`, metres (0 when empty).
fn spread_m(positions: &VecDeque<(f64, [f64; 2])>) -> f64 {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for (_, p) in positions {
        for k in 0..2 {
            min[k] = min[k].min(p[k]);
            max[k] = max[k].max(p[k]);
        }
    }
    if positions.is_empty() {
        0.0
    } else {
        (max[0] - min[0]).hypot(max[1] - min[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::test_scene::Lcg;

    #[test]
    fn test_mover_is_flagged_and_trees_are_not() {
        let mut filter = StaticFilter::new(StaticFilterOptions::default());
        let trees_in_map = [[5.0, 2.0], [8.0, -3.0], [12.0, 1.0]];
        let mut rng = Lcg::new(1);
        let mut flagged_at_s = None;
        // 10 scans a second for 5 s; a walker crosses at 1 m/s, passing 1.2 m from a tree.
        for step in 0..50 {
            let t_s = f64::from(step) * 0.1;
            let mut positions: Vec<[f64; 2]> = trees_in_map
                .iter()
                .map(|p| [p[0] + 0.05 * rng.gaussian(), p[1] + 0.05 * rng.gaussian()])
                .collect();
            positions.push([6.2, -2.0 + t_s]);
            let statics = filter.classify(t_s, &positions);
            assert_eq!(statics.len(), 4);
            assert!(statics[..3].iter().all(|&s| s), "a tree flagged at {t_s} s");
            if !statics[3] && flagged_at_s.is_none() {
                flagged_at_s = Some(t_s);
            }
            if let Some(flagged_s) = flagged_at_s {
                assert!(!statics[3], "mover cleared at {t_s} s after {flagged_s} s");
            }
        }
        // Caught once it has travelled the half metre of allowed spread.
        let flagged_s = flagged_at_s.expect("the mover is flagged");
        assert!(flagged_s <= 0.7, "flagged only at {flagged_s} s");
        assert_eq!(filter.num_tracks(), 4);
        assert_eq!(filter.num_moving(), 1);
    }

    #[test]
    fn test_tracks_are_forgotten_and_time_may_restart() {
        let mut filter = StaticFilter::new(StaticFilterOptions::default());
        filter.classify(0.0, &[[1.0, 1.0]]);
        filter.classify(0.1, &[[1.0, 1.6], [4.0, 4.0]]);
        assert_eq!(filter.num_tracks(), 2);
        filter.classify(10.0, &[[9.0, 9.0]]);
        assert_eq!(filter.num_tracks(), 1);
        filter.classify(1.0, &[]);
        assert_eq!(filter.num_tracks(), 0);
    }

    #[test]
    fn test_hostile_inputs() {
        let mut filter = StaticFilter::new(StaticFilterOptions::default());
        assert_eq!(filter.classify(f64::NAN, &[[1.0, 1.0]]), vec![false]);
        assert_eq!(
            filter.classify(0.0, &[[f64::NAN, 1.0], [1.0, 1.0], [f64::INFINITY, 0.0]]),
            vec![false, true, false]
        );
        assert!(filter.classify(0.1, &[]).is_empty());
        let mut nan_filter = StaticFilter::new(StaticFilterOptions {
            gate_m: f64::NAN,
            window_s: f64::NAN,
            max_spread_m: f64::NAN,
            forget_after_s: f64::NAN,
        });
        for step in 0..5 {
            let _ = nan_filter.classify(f64::from(step), &[[1.0, 2.0], [1.0, 2.0]]);
        }
    }

    #[test]
    fn test_two_observations_do_not_share_a_track() {
        let mut filter = StaticFilter::new(StaticFilterOptions::default());
        filter.classify(0.0, &[[0.0, 0.0]]);
        let statics = filter.classify(0.1, &[[0.3, 0.0], [0.0, 0.1]]);
        assert_eq!(statics, vec![true, true]);
        assert_eq!(filter.num_tracks(), 2);
    }
}
