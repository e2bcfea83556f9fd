//! Place recognition over point landmarks by geometric hashing of landmark pairs (Lamdan and
//! Wolfson, "Geometric hashing: a general and efficient model-based recognition scheme",
//! ICCV 1988): finds where a set of landmarks (a finished local map) lies in an indexed set
//! (the old part of the global map) from their relative geometry and diameters alone, so it
//! works however far the pose estimate has drifted.
//!
//! 1. **Index.** Every pair of indexed landmarks between `min_pair_distance_m` and
//!    `max_pair_distance_m` apart is stored in a hash map keyed by its length quantised to
//!    `distance_tolerance_m`. [`Constellation::sync`] keeps the index in step with the old map
//!    incrementally: landmarks that appear are added, those that disappear are dropped, and
//!    those that moved by more than a quarter of `distance_tolerance_m` are re-indexed.
//!    Dropped pairs stay in the hash map, recognised as stale by a generation stamp, until
//!    enough accumulate to rebuild it.
//! 2. **Hypotheses.** Each local landmark is paired with its `pairs_per_landmark` nearest
//!    neighbours. A local pair looks up the old pairs of the same length (within
//!    `distance_tolerance_m`); each one with compatible diameters gives, per orientation, a
//!    rigid transform `old_from_local`. Hypotheses vote in a coarse table indexed by their
//!    angle and by where they put the local centroid.
//! 3. **Verification.** The `verified_hypotheses` most voted are verified: each local
//!    landmark, moved by the hypothesis, is paired one to one with the nearest old landmark of
//!    compatible diameter within a gate, and the transform is refitted by least squares over
//!    those inliers (2D Procrustes), with the gate narrowed from twice `inlier_distance_m` to
//!    `inlier_distance_m`.
//! 4. **Acceptance.** Hypotheses are scored as in MSAC (Torr and Zisserman, "MLESAC: a new
//!    robust estimator...", CVIU 2000): each inlier at distance `d` counts
//!    `1 − (d / inlier_distance_m)²`, so a tight fit beats a loose one with as many inliers.
//!    The best is accepted with at least `min_inliers` inliers and when the best *distinct*
//!    competitor (one that moves some local landmark by more than twice `inlier_distance_m`
//!    away from where the best one puts it) scores at most `max_ambiguity_ratio` times as
//!    much. On a planted grid a wrong shift still finds many trunks near a node, but a looser
//!    fit; the score, not the count, is what separates it from the true place.
//!
//! Trade-offs:
//! * No pose prior at all, so any drift is recovered; the price is that a place that merely
//!   looks alike can match. The ambiguity test turns down places in strongly aliased areas (a
//!   planted grid) rather than risk a wrong one, and [`super::HistoryMemory`] asks for several
//!   consecutive, mutually consistent matches before it believes one.
//! * Covariances are ignored: in the global frame they carry the drift shared by the whole
//!   local map, which is what this search must not depend on. The tolerances are metric and
//!   suit tree trunks mapped to a few decimetres.
//! * Cost is bounded: the index holds `O(N k)` pairs for `N` old landmarks with `k`
//!   neighbours within `max_pair_distance_m` (a density bound, not a map-size one); voting
//!   costs `O(n · pairs_per_landmark · m)` for `n` local landmarks and `m` old pairs of similar
//!   length, and verification `O(verified_hypotheses · n)`. Only the most voted bins are
//!   verified, so in a very large self-similar map a true place can be crowded out and missed.
//!   Finding the local pairs is `O(n²)`, `n` being bounded by the local map size.

use std::collections::{HashMap, HashSet};
use std::ops::ControlFlow;

/// Hash maps keyed by small integer tuples, hashed with `foldhash` (fixed seed, so runs
/// repeat exactly): voting inserts hundreds of thousands of keys per local map, where the
/// standard library's SipHash dominates the cost.
type FastMap<K, V> = HashMap<K, V, foldhash::fast::FixedState>;

use super::landmark_info::LandmarkInfo;
use super::submap_slam::MappedLandmark;
use crate::geometry::{Pose2, wrap_angle_rad};

/// Side of the cells of the spatial hash of old landmarks, metres.
const CELL_SIZE_M: f64 = 4.0;
/// Angle bin of the voting table, radians.
const VOTE_ANGLE_BIN_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// Position bin of the voting table, as a multiple of `inlier_distance_m`.
const VOTE_POSITION_BIN_FACTOR: f64 = 2.0;
/// Successive verification gates, as multiples of `inlier_distance_m`; the transform is
/// refitted after each.
const VERIFICATION_GATE_FACTORS: [f64; 3] = [2.0, 1.0, 1.0];
/// An old landmark that moved by more than this fraction of `distance_tolerance_m` since it was
/// indexed is re-indexed; below it, lookups widen their windows to cover the shift.
const REINDEX_SHIFT_FRACTION: f64 = 0.25;

/// Settings of [`Constellation`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstellationOptions {
    /// Pairs shorter than this are not used: their direction is too uncertain, metres.
    pub min_pair_distance_m: f64,
    /// Pairs longer than this are not indexed, metres. Bounds the index to the neighbours of
    /// each landmark; should be about the extent of a local map.
    pub max_pair_distance_m: f64,
    /// Two pair lengths match within this, metres (about three times the standard deviation
    /// of a length difference).
    pub distance_tolerance_m: f64,
    /// Each local landmark forms pairs with this many nearest neighbours.
    pub pairs_per_landmark: usize,
    /// Diameters are compatible within this many metres...
    pub diameter_tolerance_m: f64,
    /// ...plus this fraction of the larger one (see [`LandmarkInfo::diameter_compatible`]).
    pub diameter_tolerance_fraction: f64,
    /// A local landmark moved by a hypothesis is an inlier within this of an old one, metres.
    pub inlier_distance_m: f64,
    /// How many of the most voted hypotheses are verified.
    pub verified_hypotheses: usize,
    /// A place is accepted with at least this many inliers (never fewer than two)...
    pub min_inliers: usize,
    /// ...and when the best distinct competitor scores at most this fraction of its score.
    pub max_ambiguity_ratio: f64,
}

impl Default for ConstellationOptions {
    /// Pairs of 2 to 20 m, lengths within 0.5 m, six pairs per local landmark, diameters within
    /// 0.15 m + 30 %, inliers within 0.75 m, 24 hypotheses verified, a place accepted with 5
    /// inliers and a competitor scoring at most 0.7 times as much.
    fn default() -> Self {
        ConstellationOptions {
            min_pair_distance_m: 2.0,
            max_pair_distance_m: 20.0,
            distance_tolerance_m: 0.5,
            pairs_per_landmark: 6,
            diameter_tolerance_m: 0.15,
            diameter_tolerance_fraction: 0.3,
            inlier_distance_m: 0.75,
            verified_hypotheses: 24,
            min_inliers: 5,
            max_ambiguity_ratio: 0.7,
        }
    }
}

/// Where a set of local landmarks lies in the indexed old map.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaceMatch {
    /// The transform moving the local landmarks, as given, onto the old ones:
    /// `position_in_old = old_from_local ⊕ position_in_local`.
    pub old_from_local: Pose2,
    /// Number of inliers, `pairs.len()`.
    pub inliers: usize,
    /// MSAC score: the sum over inliers of `1 − (d / inlier_distance_m)²`, `d` the distance
    /// between the paired landmarks after the fit; between 0 and `inliers`.
    pub score: f64,
    /// `(local landmark index, old landmark index)`, by local index; indices are those of the
    /// slices given to [`Constellation::find_place`] and [`Constellation::sync`].
    pub pairs: Vec<(usize, usize)>,
    /// Root mean square distance between paired landmarks after the fit, metres.
    pub rms_residual_m: f64,
    /// Votes the hypothesis got before verification.
    pub votes: usize,
    /// Score of the best distinct competitor (0 when there is none).
    pub second_best_score: f64,
}

/// An indexed old landmark.
#[derive(Debug, Clone, Copy, PartialEq)]
struct IndexedLandmark {
    /// Where it is now (as last given to `sync`).
    position_in_map: [f64; 2],
    /// Where it was when indexed: the cell and pair lengths are from this position.
    indexed_position_in_map: [f64; 2],
    info: LandmarkInfo,
    /// Stamp of this indexing; pairs carrying another stamp are stale.
    generation: u64,
}

/// A pair of old landmarks in the length index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct IndexedPair {
    first: usize,
    second: usize,
    first_generation: u64,
    second_generation: u64,
}

/// A local landmark as the search uses it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LocalPoint {
    /// Index in the caller's slice.
    index: usize,
    position_in_map: [f64; 2],
    info: LandmarkInfo,
}

/// One cell of the voting table. Kept small (the table holds tens of thousands of cells while
/// a local map is searched): the hypothesis is kept as the local pair that gave it, and
/// rebuilt for the few cells that are verified ([`Constellation::hypothesis`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Vote {
    count: u32,
    /// The longest local pair that voted here (the best determined angle; the first of
    /// equal length): its index in the local pairs. The old pair it went onto is the first
    /// of its hypotheses that falls in the cell.
    local_pair: u32,
}

/// A cell of the voting table: angle bin, then the bins of where the local centroid lands,
/// packed in one word ([`vote_key`]) whose order is theirs.
type VoteKey = u64;

/// Bits of a position bin in a [`VoteKey`]; the angle bin takes the 16 above them.
const VOTE_POSITION_BITS: u32 = 24;

/// The cell of angle bin `angle` and position bins `x` and `y` (bin indices, not yet
/// rounded). Each is offset to be non-negative and saturates at its field, so the keys order
/// as the `(angle, x, y)` bins do, and only positions thousands of kilometres out (at the
/// default bin of 1 m) could share a cell.
fn vote_key(angle: f64, x: f64, y: f64) -> VoteKey {
    let field = |bin: f64, bits: u32| {
        let half = (1_i64 << (bits - 1)) as f64;
        // Bin 0 for what is not a number, as a cast would give.
        let bin = if bin.is_nan() { 0.0 } else { bin };
        // The cast saturates; the clamp keeps the value in its field.
        (bin + half).clamp(0.0, 2.0 * half - 1.0) as u64
    };
    (field(angle.round(), 16) << (2 * VOTE_POSITION_BITS))
        | (field(x.floor(), VOTE_POSITION_BITS) << VOTE_POSITION_BITS)
        | field(y.floor(), VOTE_POSITION_BITS)
}

/// The old map indexed for place recognition. See the [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct Constellation {
    options: ConstellationOptions,
    /// By old (global) landmark index; `None` when not indexed.
    landmarks: Vec<Option<IndexedLandmark>>,
    /// Spatial hash of indexed positions.
    cells: FastMap<(i64, i64), Vec<usize>>,
    /// Pairs by quantised length.
    pairs_by_length: FastMap<i64, Vec<IndexedPair>>,
    indexed_count: usize,
    next_generation: u64,
    /// Landmarks dropped or re-indexed since the pair index was last rebuilt.
    dropped_since_rebuild: usize,
}

impl Constellation {
    /// An empty index.
    pub fn new(options: ConstellationOptions) -> Constellation {
        Constellation {
            options,
            landmarks: Vec::new(),
            cells: FastMap::default(),
            pairs_by_length: FastMap::default(),
            indexed_count: 0,
            next_generation: 0,
            dropped_since_rebuild: 0,
        }
    }

    /// The options in use.
    pub fn options(&self) -> &ConstellationOptions {
        &self.options
    }

    /// Number of indexed landmarks.
    pub fn len(&self) -> usize {
        self.indexed_count
    }

    /// Whether no landmark is indexed.
    pub fn is_empty(&self) -> bool {
        self.indexed_count == 0
    }

    /// Makes the index hold exactly `global_in_map[i]` for each `i` in `old_indices`, at their
    /// current positions. Indices out of range, repeated ones and landmarks with a non-finite
    /// position are skipped. Cost: `O(global_in_map.len())` plus the re-indexing of what
    /// appeared or moved.
    pub fn sync(&mut self, global_in_map: &[MappedLandmark], old_indices: &[usize]) {
        let shift_m = self.reindex_shift_m();
        let mut wanted = vec![false; self.landmarks.len().max(global_in_map.len())];
        for &index in old_indices {
            let Some(landmark) = global_in_map.get(index) else {
                continue;
            };
            if wanted[index] || !is_finite(landmark.position_in_map) {
                continue;
            }
            wanted[index] = true;
            let position = landmark.position_in_map;
            match self.landmarks.get_mut(index).and_then(Option::as_mut) {
                Some(indexed)
                    if distance_m(indexed.indexed_position_in_map, position) <= shift_m =>
                {
                    indexed.position_in_map = position;
                    indexed.info = landmark.info;
                }
                Some(_) => {
                    self.remove(index);
                    self.insert(index, position, landmark.info);
                }
                None => self.insert(index, position, landmark.info),
            }
        }
        for (index, &keep) in wanted.iter().enumerate() {
            if !keep {
                self.remove(index);
            }
        }
        if 2 * self.dropped_since_rebuild > self.indexed_count.max(32) {
            self.rebuild_pairs();
        }
    }

    /// Searches `local_in_map` (landmarks in any frame, typically the global frame as
    /// estimated) in the index; returns the place when one is accepted (see the
    /// [module documentation](self)), `None` otherwise. Landmarks with a non-finite position
    /// are ignored.
    pub fn find_place(&self, local_in_map: &[MappedLandmark]) -> Option<PlaceMatch> {
        let mut hypotheses = self.hypotheses(local_in_map);
        if hypotheses.is_empty() {
            return None;
        }
        let mut best = hypotheses.remove(0);
        best.second_best_score = hypotheses.first().map_or(0.0, |second| second.score);
        let accepted = best.inliers >= self.options.min_inliers.max(2)
            && best.score > 0.0
            && best.second_best_score <= self.options.max_ambiguity_ratio * best.score;
        accepted.then_some(best)
    }

    /// Every verified hypothesis for `local_in_map`, distinct from each other, best first
    /// (highest score, then most inliers); none is accepted or rejected here.
    pub fn hypotheses(&self, local_in_map: &[MappedLandmark]) -> Vec<PlaceMatch> {
        let local: Vec<LocalPoint> = local_in_map
            .iter()
            .enumerate()
            .filter(|(_, landmark)| is_finite(landmark.position_in_map))
            .map(|(index, landmark)| LocalPoint {
                index,
                position_in_map: landmark.position_in_map,
                info: landmark.info,
            })
            .collect();
        let kept = self.options.verified_hypotheses;
        if local.len() < 2 || self.indexed_count < 2 || kept == 0 {
            return Vec::new();
        }
        let local_pairs = self.local_pairs(&local);
        let centroid = centroid_in_map(local.iter().map(|point| point.position_in_map));
        let votes = self.vote(&local, &local_pairs, centroid);
        let ranked = most_voted(votes, kept);
        let mut verified: Vec<PlaceMatch> = ranked
            .iter()
            .filter_map(|cell| {
                let old_from_local = self.hypothesis(&local, &local_pairs, centroid, cell)?;
                self.verify(&local, &cell.1, old_from_local)
            })
            .collect();
        verified.sort_by(|a, b| {
            b.score
                .total_cmp(&a.score)
                .then(b.inliers.cmp(&a.inliers))
                .then(b.votes.cmp(&a.votes))
        });
        let same_place_m = 2.0 * self.options.inlier_distance_m;
        let mut distinct: Vec<PlaceMatch> = Vec::new();
        for candidate in verified {
            let seen = distinct.iter().any(|kept| {
                max_displacement_m(&local, kept.old_from_local, candidate.old_from_local)
                    <= same_place_m
            });
            if !seen {
                distinct.push(candidate);
            }
        }
        distinct
    }

    /// Hypotheses from every local pair (`local_pairs`, from [`Self::local_pairs`]) against the
    /// old pairs of the same length, binned; `centroid` is the local landmarks' centroid.
    fn vote(
        &self,
        local: &[LocalPoint],
        local_pairs: &[(usize, usize, f64)],
        centroid: [f64; 2],
    ) -> FastMap<VoteKey, Vote> {
        let mut votes: FastMap<VoteKey, Vote> = FastMap::default();
        for (local_pair, &pair) in local_pairs.iter().enumerate() {
            // Landmark and pair counts are far below `u32::MAX`.
            let this = Vote {
                count: 0,
                local_pair: local_pair as u32,
            };
            self.pair_hypotheses(local, pair, centroid, |key, _| {
                let vote = votes.entry(key).or_insert(this);
                vote.count = vote.count.saturating_add(1);
                if pair.2 > local_pairs[vote.local_pair as usize].2 {
                    vote.local_pair = this.local_pair;
                }
                ControlFlow::<()>::Continue(())
            });
        }
        votes
    }

    /// Every hypothesis the local pair `(i, j, length_m)` gives, in a fixed order: laid onto
    /// each old pair of its length (within the tolerance), both ways round, whose landmarks
    /// are compatible with its own; each as the cell of the voting table it falls in (where
    /// it takes `centroid`) and its `old_from_local`. Stops when `visit` breaks, with what it
    /// broke with.
    fn pair_hypotheses<B>(
        &self,
        local: &[LocalPoint],
        (i, j, length_m): (usize, usize, f64),
        centroid: [f64; 2],
        mut visit: impl FnMut(VoteKey, Pose2) -> ControlFlow<B>,
    ) -> Option<B> {
        let options = &self.options;
        let tolerance_m = options.distance_tolerance_m;
        let slack_m = 2.0 * self.reindex_shift_m();
        let position_bin_m = VOTE_POSITION_BIN_FACTOR * options.inlier_distance_m;
        let (first, second) = (&local[i], &local[j]);
        let local_frame = PairFrame::new(first.position_in_map, second.position_in_map);
        let low = self.length_key(length_m - tolerance_m - slack_m);
        let high = self.length_key(length_m + tolerance_m + slack_m);
        for key in low..=high {
            let Some(bucket) = self.pairs_by_length.get(&key) else {
                continue;
            };
            for pair in bucket {
                let (Some(a), Some(b)) = (
                    self.live(pair.first, pair.first_generation),
                    self.live(pair.second, pair.second_generation),
                ) else {
                    continue;
                };
                let old_length_m = distance_m(a.position_in_map, b.position_in_map);
                if (old_length_m - length_m).abs() > tolerance_m {
                    continue;
                }
                for (to_first, to_second) in [(a, b), (b, a)] {
                    if !self.compatible(&first.info, &to_first.info)
                        || !self.compatible(&second.info, &to_second.info)
                    {
                        continue;
                    }
                    let old_from_local = local_frame
                        .transform_onto(to_first.position_in_map, to_second.position_in_map);
                    let landed = transform(old_from_local, centroid);
                    let cell = vote_key(
                        old_from_local.theta_rad / VOTE_ANGLE_BIN_RAD,
                        landed[0] / position_bin_m,
                        landed[1] / position_bin_m,
                    );
                    if let ControlFlow::Break(found) = visit(cell, old_from_local) {
                        return Some(found);
                    }
                }
            }
        }
        None
    }

    /// The hypothesis `old_from_local` the cell `key` of the voting table keeps: the first
    /// of its local pair's hypotheses that falls in it, as [`Self::vote`] met it.
    fn hypothesis(
        &self,
        local: &[LocalPoint],
        local_pairs: &[(usize, usize, f64)],
        centroid: [f64; 2],
        (key, vote): &(VoteKey, Vote),
    ) -> Option<Pose2> {
        let pair = local_pairs[vote.local_pair as usize];
        self.pair_hypotheses(local, pair, centroid, |cell, old_from_local| {
            if cell == *key {
                ControlFlow::Break(old_from_local)
            } else {
                ControlFlow::Continue(())
            }
        })
    }

    /// Each local landmark with its `pairs_per_landmark` nearest neighbours in the usable
    /// length range: `(i, j, length_m)` with `i < j`, without repeats.
    fn local_pairs(&self, local: &[LocalPoint]) -> Vec<(usize, usize, f64)> {
        let options = &self.options;
        let mut pairs = Vec::new();
        let mut neighbours: Vec<(f64, usize)> = Vec::new();
        for (i, point) in local.iter().enumerate() {
            neighbours.clear();
            neighbours.extend(local.iter().enumerate().filter_map(|(j, other)| {
                let length_m = distance_m(point.position_in_map, other.position_in_map);
                (j != i
                    && length_m >= options.min_pair_distance_m
                    && length_m <= options.max_pair_distance_m)
                    .then_some((length_m, j))
            }));
            neighbours.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            for &(length_m, j) in neighbours.iter().take(options.pairs_per_landmark) {
                pairs.push((i.min(j), i.max(j), length_m));
            }
        }
        pairs.sort_by_key(|&(i, j, _)| (i, j));
        pairs.dedup_by(|a, b| (a.0, a.1) == (b.0, b.1));
        pairs
    }

    /// Pairs the local landmarks under `vote`'s hypothesis `old_from_local`, refitting it as
    /// the gate narrows.
    fn verify(
        &self,
        local: &[LocalPoint],
        vote: &Vote,
        mut old_from_local: Pose2,
    ) -> Option<PlaceMatch> {
        for factor in VERIFICATION_GATE_FACTORS {
            let pairs = self.associate(
                local,
                old_from_local,
                factor * self.options.inlier_distance_m,
            );
            if pairs.len() < 2 {
                return None;
            }
            old_from_local = self.fit(local, &pairs)?;
        }
        let pairs = self.associate(local, old_from_local, self.options.inlier_distance_m);
        if pairs.len() < 2 {
            return None;
        }
        let sum_squares_m2: f64 = pairs.iter().map(|&(_, _, d)| d * d).sum();
        let gate_m = self.options.inlier_distance_m.max(f64::MIN_POSITIVE);
        let score: f64 = pairs
            .iter()
            .map(|&(_, _, d)| 1.0 - (d / gate_m).powi(2))
            .sum();
        let mut pairs: Vec<(usize, usize)> = pairs
            .iter()
            .map(|&(k, old, _)| (local[k].index, old))
            .collect();
        pairs.sort_unstable();
        Some(PlaceMatch {
            old_from_local,
            inliers: pairs.len(),
            score,
            rms_residual_m: (sum_squares_m2 / pairs.len() as f64).sqrt(),
            pairs,
            votes: vote.count as usize,
            second_best_score: 0.0,
        })
    }

    /// One-to-one pairs `(position in local, old index, distance_m)` of the local landmarks
    /// moved by `old_from_local` with old landmarks of compatible diameter within `gate_m`,
    /// nearest first.
    fn associate(
        &self,
        local: &[LocalPoint],
        old_from_local: Pose2,
        gate_m: f64,
    ) -> Vec<(usize, usize, f64)> {
        let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
        for (k, point) in local.iter().enumerate() {
            let landed = transform(old_from_local, point.position_in_map);
            self.for_each_near(landed, gate_m, |old, indexed| {
                let d = distance_m(landed, indexed.position_in_map);
                if d <= gate_m && self.compatible(&point.info, &indexed.info) {
                    candidates.push((d, k, old));
                }
            });
        }
        candidates.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
        let mut local_used = vec![false; local.len()];
        let mut old_used: HashSet<usize> = HashSet::new();
        let mut pairs = Vec::new();
        for (d, k, old) in candidates {
            if local_used[k] || !old_used.insert(old) {
                continue;
            }
            local_used[k] = true;
            pairs.push((k, old, d));
        }
        pairs
    }

    /// Least-squares rigid transform moving the paired local landmarks onto the old ones
    /// (closed-form 2D Procrustes); `None` if it is not determined.
    fn fit(&self, local: &[LocalPoint], pairs: &[(usize, usize, f64)]) -> Option<Pose2> {
        let mut from = Vec::with_capacity(pairs.len());
        let mut to = Vec::with_capacity(pairs.len());
        for &(k, old, _) in pairs {
            let indexed = self.landmarks.get(old).copied().flatten()?;
            from.push(local[k].position_in_map);
            to.push(indexed.position_in_map);
        }
        fit_rigid(&from, &to)
    }

    /// Calls `visit(index, landmark)` for the indexed landmarks that may lie within `radius_m`
    /// of `position_in_map` (a superset: the caller checks the distance).
    fn for_each_near(
        &self,
        position_in_map: [f64; 2],
        radius_m: f64,
        mut visit: impl FnMut(usize, &IndexedLandmark),
    ) {
        let reach_m = radius_m + self.reindex_shift_m();
        let [low_x, low_y] = cell_of([position_in_map[0] - reach_m, position_in_map[1] - reach_m]);
        let [high_x, high_y] =
            cell_of([position_in_map[0] + reach_m, position_in_map[1] + reach_m]);
        for x in low_x..=high_x {
            for y in low_y..=high_y {
                let Some(members) = self.cells.get(&(x, y)) else {
                    continue;
                };
                for &index in members {
                    if let Some(indexed) = self.landmarks.get(index).and_then(Option::as_ref) {
                        visit(index, indexed);
                    }
                }
            }
        }
    }

    /// Indexes landmark `index` at `position_in_map` with its pairs to the indexed neighbours.
    fn insert(&mut self, index: usize, position_in_map: [f64; 2], info: LandmarkInfo) {
        if self.landmarks.len() <= index {
            self.landmarks.resize(index + 1, None);
        }
        let generation = self.next_generation;
        self.next_generation += 1;
        let mut new_pairs: Vec<(i64, IndexedPair)> = Vec::new();
        self.for_each_near(
            position_in_map,
            self.options.max_pair_distance_m,
            |other, indexed| {
                if let Some(key) = self.pair_key(position_in_map, indexed.indexed_position_in_map) {
                    new_pairs.push((
                        key,
                        IndexedPair {
                            first: index,
                            second: other,
                            first_generation: generation,
                            second_generation: indexed.generation,
                        },
                    ));
                }
            },
        );
        for (key, pair) in new_pairs {
            self.pairs_by_length.entry(key).or_default().push(pair);
        }
        let [x, y] = cell_of(position_in_map);
        self.cells.entry((x, y)).or_default().push(index);
        self.landmarks[index] = Some(IndexedLandmark {
            position_in_map,
            indexed_position_in_map: position_in_map,
            info,
            generation,
        });
        self.indexed_count += 1;
    }

    /// Drops landmark `index` from the index (its pairs become stale).
    fn remove(&mut self, index: usize) {
        let Some(indexed) = self.landmarks.get_mut(index).and_then(Option::take) else {
            return;
        };
        let [x, y] = cell_of(indexed.indexed_position_in_map);
        if let Some(members) = self.cells.get_mut(&(x, y)) {
            members.retain(|&member| member != index);
            if members.is_empty() {
                self.cells.remove(&(x, y));
            }
        }
        self.indexed_count -= 1;
        self.dropped_since_rebuild += 1;
    }

    /// Rebuilds the length index from the indexed landmarks, dropping stale pairs.
    fn rebuild_pairs(&mut self) {
        let mut pairs_by_length: FastMap<i64, Vec<IndexedPair>> = FastMap::default();
        for (index, indexed) in self.landmarks.iter().enumerate() {
            let Some(indexed) = indexed else {
                continue;
            };
            self.for_each_near(
                indexed.indexed_position_in_map,
                self.options.max_pair_distance_m,
                |other, neighbour| {
                    if other <= index {
                        return;
                    }
                    if let Some(key) = self.pair_key(
                        indexed.indexed_position_in_map,
                        neighbour.indexed_position_in_map,
                    ) {
                        pairs_by_length.entry(key).or_default().push(IndexedPair {
                            first: index,
                            second: other,
                            first_generation: indexed.generation,
                            second_generation: neighbour.generation,
                        });
                    }
                },
            );
        }
        self.pairs_by_length = pairs_by_length;
        self.dropped_since_rebuild = 0;
    }

    /// The length key of a pair between two indexed positions, `None` outside the indexed
    /// length range (widened by the lookup slack).
    fn pair_key(&self, a_in_map: [f64; 2], b_in_map: [f64; 2]) -> Option<i64> {
        let slack_m = 2.0 * self.reindex_shift_m();
        let length_m = distance_m(a_in_map, b_in_map);
        (length_m >= self.options.min_pair_distance_m - slack_m
            && length_m <= self.options.max_pair_distance_m + slack_m)
            .then(|| self.length_key(length_m))
    }

    /// The quantised length.
    fn length_key(&self, length_m: f64) -> i64 {
        (length_m / self.options.distance_tolerance_m.max(1e-3)).floor() as i64
    }

    /// The indexed landmark `index` if it still carries `generation`.
    fn live(&self, index: usize, generation: u64) -> Option<&IndexedLandmark> {
        self.landmarks
            .get(index)
            .and_then(Option::as_ref)
            .filter(|indexed| indexed.generation == generation)
    }

    /// Whether two diameters are compatible under the options.
    fn compatible(&self, local: &LandmarkInfo, old: &LandmarkInfo) -> bool {
        old.diameter_compatible(
            local.diameter_m,
            self.options.diameter_tolerance_m,
            self.options.diameter_tolerance_fraction,
        )
    }

    /// Largest shift of an old landmark tolerated before re-indexing it, metres.
    fn reindex_shift_m(&self) -> f64 {
        REINDEX_SHIFT_FRACTION * self.options.distance_tolerance_m.max(0.0)
    }
}

/// The `kept` cells of `votes` with the most votes, most first; the key breaks ties, so the
/// result does not depend on hashing. Taken from the table as it is walked, so that only
/// those cells are ever copied out of it: the table holds thousands of cells once a park is
/// mapped, and a copy of all of them, beside the table, would double a join's memory.
fn most_voted(votes: FastMap<VoteKey, Vote>, kept: usize) -> Vec<(VoteKey, Vote)> {
    let ranks_before = |a: &(VoteKey, Vote), b: &(VoteKey, Vote)| {
        b.1.count.cmp(&a.1.count).then(a.0.cmp(&b.0)) == std::cmp::Ordering::Less
    };
    let mut best: Vec<(VoteKey, Vote)> = Vec::with_capacity(kept.min(votes.len()) + 1);
    for cell in votes {
        if best.len() == kept && best.last().is_none_or(|last| !ranks_before(&cell, last)) {
            continue;
        }
        let at = best.partition_point(|kept_cell| ranks_before(kept_cell, &cell));
        best.insert(at, cell);
        best.truncate(kept);
    }
    best
}

/// `a_from_b ⊕ point_in_b`, summed as [`super::frames::transform_point`] sums it, without the
/// Jacobians.
pub(crate) fn transform(a_from_b: Pose2, point_in_b: [f64; 2]) -> [f64; 2] {
    let (sin, cos) = a_from_b.theta_rad.sin_cos();
    [
        a_from_b.x_m + cos * point_in_b[0] - sin * point_in_b[1],
        a_from_b.y_m + sin * point_in_b[0] + cos * point_in_b[1],
    ]
}

/// Mean of the points (the origin when there are none).
pub(crate) fn centroid_in_map(points: impl IntoIterator<Item = [f64; 2]>) -> [f64; 2] {
    let (mut sum, mut count) = ([0.0, 0.0], 0_usize);
    for point in points {
        sum[0] += point[0];
        sum[1] += point[1];
        count += 1;
    }
    if count == 0 {
        return [0.0, 0.0];
    }
    [sum[0] / count as f64, sum[1] / count as f64]
}

/// A segment between two points, as the rigid transform taking it onto another segment needs
/// it: worked out once per local pair, since voting moves each onto many old ones.
#[derive(Debug, Clone, Copy)]
struct PairFrame {
    /// Direction from the first point to the second, radians.
    angle_rad: f64,
    /// Midpoint of the two.
    mid: [f64; 2],
}

impl PairFrame {
    fn new(first: [f64; 2], second: [f64; 2]) -> PairFrame {
        PairFrame {
            angle_rad: (second[1] - first[1]).atan2(second[0] - first[0]),
            mid: [(first[0] + second[0]) / 2.0, (first[1] + second[1]) / 2.0],
        }
    }

    /// The rigid transform taking this pair onto `(first, second)`: its direction onto
    /// theirs, its midpoint onto theirs.
    fn transform_onto(&self, first: [f64; 2], second: [f64; 2]) -> Pose2 {
        let to = PairFrame::new(first, second);
        let theta_rad = wrap_angle_rad(to.angle_rad - self.angle_rad);
        let rotated = transform(rotation(theta_rad), self.mid);
        Pose2 {
            x_m: to.mid[0] - rotated[0],
            y_m: to.mid[1] - rotated[1],
            theta_rad,
        }
    }
}

/// The rotation by `theta_rad` about the origin (the angle as given, not wrapped).
fn rotation(theta_rad: f64) -> Pose2 {
    Pose2 {
        theta_rad,
        ..Pose2::IDENTITY
    }
}

/// Least-squares rigid transform moving `from[i]` onto `to[i]` (2D Procrustes, equal weights);
/// `None` for fewer than two points or coincident ones.
pub(crate) fn fit_rigid(from: &[[f64; 2]], to: &[[f64; 2]]) -> Option<Pose2> {
    if from.len() != to.len() || from.len() < 2 {
        return None;
    }
    let from_centroid = centroid_in_map(from.iter().copied());
    let to_centroid = centroid_in_map(to.iter().copied());
    let (mut cross, mut dot) = (0.0, 0.0);
    for (p, q) in from.iter().zip(to) {
        let (px, py) = (p[0] - from_centroid[0], p[1] - from_centroid[1]);
        let (qx, qy) = (q[0] - to_centroid[0], q[1] - to_centroid[1]);
        cross += px * qy - py * qx;
        dot += px * qx + py * qy;
    }
    if cross.hypot(dot) < 1e-12 || !cross.is_finite() || !dot.is_finite() {
        return None;
    }
    let theta_rad = cross.atan2(dot);
    let rotated = transform(rotation(theta_rad), from_centroid);
    Some(Pose2 {
        x_m: to_centroid[0] - rotated[0],
        y_m: to_centroid[1] - rotated[1],
        theta_rad,
    })
}

/// Largest distance between where `a` and `b` put any of the local landmarks, metres.
fn max_displacement_m(local: &[LocalPoint], a: Pose2, b: Pose2) -> f64 {
    local
        .iter()
        .map(|point| {
            distance_m(
                transform(a, point.position_in_map),
                transform(b, point.position_in_map),
            )
        })
        .fold(0.0, f64::max)
}

/// Euclidean distance, metres.
fn distance_m(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Whether both coordinates are finite.
fn is_finite(point: [f64; 2]) -> bool {
    point[0].is_finite() && point[1].is_finite()
}

/// The spatial-hash cell of a position.
fn cell_of(position_in_map: [f64; 2]) -> [i64; 2] {
    [
        (position_in_map[0] / CELL_SIZE_M).floor() as i64,
        (position_in_map[1] / CELL_SIZE_M).floor() as i64,
    ]
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix2;

    use super::*;
    use crate::ekf_slam::frames::compose_pose;

    /// Fourteen hand-placed trunks: position (m) and diameter (m).
    const TREES: [([f64; 2], f64); 14] = [
        ([0.0, 0.0], 0.30),
        ([4.2, 1.1], 0.45),
        ([7.9, -0.6], 0.25),
        ([2.5, 5.3], 0.52),
        ([6.1, 4.4], 0.33),
        ([10.4, 3.0], 0.41),
        ([1.2, 9.8], 0.28),
        ([5.6, 8.7], 0.60),
        ([9.3, 7.9], 0.36),
        ([12.8, 9.5], 0.22),
        ([14.1, 1.7], 0.48),
        ([3.4, 13.2], 0.31),
        ([8.8, 12.6], 0.39),
        ([13.5, 13.9], 0.27),
    ];

    fn mapped(position_in_map: [f64; 2], diameter_m: f64) -> MappedLandmark {
        MappedLandmark {
            position_in_map,
            covariance: Matrix2::identity() * 0.01,
            info: LandmarkInfo::first_seen(Some(diameter_m)),
        }
    }

    /// A pose, the angle as given (not wrapped).
    fn pose(x_m: f64, y_m: f64, theta_rad: f64) -> Pose2 {
        Pose2 {
            x_m,
            y_m,
            theta_rad,
        }
    }

    /// The trees moved by `map_from_true`.
    fn park(map_from_true: Pose2) -> Vec<MappedLandmark> {
        TREES
            .iter()
            .map(|&(p, d)| mapped(transform(map_from_true, p), d))
            .collect()
    }

    /// Trees 2 to 11 as a local map drifted by `estimated_from_true`.
    fn local(estimated_from_true: Pose2) -> Vec<MappedLandmark> {
        park(estimated_from_true)[2..12].to_vec()
    }

    fn assert_pose_close(a: Pose2, b: Pose2, tolerance: f64) {
        let error = [
            a.x_m - b.x_m,
            a.y_m - b.y_m,
            wrap_angle_rad(a.theta_rad - b.theta_rad),
        ];
        assert!(error.iter().all(|e| e.abs() < tolerance), "{a:?} != {b:?}");
    }

    #[test]
    fn test_fit_rigid_recovers_the_transform() {
        let truth = pose(3.0, -2.0, 2.5);
        let from: Vec<[f64; 2]> = TREES.iter().map(|&(p, _)| p).collect();
        let to: Vec<[f64; 2]> = from.iter().map(|&p| transform(truth, p)).collect();
        let found = fit_rigid(&from, &to).expect("determined");
        assert_pose_close(found, truth, 1e-9);
        assert_eq!(fit_rigid(&from[..1], &to[..1]), None);
        assert_eq!(fit_rigid(&[[1.0, 1.0]; 3], &[[2.0, 0.0]; 3]), None);
        assert_eq!(fit_rigid(&from, &to[..3]), None);
    }

    #[test]
    fn cells_order_as_their_bins_and_saturate_far_out() {
        let bins = [
            (-36.0, -5.2, 7.9),
            (-36.0, -5.0, -3.0),
            (0.4, 1e9, -1e9),
            (0.0, 0.0, 0.0),
            (0.0, 0.0, 0.5),
            (36.0, -8_388_608.0, 8_388_607.0),
        ];
        let key = |&(a, x, y): &(f64, f64, f64)| vote_key(a, x, y);
        let as_tuple = |&(a, x, y): &(f64, f64, f64)| {
            (
                a.round() as i32,
                (x.floor() as i32).clamp(-(1 << 23), (1 << 23) - 1),
                (y.floor() as i32).clamp(-(1 << 23), (1 << 23) - 1),
            )
        };
        for a in &bins {
            for b in &bins {
                assert_eq!(
                    key(a).cmp(&key(b)),
                    as_tuple(a).cmp(&as_tuple(b)),
                    "{a:?} {b:?}"
                );
            }
        }
        assert_eq!(vote_key(0.0, 0.0, 0.0), vote_key(0.4, 0.9, 0.2));
        assert_eq!(vote_key(0.0, 1e12, 0.0), vote_key(0.0, 1e9, 0.0));
    }

    #[test]
    fn the_most_voted_cells_are_the_first_of_the_whole_table_sorted() {
        // Cells with few distinct counts, so that ties are many and the key must break them.
        let votes: FastMap<VoteKey, Vote> = (0..5_000u32)
            .map(|i| {
                let key = vote_key(
                    (i % 7) as f64,
                    (i / 7 % 31) as f64 - 15.0,
                    (i.wrapping_mul(2_654_435_761) % 97) as f64,
                );
                let vote = Vote {
                    count: i.wrapping_mul(2_654_435_761) % 5,
                    local_pair: i,
                };
                (key, vote)
            })
            .collect();
        let mut sorted: Vec<(VoteKey, Vote)> = votes.clone().into_iter().collect();
        sorted.sort_by(|a, b| b.1.count.cmp(&a.1.count).then(a.0.cmp(&b.0)));
        for kept in [1, 24, 1_000, 10_000] {
            let expected = &sorted[..kept.min(sorted.len())];
            assert_eq!(most_voted(votes.clone(), kept), expected, "{kept} kept");
        }
    }

    #[test]
    fn test_finds_exact_place() {
        let mut constellation = Constellation::new(ConstellationOptions::default());
        let global = park(Pose2::IDENTITY);
        let all: Vec<usize> = (0..global.len()).collect();
        constellation.sync(&global, &all);
        assert_eq!(constellation.len(), 14);
        let drift = pose(5.0, -3.0, 0.4);
        let place = constellation.find_place(&local(drift)).expect("recognised");
        assert_pose_close(place.old_from_local, drift.inverse(), 1e-9);
        let expected: Vec<(usize, usize)> = (0..10).map(|k| (k, k + 2)).collect();
        assert_eq!(place.pairs, expected);
        assert!(place.rms_residual_m < 1e-9 && (place.score - 10.0).abs() < 1e-9);
    }

    #[test]
    fn test_sync_follows_moves_and_removals() {
        let mut constellation = Constellation::new(ConstellationOptions::default());
        let all: Vec<usize> = (0..TREES.len()).collect();
        constellation.sync(&park(Pose2::IDENTITY), &all);
        // A small shift keeps the index; a large correction re-indexes every landmark.
        constellation.sync(&park(pose(0.05, 0.0, 0.0)), &all);
        assert_eq!(constellation.dropped_since_rebuild, 0);
        let map_from_true = pose(-20.0, 35.0, -1.0);
        constellation.sync(&park(map_from_true), &all);
        assert_eq!(constellation.len(), 14);
        // Every landmark re-indexed; the old pairs stay, stale, until a rebuild.
        assert_eq!(constellation.dropped_since_rebuild, 14);
        // Moving them back makes the stale pairs the majority: the index is rebuilt.
        constellation.sync(&park(Pose2::IDENTITY), &all);
        assert_eq!(constellation.dropped_since_rebuild, 0);
        constellation.sync(&park(map_from_true), &all);
        let drift = pose(1.0, 2.0, 0.1);
        let place = constellation
            .find_place(&local(drift))
            .expect("recognised after the correction");
        let (expected, _, _) = compose_pose(map_from_true, drift.inverse());
        assert_pose_close(place.old_from_local, expected, 1e-9);
        // Only the first seven remain old: the best hypothesis pairs trees 2 to 6, and no
        // hypothesis pairs a dropped landmark.
        constellation.sync(&park(map_from_true), &all[..7]);
        assert_eq!(constellation.len(), 7);
        let hypotheses = constellation.hypotheses(&local(drift));
        assert_eq!(
            hypotheses[0].pairs,
            (0..5).map(|k| (k, k + 2)).collect::<Vec<_>>()
        );
        assert!(
            hypotheses
                .iter()
                .all(|h| h.pairs.iter().all(|&(_, old)| old < 7))
        );
        constellation.sync(&[], &[]);
        assert!(constellation.is_empty());
        assert_eq!(constellation.find_place(&local(drift)), None);
    }

    #[test]
    fn test_diameters_veto_pairs() {
        let mut constellation = Constellation::new(ConstellationOptions::default());
        let global = park(Pose2::IDENTITY);
        let all: Vec<usize> = (0..global.len()).collect();
        constellation.sync(&global, &all);
        // The same layout with trunks four times as thick matches nothing.
        let thick: Vec<MappedLandmark> = local(Pose2::IDENTITY)
            .into_iter()
            .map(|mut landmark| {
                landmark.info.diameter_m = landmark.info.diameter_m.map(|d| 4.0 * d);
                landmark
            })
            .collect();
        assert!(constellation.hypotheses(&thick).is_empty());
    }

    #[test]
    fn test_tiny_and_invalid_inputs() {
        let mut constellation = Constellation::new(ConstellationOptions::default());
        assert_eq!(constellation.find_place(&[]), None);
        assert_eq!(constellation.find_place(&local(Pose2::IDENTITY)), None);
        let global = park(Pose2::IDENTITY);
        constellation.sync(&global, &[0, 0, 3, 99, usize::MAX]);
        assert_eq!(constellation.len(), 2);
        let nan = [mapped([f64::NAN, 0.0], 0.3), mapped([1.0, 1.0], 0.3)];
        constellation.sync(&nan, &[0, 1]);
        assert_eq!(constellation.len(), 1);
        assert_eq!(constellation.find_place(&nan), None);
        assert_eq!(constellation.find_place(&global[..1]), None);
        let degenerate = Constellation::new(ConstellationOptions {
            distance_tolerance_m: 0.0,
            inlier_distance_m: 0.0,
            pairs_per_landmark: 0,
            verified_hypotheses: 0,
            ..ConstellationOptions::default()
        });
        assert_eq!(degenerate.find_place(&global), None);
    }
}
