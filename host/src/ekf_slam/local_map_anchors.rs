//! Where each finished local map lies in the final map.
//!
//! A local map's landmarks are kept in its own base frame, numbered as the global map numbers
//! them once it is joined ([`GlobalMap::last_joined_ids`]). At the end of a run each base is
//! fitted again (least squares, rigid) to where the map finally put those landmarks, after
//! every later fusion and closed loop. A pose recorded in a local map's base frame, composed
//! with that fitted base, follows those corrections; the filter's estimate at the time does
//! not, so a stretch driven before a loop closed keeps the drift it had then.
//!
//! Trade-off: the fitted base is only as good as the local map's landmarks; a local map with
//! fewer than [`LocalMapAnchors::MIN_LANDMARKS`] of them left in the map has none.

use super::constellation::fit_rigid;
use super::global_map::GlobalMap;
use crate::geometry::Pose2;

/// The landmarks of one finished local map.
#[derive(Debug, Clone, PartialEq)]
struct Anchors {
    /// The number each landmark stands as in the global map.
    ids: Vec<usize>,
    landmarks_in_base: Vec<[f64; 2]>,
}

/// The landmarks of every finished local map, in its base frame. See the
/// [module documentation](self).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LocalMapAnchors {
    maps: Vec<Anchors>,
}

impl LocalMapAnchors {
    /// Fewest landmarks a fitted base stands on.
    pub const MIN_LANDMARKS: usize = 3;

    /// Records the next local map: `landmarks_in_base` as joined, and `ids`, the number each
    /// stands as in the global map ([`GlobalMap::last_joined_ids`] right after its join).
    pub fn record(&mut self, ids: Vec<usize>, landmarks_in_base: Vec<[f64; 2]>) {
        debug_assert_eq!(ids.len(), landmarks_in_base.len());
        self.maps.push(Anchors {
            ids,
            landmarks_in_base,
        });
    }

    /// Follows the global map's merges of records of one trunk
    /// ([`GlobalMap::last_merged_ids`]): a landmark that stood as `from` stands as `to`.
    pub fn follow(&mut self, merged: &[(usize, usize)]) {
        for &(from, to) in merged {
            for id in self.maps.iter_mut().flat_map(|a| a.ids.iter_mut()) {
                if *id == from {
                    *id = to;
                }
            }
        }
    }

    /// Local maps recorded.
    pub fn len(&self) -> usize {
        self.maps.len()
    }

    /// True when none was recorded.
    pub fn is_empty(&self) -> bool {
        self.maps.is_empty()
    }

    /// The base of every recorded local map (`map_from_base`) fitted to where `global` now
    /// puts its landmarks; `None` for those with too few left.
    pub fn bases_in_map(&self, global: &GlobalMap) -> Vec<Option<Pose2>> {
        self.maps
            .iter()
            .map(|anchors| {
                let (from, to): (Vec<[f64; 2]>, Vec<[f64; 2]>) = anchors
                    .landmarks_in_base
                    .iter()
                    .zip(global.positions_by_id(&anchors.ids))
                    .filter_map(|(&in_base, in_map)| in_map.map(|in_map| (in_base, in_map)))
                    .unzip();
                if from.len() < Self::MIN_LANDMARKS {
                    return None;
                }
                fit_rigid(&from, &to)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix3;

    use super::*;
    use crate::ekf_slam::AssociationOptions;
    use crate::ekf_slam::local_map::seen_once;

    #[test]
    fn an_anchor_follows_its_landmark_into_the_record_it_was_merged_into() {
        let trees = [[8.0, 3.0], [12.0, -4.0], [15.0, 6.0]];
        let local = seen_once(&trees);
        let mut global = GlobalMap::new(Pose2::IDENTITY, Matrix3::zeros());
        let in_base: Vec<[f64; 2]> = (0..local.landmark_count())
            .map(|i| local.state().landmark(i))
            .collect();
        global
            .join(local, &AssociationOptions::default(), &[])
            .expect("join");
        let mut anchors = LocalMapAnchors::default();
        // Recorded with the third tree numbered 9, a number merged into 2 since.
        anchors.record(vec![0, 1, 9], in_base);
        assert_eq!(anchors.bases_in_map(&global), vec![None]);
        anchors.follow(&[(9, 2)]);
        let base = anchors.bases_in_map(&global)[0].expect("three landmarks fit a base");
        assert!(base.x_m.abs() < 1e-9 && base.y_m.abs() < 1e-9 && base.theta_rad.abs() < 1e-9);
    }

    #[test]
    fn a_base_follows_its_landmarks_when_the_map_moves() {
        let trees = [[8.0, 3.0], [12.0, -4.0], [15.0, 6.0], [20.0, -1.0]];
        let local = seen_once(&trees);
        let mut global = GlobalMap::new(Pose2::IDENTITY, Matrix3::zeros());
        let mut anchors = LocalMapAnchors::default();
        let in_base = (0..local.landmark_count())
            .map(|i| local.state().landmark(i))
            .collect();
        global
            .join(local, &AssociationOptions::default(), &[])
            .expect("join");
        anchors.record(global.last_joined_ids().to_vec(), in_base);
        // A local map of two trees has no base to fit.
        anchors.record(vec![0, 1], vec![[1.0, 0.0], [2.0, 0.0]]);

        let moved = Pose2 {
            x_m: 3.0,
            y_m: -2.0,
            theta_rad: 0.4,
        };
        global.transform(moved);
        let bases = anchors.bases_in_map(&global);
        assert_eq!(bases.len(), 2);
        let base = bases[0].expect("four landmarks fit a base");
        for (found, expected) in [
            (base.x_m, moved.x_m),
            (base.y_m, moved.y_m),
            (base.theta_rad, moved.theta_rad),
        ] {
            assert!((found - expected).abs() < 1e-9, "{base:?}");
        }
        assert_eq!(bases[1], None);
    }
}
