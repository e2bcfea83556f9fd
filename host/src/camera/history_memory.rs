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
//!    with most candidates is the place to test. Only maps whose camera was near and looked
//!    the same way are counted ([`PlaceIndex`]), so the cost of the step does not grow with
//!    the run.
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

use std::collections::HashMap;

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
    /// The side of the cells the place index splits the world into, in the filter's units
    /// (about the depth a new feature is given).
    pub place_cell_m: f64,
    /// A cell and viewing direction remembers the newest this many local maps seen from it.
    pub maps_per_place: usize,
    /// At most this many local maps near the camera are counted for candidates.
    pub max_maps_counted: usize,
}

impl Default for CameraHistoryOptions {
    /// Six agreeing features out of at most 30 searched; cells of 10 m (the inverse of a new
    /// feature's initial inverse depth), four maps per place, eight counted.
    fn default() -> Self {
        CameraHistoryOptions {
            enabled: true,
            min_support: 6,
            max_candidates: 30,
            place_cell_m: 10.0,
            maps_per_place: 4,
            max_maps_counted: 8,
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
    /// For each local map, the records stored from it (a record recalled and stored again
    /// from a later map stays listed here, and is skipped).
    members: Vec<Vec<usize>>,
    /// For each local map, the position (m²) and angle (rad²) variances of its frame
    /// relative to the first one's, summed over the rebases between them.
    chain_variances: Vec<(f64, f64)>,
    places: PlaceIndex,
}

impl Default for CameraHistory {
    fn default() -> Self {
        CameraHistory::new(&CameraHistoryOptions::default())
    }
}

impl CameraHistory {
    /// An empty memory whose place index is set by `options`.
    pub fn new(options: &CameraHistoryOptions) -> Self {
        CameraHistory {
            features: Vec::new(),
            members: vec![Vec::new()],
            chain_variances: vec![(0.0, 0.0)],
            places: PlaceIndex::new(options.place_cell_m, options.maps_per_place),
        }
    }

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
        self.members.push(Vec::new());
    }

    /// The camera of the local map being built is at `position_in_world` looking along
    /// `axis_in_world`.
    pub fn note_view(&mut self, position_in_world: &Vector3<f64>, axis_in_world: &Vector3<f64>) {
        let map = self.current_map();
        self.places.note(map, position_in_world, axis_in_world);
    }

    /// The finished local maps whose camera was nearest to `position_in_world` looking
    /// along `axis_in_world`, at most `max_maps`, each with the records it was last part of.
    /// The cost is bounded by the index's settings, not by the number of maps.
    pub fn maps_near(
        &self,
        position_in_world: &Vector3<f64>,
        axis_in_world: &Vector3<f64>,
        max_maps: usize,
    ) -> Vec<(usize, Vec<usize>)> {
        self.places
            .near(
                position_in_world,
                axis_in_world,
                max_maps,
                self.current_map(),
            )
            .into_iter()
            .map(|map| {
                let ids = self.members[map]
                    .iter()
                    .copied()
                    .filter(|&id| self.features[id].local_map == map)
                    .collect();
                (map, ids)
            })
            .collect()
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
        appearance.change_frame(rotation, origin);
        let stored = StoredFeature {
            kind,
            feature_in_world,
            covariance,
            appearance,
            local_map: self.current_map(),
            found,
        };
        let id = match id.filter(|&id| id < self.features.len()) {
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
        };
        let map = self.current_map();
        if !self.members[map].contains(&id) {
            self.members[map].push(id);
        }
        id
    }

    /// Every record.
    pub fn features(&self) -> &[StoredFeature] {
        &self.features
    }

    /// Where each of [`CameraHistory::points`]' points was first seen (frame number and
    /// pixel), in the same order.
    pub fn sightings(&self, skip: &[usize]) -> Vec<(usize, [f64; 2])> {
        self.features
            .iter()
            .enumerate()
            .filter(|(id, _)| !skip.contains(id))
            .filter(|(_, f)| feature_point(f.kind, &f.feature_in_world).is_some())
            .map(|(_, f)| f.appearance.sighting())
            .collect()
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

/// A cell of the world and a bin of viewing directions.
type PlaceKey = ([i64; 3], u8);

/// Which local maps the camera was in at each place: the world cut into cubes, the viewing
/// direction into the 24 quarters of a cube's faces, and for each cube and quarter the
/// newest few maps whose camera was there. A look-up reads the 27 cubes around the camera
/// and the quarters facing its way, so it costs the same however many maps there are; a
/// place visited again and again remembers its newest visits, whose maps hold the features
/// of the older ones that were recalled.
#[derive(Clone, Debug)]
pub struct PlaceIndex {
    cell_m: f64,
    maps_per_place: usize,
    places: HashMap<PlaceKey, Vec<usize>>,
}

impl PlaceIndex {
    fn new(cell_m: f64, maps_per_place: usize) -> Self {
        PlaceIndex {
            cell_m: if cell_m.is_finite() && cell_m > 0.0 {
                cell_m
            } else {
                CameraHistoryOptions::default().place_cell_m
            },
            maps_per_place: maps_per_place.max(1),
            places: HashMap::new(),
        }
    }

    fn cell(&self, position: &Vector3<f64>) -> [i64; 3] {
        position.map(|c| (c / self.cell_m).floor() as i64).into()
    }

    /// Map `map`'s camera was at `position` looking along `axis`.
    fn note(&mut self, map: usize, position: &Vector3<f64>, axis: &Vector3<f64>) {
        let Some(bin) = direction_bin(axis) else {
            return;
        };
        let maps = self.places.entry((self.cell(position), bin)).or_default();
        if maps.last() != Some(&map) {
            maps.push(map);
            if maps.len() > self.maps_per_place {
                maps.remove(0);
            }
        }
    }

    /// The maps before `before` seen from the cubes around `position` and the quarters
    /// facing along `axis`, nearest first (the angle from `axis` to the quarter's centre,
    /// plus a radian for each cube away), newest first among equals; at most `max_maps`.
    fn near(
        &self,
        position: &Vector3<f64>,
        axis: &Vector3<f64>,
        max_maps: usize,
        before: usize,
    ) -> Vec<usize> {
        let Some(axis) = axis.try_normalize(f64::EPSILON) else {
            return Vec::new();
        };
        let centre = self.cell(position);
        let mut scored: Vec<(f64, usize)> = Vec::new();
        for bin in 0..24 {
            let cos = bin_centre(bin).dot(&axis);
            if cos <= 0.0 {
                continue;
            }
            let angle = cos.min(1.0).acos();
            for dx in -1..=1i64 {
                for dy in -1..=1i64 {
                    for dz in -1..=1i64 {
                        let cell = [centre[0] + dx, centre[1] + dy, centre[2] + dz];
                        let Some(maps) = self.places.get(&(cell, bin)) else {
                            continue;
                        };
                        let away = (dx.abs() + dy.abs() + dz.abs()) as f64;
                        for &map in maps.iter().filter(|&&map| map < before) {
                            scored.push((angle + away, map));
                        }
                    }
                }
            }
        }
        scored.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
        let mut maps: Vec<usize> = Vec::with_capacity(max_maps);
        for (_, map) in scored {
            if maps.len() == max_maps {
                break;
            }
            if !maps.contains(&map) {
                maps.push(map);
            }
        }
        maps
    }
}

/// The quarter of a cube face `direction` points through: the face (its axis and sign) and
/// the signs of the other two components; `None` for a zero or non-finite direction.
fn direction_bin(direction: &Vector3<f64>) -> Option<u8> {
    if !direction.iter().all(|c| c.is_finite()) || direction.norm() == 0.0 {
        return None;
    }
    let axis = direction.iamax();
    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
    let face = 2 * axis as u8 + u8::from(direction[axis] < 0.0);
    Some(4 * face + 2 * u8::from(direction[b] < 0.0) + u8::from(direction[c] < 0.0))
}

/// The unit direction through the centre of quarter `bin` (see [`direction_bin`]).
fn bin_centre(bin: u8) -> Vector3<f64> {
    let face = bin / 4;
    let axis = usize::from(face / 2);
    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
    let sign = |negative: bool| if negative { -1.0 } else { 1.0 };
    let mut centre = Vector3::zeros();
    centre[axis] = sign(face % 2 == 1);
    centre[b] = 0.5 * sign(bin & 2 != 0);
    centre[c] = 0.5 * sign(bin & 1 != 0);
    centre.normalize()
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

    #[test]
    fn every_direction_falls_in_the_quarter_around_it() {
        for bin in 0..24 {
            assert_eq!(direction_bin(&bin_centre(bin)), Some(bin));
        }
        assert_eq!(direction_bin(&Vector3::zeros()), None);
    }

    #[test]
    fn the_place_index_finds_maps_seen_from_near_and_the_same_way() {
        let mut index = PlaceIndex::new(10.0, 2);
        let ahead = Vector3::new(0.0, 0.0, 1.0);
        let behind = -ahead;
        index.note(0, &Vector3::new(1.0, 1.0, 1.0), &ahead);
        index.note(1, &Vector3::new(1.0, 1.0, 1.0), &behind);
        index.note(2, &Vector3::new(15.0, 1.0, 1.0), &ahead);
        index.note(3, &Vector3::new(100.0, 1.0, 1.0), &ahead);
        let near = index.near(&Vector3::new(2.0, 2.0, 2.0), &ahead, 8, 4);
        assert_eq!(near, vec![0, 2]);
        // A place keeps its newest maps.
        index.note(4, &Vector3::new(1.0, 1.0, 1.0), &ahead);
        index.note(5, &Vector3::new(1.0, 1.0, 1.0), &ahead);
        let near = index.near(&Vector3::new(2.0, 2.0, 2.0), &ahead, 2, 6);
        assert_eq!(near, vec![5, 4]);
        // The map being built is not a candidate, and does not take a place.
        let near = index.near(&Vector3::new(2.0, 2.0, 2.0), &ahead, 2, 5);
        assert_eq!(near, vec![4, 2]);
    }

    #[test]
    fn a_recalled_record_is_listed_under_the_map_it_was_stored_from_last() {
        let mut history = CameraHistory::default();
        let appearance = Appearance::new(
            0,
            &image::GrayImage::from_fn(20, 20, |x, y| image::Luma([(x * 7 + y * 13) as u8])),
            [10, 10],
            3,
            Vector3::zeros(),
            UnitQuaternion::identity(),
        )
        .expect("fits");
        let frame = (Vector3::zeros(), UnitQuaternion::identity());
        let covariance = DMatrix::identity(3, 3) * 0.01;
        let point = [0.0, 0.0, 5.0];
        history.note_view(&Vector3::zeros(), &Vector3::z());
        let id = history.store(
            None,
            frame,
            FeatureKind::Euclidean,
            &point,
            &covariance,
            appearance.clone(),
            3,
        );
        history.start_map(0.0, 0.0);
        history.note_view(&Vector3::zeros(), &Vector3::z());
        history.store(
            Some(id),
            frame,
            FeatureKind::Euclidean,
            &point,
            &covariance,
            appearance,
            2,
        );
        history.start_map(0.0, 0.0);
        let near = history.maps_near(&Vector3::zeros(), &Vector3::z(), 8);
        assert_eq!(near, vec![(1, vec![id]), (0, vec![])]);
        assert_eq!(history.features()[id].found, 5);
    }
}
