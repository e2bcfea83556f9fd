//! The history memory: recognises that the robot is back in a place it mapped long ago from
//! the landmarks of each finished local map and their geometry, independently of the (possibly
//! drifted) pose estimate, and closes a loop only on evidence accumulated over consecutive
//! local maps.
//!
//! Map joining pairs a local map's landmarks with the global ones by a Mahalanobis gate and
//! JCBB in the global frame (Tardós et al. 2002), which only works while the drift accumulated
//! around a loop stays inside the gate. This memory does not use the gate:
//!
//! 1. **Place recognition** ([`Constellation`]): the landmarks of local map `k`, expressed in
//!    the global frame as estimated, are searched in the *old map* (the global landmarks
//!    mapped before the last one or two local maps, which overlap `k` trivially) by
//!    geometric hashing of landmark pairs: pair lengths and trunk diameters propose rigid
//!    transforms `old_from_local`, the most voted are verified by counting inliers and refined
//!    by least squares. A place is accepted with enough inliers and a clear margin over the
//!    best distinct alternative.
//! 2. **Evidence over time**: trees look alike, so one accepted place may be a coincidence. A
//!    loop is confirmed only when `min_consecutive_matches` consecutive local maps give
//!    accepted places whose corrections agree (within `consistency_distance_m` where they put
//!    the local maps' centroids and `consistency_angle_rad`). Consecutive local maps share
//!    almost all of their drift, so the true correction repeats while a coincidental one
//!    does not.
//!
//! The confirmed [`LoopClosure`] gives the correction and the landmark pairs; the caller
//! fuses the pairs with equality constraints in the join, and the map's covariance spreads
//! the correction over the loop.
//!
//! Trade-offs: a loop is confirmed one local map late at the earliest (two with the default),
//! and a revisit shorter than `min_consecutive_matches` local maps is never closed here (the
//! ordinary join still closes it when the drift is small). In strongly aliased areas (a
//! planted grid) places are turned down by the ambiguity test, so loops there close later or
//! not at all: a missed loop costs accuracy, a wrong one ruins the map.

use std::collections::VecDeque;

use super::constellation::{
    Constellation, ConstellationOptions, PlaceMatch, centroid_in_map, transform,
};
use super::submap_slam::MappedLandmark;
use crate::geometry::{Pose2, wrap_angle_rad};

/// Settings of [`HistoryMemory`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HistoryMemoryOptions {
    /// Place recognition.
    pub constellation: ConstellationOptions,
    /// A loop is confirmed once this many consecutive local maps gave consistent places.
    pub min_consecutive_matches: usize,
    /// Two places are consistent when their corrections put each local map's centroid within
    /// this of each other, metres...
    pub consistency_distance_m: f64,
    /// ...and their rotations differ by at most this, radians.
    pub consistency_angle_rad: f64,
}

impl Default for HistoryMemoryOptions {
    /// Default place recognition, two consecutive local maps, corrections within 4 m and 5°.
    ///
    /// Right after a loop closed with a large correction the heading can still drift by
    /// 4–5° per local map, and consecutive corrections then put the centroids 2–4 m apart
    /// (Victoria Park at 1 436–1 478 s: three revisits in a row missed at 2 m).
    fn default() -> Self {
        HistoryMemoryOptions {
            constellation: ConstellationOptions::default(),
            min_consecutive_matches: 2,
            consistency_distance_m: 4.0,
            consistency_angle_rad: 5f64.to_radians(),
        }
    }
}

/// A confirmed loop: local map `local_map` lies on the old map.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopClosure {
    /// The local map that confirmed the loop (as numbered by the caller).
    pub local_map: usize,
    /// `corrected_from_estimated`, in the global frame: applied to the recent part of the map
    /// (`position_corrected = correction ⊕ position_in_map`) it puts the local map's landmarks
    /// onto the old ones.
    pub correction: Pose2,
    /// `(local landmark index, global landmark index)`: indices into the slices given to
    /// [`HistoryMemory::add_local_map`], to be fused.
    pub pairs: Vec<(usize, usize)>,
    /// Number of pairs.
    pub inliers: usize,
    /// Root mean square distance between the paired landmarks after the correction, metres.
    pub rms_residual_m: f64,
    /// Consecutive local maps, this one included, whose places agree.
    pub evidence: usize,
}

/// An accepted place, kept as evidence.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Evidence {
    local_map: usize,
    old_from_local: Pose2,
    local_centroid_in_map: [f64; 2],
}

/// Place recognition with evidence over consecutive local maps. See the
/// [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct HistoryMemory {
    options: HistoryMemoryOptions,
    constellation: Constellation,
    /// Accepted places of the latest local maps, oldest first.
    recent: VecDeque<Evidence>,
    last_match: Option<PlaceMatch>,
    evidence: usize,
}

impl HistoryMemory {
    /// An empty memory.
    pub fn new(options: HistoryMemoryOptions) -> HistoryMemory {
        HistoryMemory {
            constellation: Constellation::new(options.constellation),
            options,
            recent: VecDeque::new(),
            last_match: None,
            evidence: 0,
        }
    }

    /// The options in use.
    pub fn options(&self) -> &HistoryMemoryOptions {
        &self.options
    }

    /// Offers finished local map number `local_map` (numbers increase by one per local map;
    /// a smaller or equal number than the previous one forgets the evidence):
    /// `local_in_map` holds its landmarks in the global frame as estimated, `global_in_map`
    /// the global map's landmarks, and `old_indices` those of them that form the old map
    /// (mapped before the last one or two local maps). Returns the loop when this local map
    /// confirms one; the evidence is then forgotten, so the next loop needs
    /// `min_consecutive_matches` fresh local maps.
    ///
    /// Out-of-range or repeated indices and non-finite positions are skipped.
    pub fn add_local_map(
        &mut self,
        local_map: usize,
        local_in_map: &[MappedLandmark],
        global_in_map: &[MappedLandmark],
        old_indices: &[usize],
    ) -> Option<LoopClosure> {
        if self
            .recent
            .back()
            .is_some_and(|last| last.local_map >= local_map)
        {
            self.recent.clear();
        }
        self.constellation.sync(global_in_map, old_indices);
        self.last_match = self.constellation.find_place(local_in_map);
        let Some(place) = &self.last_match else {
            self.evidence = 0;
            return None;
        };
        let centroid = centroid_in_map(
            place
                .pairs
                .iter()
                .filter_map(|&(local, _)| local_in_map.get(local))
                .map(|landmark| landmark.position_in_map),
        );
        let newest = Evidence {
            local_map,
            old_from_local: place.old_from_local,
            local_centroid_in_map: centroid,
        };

        // Walk back over consecutive local maps while each agrees with all those kept.
        let mut chain = vec![newest];
        for prior in self.recent.iter().rev() {
            let expected = chain.last().map_or(local_map, |e| e.local_map);
            if prior.local_map + 1 != expected
                || !chain.iter().all(|kept| self.consistent(kept, prior))
            {
                break;
            }
            chain.push(*prior);
        }
        self.evidence = chain.len();
        self.recent.push_back(newest);
        while self.recent.len() > self.options.min_consecutive_matches.max(1) {
            self.recent.pop_front();
        }
        if self.evidence < self.options.min_consecutive_matches {
            return None;
        }
        self.recent.clear();
        Some(LoopClosure {
            local_map,
            correction: place.old_from_local,
            pairs: place.pairs.clone(),
            inliers: place.inliers,
            rms_residual_m: place.rms_residual_m,
            evidence: self.evidence,
        })
    }

    /// The place accepted for the last local map offered, if any (a loop or not).
    pub fn last_match(&self) -> Option<&PlaceMatch> {
        self.last_match.as_ref()
    }

    /// Consecutive local maps, ending with the last one offered, whose places agree (0 when
    /// the last one found no place).
    pub fn evidence(&self) -> usize {
        self.evidence
    }

    /// Forgets the accumulated evidence (for example after the caller has applied a
    /// correction by other means); the index of the old map is kept.
    pub fn forget_evidence(&mut self) {
        self.recent.clear();
        self.evidence = 0;
    }

    /// Whether two accepted places imply the same correction.
    fn consistent(&self, a: &Evidence, b: &Evidence) -> bool {
        let angle_ok = wrap_angle_rad(a.old_from_local.theta_rad - b.old_from_local.theta_rad)
            .abs()
            <= self.options.consistency_angle_rad;
        let distance_ok = [a.local_centroid_in_map, b.local_centroid_in_map]
            .iter()
            .all(|&centroid| {
                let (p, q) = (
                    transform(a.old_from_local, centroid),
                    transform(b.old_from_local, centroid),
                );
                (p[0] - q[0]).hypot(p[1] - q[1]) <= self.options.consistency_distance_m
            });
        angle_ok && distance_ok
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix2;

    use super::*;
    use crate::ekf_slam::landmark_info::LandmarkInfo;
    use crate::pose_graph::synthetic::Lcg;

    /// A tree of a synthetic park: true position and diameter.
    #[derive(Debug, Clone, Copy)]
    struct Tree {
        position: [f64; 2],
        diameter_m: f64,
    }

    fn mapped(position_in_map: [f64; 2], diameter_m: f64) -> MappedLandmark {
        MappedLandmark {
            position_in_map,
            covariance: Matrix2::identity() * 0.01,
            info: LandmarkInfo::first_seen(Some(diameter_m)),
        }
    }

    /// `count` trees at least `spacing_m` apart over a `side_m` square, diameters 0.15–0.6 m.
    fn random_park(rng: &mut Lcg, count: usize, side_m: f64, spacing_m: f64) -> Vec<Tree> {
        let mut trees: Vec<Tree> = Vec::new();
        while trees.len() < count {
            let position = [side_m * rng.uniform(), side_m * rng.uniform()];
            let clear = trees.iter().all(|t| {
                (t.position[0] - position[0]).hypot(t.position[1] - position[1]) >= spacing_m
            });
            if clear {
                trees.push(Tree {
                    position,
                    diameter_m: 0.15 + 0.45 * rng.uniform(),
                });
            }
        }
        trees
    }

    /// A planted grid: `columns` × `rows` nodes `spacing_m` apart, each planted with
    /// probability `planted`, trunks `jitter_m` (standard deviation) off their node, all of
    /// one species (diameters 0.30 ± 0.03 m): strong aliasing.
    fn grid_park(
        rng: &mut Lcg,
        columns: usize,
        rows: usize,
        spacing_m: f64,
        jitter_m: f64,
        planted: f64,
    ) -> Vec<Tree> {
        let mut trees = Vec::new();
        for column in 0..columns {
            for row in 0..rows {
                let keep = rng.uniform() < planted;
                let offset = [jitter_m * rng.gaussian(), jitter_m * rng.gaussian()];
                let diameter_m = 0.27 + 0.06 * rng.uniform();
                if keep {
                    trees.push(Tree {
                        position: [
                            column as f64 * spacing_m + offset[0],
                            row as f64 * spacing_m + offset[1],
                        ],
                        diameter_m,
                    });
                }
            }
        }
        trees
    }

    /// The old map: every tree as mapped earlier (0.05 m noise), global index = tree index.
    fn old_map(rng: &mut Lcg, trees: &[Tree]) -> Vec<MappedLandmark> {
        trees
            .iter()
            .map(|t| {
                let p = [
                    t.position[0] + 0.05 * rng.gaussian(),
                    t.position[1] + 0.05 * rng.gaussian(),
                ];
                mapped(p, t.diameter_m + 0.01 * rng.gaussian())
            })
            .collect()
    }

    /// A local map: the trees within `radius_m` of `centre`, as estimated in a global frame
    /// drifted by `estimated_from_true`, with `noise_m` of noise per axis; with the index of
    /// the tree each landmark is.
    fn local_view(
        rng: &mut Lcg,
        trees: &[Tree],
        centre: [f64; 2],
        radius_m: f64,
        estimated_from_true: Pose2,
        noise_m: f64,
    ) -> (Vec<MappedLandmark>, Vec<usize>) {
        let mut landmarks = Vec::new();
        let mut truth = Vec::new();
        for (index, tree) in trees.iter().enumerate() {
            let d = (tree.position[0] - centre[0]).hypot(tree.position[1] - centre[1]);
            if d > radius_m {
                continue;
            }
            let estimated = transform(estimated_from_true, tree.position);
            let noisy = [
                estimated[0] + noise_m * rng.gaussian(),
                estimated[1] + noise_m * rng.gaussian(),
            ];
            landmarks.push(mapped(noisy, tree.diameter_m + 0.02 * rng.gaussian()));
            truth.push(index);
        }
        (landmarks, truth)
    }

    /// Largest distance between where two corrections put the landmarks, and their angle
    /// difference.
    /// Asserts that `correction` is within 0.3 m (at every local landmark) and 1° of `truth`.
    fn assert_correction_close(correction: Pose2, truth: Pose2, local: &[MappedLandmark]) {
        let (distance_m, angle_rad) = correction_error(correction, truth, local);
        assert!(distance_m < 0.3, "{distance_m} m");
        assert!(
            angle_rad < 1f64.to_radians(),
            "{} deg",
            angle_rad.to_degrees()
        );
    }

    fn correction_error(found: Pose2, truth: Pose2, landmarks: &[MappedLandmark]) -> (f64, f64) {
        let distance = landmarks
            .iter()
            .map(|l| {
                let (a, b) = (
                    transform(found, l.position_in_map),
                    transform(truth, l.position_in_map),
                );
                (a[0] - b[0]).hypot(a[1] - b[1])
            })
            .fold(0.0, f64::max);
        (
            distance,
            wrap_angle_rad(found.theta_rad - truth.theta_rad).abs(),
        )
    }

    /// A pose, the angle as given (not wrapped).
    fn pose(x_m: f64, y_m: f64, theta_rad: f64) -> Pose2 {
        Pose2 {
            x_m,
            y_m,
            theta_rad,
        }
    }

    /// Pairs whose global index is the tree the local landmark really is.
    fn correct_pairs(pairs: &[(usize, usize)], truth: &[usize]) -> usize {
        pairs
            .iter()
            .filter(|&&(local, global)| truth.get(local) == Some(&global))
            .count()
    }

    #[test]
    fn test_recognises_a_revisit_despite_a_large_drift() {
        let mut rng = Lcg::new(7);
        let trees = random_park(&mut rng, 600, 160.0, 2.5);
        let global = old_map(&mut rng, &trees);
        let old: Vec<usize> = (0..global.len()).collect();
        // 9 m and 12° of drift around the origin: tens of metres at the park's far side.
        let estimated_from_true = pose(9.0, -6.0, 12f64.to_radians());
        let truth = estimated_from_true.inverse();
        let mut memory = HistoryMemory::new(HistoryMemoryOptions::default());
        let (local, ids) = local_view(
            &mut rng,
            &trees,
            [110.0, 70.0],
            18.0,
            estimated_from_true,
            0.2,
        );
        assert!(local.len() >= 15, "{}", local.len());
        assert_eq!(memory.add_local_map(5, &local, &global, &old), None);
        let place = memory.last_match().expect("the place is recognised");
        let (distance_m, angle_rad) = correction_error(place.old_from_local, truth, &local);
        assert!(distance_m < 0.3, "{distance_m} m");
        assert!(
            angle_rad < 1f64.to_radians(),
            "{} deg",
            angle_rad.to_degrees()
        );
        assert_eq!(correct_pairs(&place.pairs, &ids), place.inliers);
        assert!(
            place.inliers * 10 >= local.len() * 9,
            "{} of {}",
            place.inliers,
            local.len()
        );
        assert_eq!(memory.evidence(), 1);
    }

    #[test]
    fn test_two_consistent_local_maps_confirm_a_loop() {
        let mut rng = Lcg::new(11);
        let trees = random_park(&mut rng, 600, 160.0, 2.5);
        let global = old_map(&mut rng, &trees);
        let old: Vec<usize> = (0..global.len()).collect();
        let drift_a = pose(-7.0, 11.0, (-15f64).to_radians());
        // The drift grows a little from one local map to the next.
        let drift_b = pose(-7.3, 11.2, (-15.5f64).to_radians());
        let mut memory = HistoryMemory::new(HistoryMemoryOptions::default());
        let (local_a, _) = local_view(&mut rng, &trees, [60.0, 60.0], 18.0, drift_a, 0.2);
        let (local_b, ids_b) = local_view(&mut rng, &trees, [75.0, 65.0], 18.0, drift_b, 0.2);
        assert_eq!(memory.add_local_map(3, &local_a, &global, &old), None);
        assert_eq!(memory.evidence(), 1);
        let closure = memory
            .add_local_map(4, &local_b, &global, &old)
            .expect("a loop after two consistent local maps");
        assert_eq!((closure.local_map, closure.evidence), (4, 2));
        assert_correction_close(closure.correction, drift_b.inverse(), &local_b);
        assert_eq!(correct_pairs(&closure.pairs, &ids_b), closure.inliers);
        assert_eq!(closure.inliers, closure.pairs.len());
        // The evidence is spent: the next local map alone does not close again.
        let (local_c, _) = local_view(&mut rng, &trees, [90.0, 70.0], 18.0, drift_b, 0.2);
        assert_eq!(memory.add_local_map(5, &local_c, &global, &old), None);
    }

    #[test]
    fn test_gap_or_inconsistent_corrections_do_not_confirm() {
        let mut rng = Lcg::new(13);
        let trees = random_park(&mut rng, 600, 160.0, 2.5);
        let global = old_map(&mut rng, &trees);
        let old: Vec<usize> = (0..global.len()).collect();
        let drift = pose(4.0, 3.0, 8f64.to_radians());
        let other_drift = pose(4.0, 3.0, 20f64.to_radians());
        let mut memory = HistoryMemory::new(HistoryMemoryOptions::default());
        let (local_a, _) = local_view(&mut rng, &trees, [60.0, 60.0], 18.0, drift, 0.2);
        let (local_b, _) = local_view(&mut rng, &trees, [75.0, 65.0], 18.0, drift, 0.2);
        let (local_c, _) = local_view(&mut rng, &trees, [90.0, 70.0], 18.0, other_drift, 0.2);
        // Local maps 1 and 3 are not consecutive.
        assert_eq!(memory.add_local_map(1, &local_a, &global, &old), None);
        assert_eq!(memory.add_local_map(3, &local_b, &global, &old), None);
        assert_eq!(memory.evidence(), 1);
        // Local map 4 is consecutive but its correction differs by 12°.
        assert_eq!(memory.add_local_map(4, &local_c, &global, &old), None);
        assert_eq!(memory.evidence(), 1);
    }

    #[test]
    fn test_aliased_grid_is_not_confirmed_but_a_revisit_is() {
        let mut rng = Lcg::new(3);
        // 40 × 20 nodes 6 m apart; the old map is the western half.
        let trees = grid_park(&mut rng, 40, 20, 6.0, 0.4, 0.75);
        let global = old_map(&mut rng, &trees);
        let old: Vec<usize> = (0..trees.len())
            .filter(|&i| trees[i].position[0] < 117.0)
            .collect();
        let drift = pose(6.0, -4.0, 7f64.to_radians());
        let mut memory = HistoryMemory::new(HistoryMemoryOptions::default());
        let mut accepted = 0;
        // Eight consecutive local maps along the eastern half, never mapped before.
        for (k, x) in (0..8).map(|k| (k, 140.0 + 10.0 * k as f64)) {
            let (local, _) = local_view(&mut rng, &trees, [x, 57.0], 18.0, drift, 0.2);
            assert!(local.len() >= 15, "{}", local.len());
            assert_eq!(
                memory.add_local_map(10 + k, &local, &global, &old),
                None,
                "map {k}"
            );
            accepted += usize::from(memory.last_match().is_some());
        }
        // Each was turned down as ambiguous; had one slipped through, a single local map would
        // still not have confirmed it.
        assert_eq!(accepted, 0, "aliased places accepted");
        // Back in the western half: two consecutive local maps close the loop.
        let (local_a, _) = local_view(&mut rng, &trees, [50.0, 57.0], 18.0, drift, 0.2);
        let (local_b, ids_b) = local_view(&mut rng, &trees, [62.0, 57.0], 18.0, drift, 0.2);
        assert_eq!(memory.add_local_map(18, &local_a, &global, &old), None);
        assert_eq!(memory.evidence(), 1);
        let closure = memory
            .add_local_map(19, &local_b, &global, &old)
            .expect("the revisit is confirmed");
        assert_correction_close(closure.correction, drift.inverse(), &local_b);
        assert_eq!(correct_pairs(&closure.pairs, &ids_b), closure.inliers);
    }

    #[test]
    fn test_empty_and_tiny_inputs_do_not_panic() {
        let mut memory = HistoryMemory::new(HistoryMemoryOptions::default());
        let one = [mapped([1.0, 2.0], 0.3)];
        let two = [mapped([1.0, 2.0], 0.3), mapped([5.0, 2.0], 0.4)];
        let nan = [
            mapped([f64::NAN, 2.0], 0.3),
            mapped([1.0, f64::INFINITY], 0.3),
            mapped([3.0, 2.0], 0.3),
        ];
        assert_eq!(memory.add_local_map(0, &[], &[], &[]), None);
        assert_eq!(memory.add_local_map(1, &one, &[], &[0, 7]), None);
        assert_eq!(memory.add_local_map(2, &two, &two, &[0, 1, 1, 99]), None);
        assert_eq!(memory.add_local_map(3, &two, &two, &[0, 1]), None);
        assert_eq!(memory.add_local_map(4, &nan, &nan, &[0, 1, 2]), None);
        assert_eq!(memory.add_local_map(2, &one, &two, &[]), None);
        assert_eq!(memory.evidence(), 0);
        memory.forget_evidence();
        assert!(memory.last_match().is_none());
    }

    #[test]
    fn test_is_deterministic() {
        let run = || {
            let mut rng = Lcg::new(5);
            let trees = random_park(&mut rng, 300, 120.0, 2.5);
            let global = old_map(&mut rng, &trees);
            let old: Vec<usize> = (0..global.len()).collect();
            let drift = pose(3.0, 2.0, 30f64.to_radians());
            let (local, _) = local_view(&mut rng, &trees, [60.0, 60.0], 20.0, drift, 0.2);
            let mut memory = HistoryMemory::new(HistoryMemoryOptions::default());
            memory.add_local_map(0, &local, &global, &old);
            memory.last_match().cloned()
        };
        let first = run();
        assert!(first.is_some());
        assert_eq!(first, run());
    }
}
