//! The camera method's history memory: the features of finished local maps, kept with their
//! appearance and uncertainty so that a place seen before is recognised and its features
//! used again instead of new ones.
//!
//! Local maps are chained: each starts at the camera's pose in the one before, known only as
//! well as the camera was then. Without a memory, a camera that comes back to a place mapped
//! two local maps ago starts new features there, and the error accumulated along the chain
//! stays. With it (as the laser method's history memory does for trees, and as map re-use
//! does in MonoSLAM), whenever the filter wants new features:
//!
//! 1. **Candidates**: the stored features that the camera's estimate puts in view, away from
//!    the features already tracked, grouped by the local map they were last part of. The map
//!    with most candidates is the place to test.
//! 2. **Where to look**: the frames of that map and of the current one are related through
//!    every rebase between them, each as uncertain as the camera was when its map ended.
//!    [`CameraHistory`] sums those variances along the chain (per axis, position and
//!    angle), and the test runs in a filter holding the camera with its pose widened by that
//!    sum ([`MonoEkf::camera_only`](super::mono_ekf::MonoEkf::camera_only)), its heading at
//!    least to what the search box reaches (a monocular EKF is surer of its heading than it
//!    is right after a fast turn), and the candidates. The old map is the reference the
//!    camera is placed against: its features enter with their geometry fixed, all but the
//!    depth it never measured. Each candidate is searched for in its innovation ellipse
//!    there, its patch warped from its first sighting.
//! 3. **Consensus, not coincidence**: one match and one look-alike are easily confused, a
//!    consistent set is not. Each match in turn updates the test's filter alone; the matches
//!    then inside their 99 % innovation gate support it (the gate of a feature whose depth
//!    the old map never fixed stays long along its epipolar line, where a fixed pixel
//!    distance would refuse it). The best hypothesis needs at least
//!    [`CameraHistoryOptions::min_support`] supporters, else the place is refused and
//!    nothing changes.
//! 4. **Joining**: the supporters update that filter, which gives the camera's pose as the
//!    old map sees it. The current local map is moved onto it (its frame in the world is
//!    corrected, its features unchanged relative to the camera), and the supporters enter the
//!    current local map with the covariance they were stored with, as features tracked from
//!    then on.
//!    When they leave the view again their record is updated, so a place revisited does not
//!    grow the map.
//!
//! Trade-offs: the current local map's placement is corrected, not the frames before the
//! recognition (the trajectory before a revisit keeps its drift); the correlations of the
//! re-used features with the camera they were mapped from are dropped, as in any map re-use
//! with local maps; and a single camera's scale drift is not a rigid motion, so a revisit
//! after a large change of scale is not recognised.

use nalgebra::{DMatrix, UnitQuaternion, Vector3};

use super::appearance::Appearance;
use super::mono_ekf::{FeatureKind, feature_point, moved_feature_with_covariance};

/// Settings of the history memory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraHistoryOptions {
    /// Off: finished local maps are kept only as points.
    pub enabled: bool,
    /// A place is recognised when at least this many of its features agree on one camera
    /// pose.
    pub min_support: usize,
    /// At most this many of a place's features are searched for, those found most often
    /// first.
    pub max_candidates: usize,
}

impl Default for CameraHistoryOptions {
    /// Six agreeing features out of at most 30 searched.
    fn default() -> Self {
        CameraHistoryOptions {
            enabled: true,
            min_support: 6,
            max_candidates: 30,
        }
    }
}

/// A feature of a finished local map.
#[derive(Clone, Debug)]
pub struct StoredFeature {
    pub kind: FeatureKind,
    /// Its numbers in the world frame.
    pub feature_in_world: Vec<f64>,
    /// Their covariance (relative to the frame of the local map it was last part of).
    pub covariance: DMatrix<f64>,
    /// Its first sighting, the camera's orientation in the world frame.
    pub appearance: Appearance,
    /// The local map it was last part of.
    pub local_map: usize,
    /// Frames it was measured in, over every local map it was tracked in.
    pub found: u32,
}

/// The finished local maps' features and the chain's uncertainty. See the
/// [module documentation](self).
#[derive(Clone, Debug)]
pub struct CameraHistory {
    features: Vec<StoredFeature>,
    /// For each local map, the position (m²) and angle (rad²) variances of its frame
    /// relative to the first one's, summed over the rebases between them.
    chain_variances: Vec<(f64, f64)>,
}

impl Default for CameraHistory {
    fn default() -> Self {
        CameraHistory {
            features: Vec::new(),
            chain_variances: vec![(0.0, 0.0)],
        }
    }
}

impl CameraHistory {
    /// Index of the local map being built.
    pub fn current_map(&self) -> usize {
        self.chain_variances.len() - 1
    }

    /// A new local map starts where the camera's pose in the one before was known to
    /// `position_variance_m2` and `angle_variance_rad2` (per axis).
    pub fn start_map(&mut self, position_variance_m2: f64, angle_variance_rad2: f64) {
        let (position, angle) = self.chain_variances[self.current_map()];
        self.chain_variances
            .push((position + position_variance_m2, angle + angle_variance_rad2));
    }

    /// The variances (position m², angle rad², per axis) of the current local map's frame
    /// relative to local map `map`'s.
    pub fn chain_variances_since(&self, map: usize) -> (f64, f64) {
        let now = self.chain_variances[self.current_map()];
        let then = self.chain_variances[map.min(self.current_map())];
        (now.0 - then.0, now.1 - then.1)
    }

    /// Keeps a feature of the local map being finished, whose frame in the world is
    /// `world_from_local` (origin, rotation), given in that map's frame. `id` is the record it
    /// came from when it was recalled. Returns its record.
    #[allow(clippy::too_many_arguments)]
    pub fn store(
        &mut self,
        id: Option<usize>,
        world_from_local: (Vector3<f64>, UnitQuaternion<f64>),
        kind: FeatureKind,
        feature: &[f64],
        covariance: &DMatrix<f64>,
        mut appearance: Appearance,
        found: u32,
    ) -> usize {
        let (origin, rotation) = world_from_local;
        let (feature_in_world, covariance) =
            moved_feature_with_covariance(kind, feature, covariance, rotation, origin);
        appearance.change_frame(rotation);
        let stored = StoredFeature {
            kind,
            feature_in_world,
            covariance,
            appearance,
            local_map: self.current_map(),
            found,
        };
        match id.filter(|&id| id < self.features.len()) {
            Some(id) => {
                let found_before = self.features[id].found;
                self.features[id] = StoredFeature {
                    found: found_before + stored.found,
                    ..stored
                };
                id
            }
            None => {
                self.features.push(stored);
                self.features.len() - 1
            }
        }
    }

    /// Every record.
    pub fn features(&self) -> &[StoredFeature] {
        &self.features
    }

    /// The records' points with a finite depth, world frame, but those in `skip`.
    pub fn points(&self, skip: &[usize]) -> Vec<Vector3<f64>> {
        self.features
            .iter()
            .enumerate()
            .filter(|(id, _)| !skip.contains(id))
            .filter_map(|(_, f)| feature_point(f.kind, &f.feature_in_world))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_chain_sums_the_rebases_between_two_maps() {
        let mut history = CameraHistory::default();
        history.start_map(0.01, 0.001);
        history.start_map(0.04, 0.002);
        assert_eq!(history.current_map(), 2);
        let (position, angle) = history.chain_variances_since(0);
        assert!((position - 0.05).abs() < 1e-12 && (angle - 0.003).abs() < 1e-12);
        let (position, angle) = history.chain_variances_since(1);
        assert!((position - 0.04).abs() < 1e-12 && (angle - 0.002).abs() < 1e-12);
        assert_eq!(history.chain_variances_since(2), (0.0, 0.0));
    }
}
