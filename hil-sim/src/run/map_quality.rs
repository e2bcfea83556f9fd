//! How well the landmark map the EKF method built matches the world's trees: which trunk each
//! mapped landmark is a record of, how many trunks were mapped more than once (a second
//! record of a tree already in the map, which costs memory and time, as the filter's cost
//! grows with the square of its landmarks, and splits the tree's observations), how many
//! records belong to no tree, and how far the records lie from their trunks' centres.
//!
//! A record belongs to the trunk whose centre is nearest, if it lies within that trunk's
//! radius plus [`MATCH_DISTANCE_M`]; trunks stand at least a metre apart in the simulated
//! worlds, so a record within that distance can only be of that trunk.

use host::ekf_slam::MappedLandmark;
use serde::Serialize;

use crate::world::Landmark;

/// How far outside its trunk a record may lie and still count as a record of it, metres.
pub const MATCH_DISTANCE_M: f64 = 1.0;

/// The mapped landmarks against the world's trees (see the [module documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MapQuality {
    /// Landmarks in the final map.
    pub landmarks: usize,
    /// Trees in the world.
    pub trees: usize,
    /// Trees with at least one record.
    pub trees_mapped: usize,
    /// Trees with more than one record.
    pub trees_mapped_more_than_once: usize,
    /// Records beyond the first of each tree.
    pub extra_records: usize,
    /// Records within no tree's reach.
    pub spurious: usize,
    /// Root mean square distance of the records from their trunks' centres, metres.
    pub rms_error_m: f64,
    /// Mean of the records' diameters over their trunks' true diameters (records without a
    /// diameter left out).
    pub mean_diameter_ratio: f64,
}

impl MapQuality {
    /// Scores `map` against `trees`; `world_from_map` takes a map position into the world
    /// frame.
    pub fn new(
        map: &[MappedLandmark],
        trees: &[Landmark],
        world_from_map: impl Fn([f64; 2]) -> [f64; 2],
    ) -> MapQuality {
        let mut records_of = vec![0usize; trees.len()];
        let (mut spurious, mut sum_sq_m2, mut matched) = (0, 0.0, 0usize);
        let (mut ratio_sum, mut ratio_count) = (0.0, 0usize);
        for landmark in map {
            let [x, y] = world_from_map(landmark.position_in_map);
            let nearest = trees
                .iter()
                .enumerate()
                .map(|(i, tree)| (i, (x - tree.center_m[0]).hypot(y - tree.center_m[1])))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match nearest {
                Some((i, distance_m)) if distance_m <= trees[i].radius_m + MATCH_DISTANCE_M => {
                    records_of[i] += 1;
                    matched += 1;
                    sum_sq_m2 += distance_m * distance_m;
                    if let Some(diameter_m) = landmark.info.diameter_m {
                        ratio_sum += diameter_m / (2.0 * trees[i].radius_m);
                        ratio_count += 1;
                    }
                }
                _ => spurious += 1,
            }
        }
        MapQuality {
            landmarks: map.len(),
            trees: trees.len(),
            trees_mapped: records_of.iter().filter(|&&n| n > 0).count(),
            trees_mapped_more_than_once: records_of.iter().filter(|&&n| n > 1).count(),
            extra_records: records_of.iter().map(|&n| n.saturating_sub(1)).sum(),
            spurious,
            rms_error_m: (sum_sq_m2 / matched.max(1) as f64).sqrt(),
            mean_diameter_ratio: ratio_sum / ratio_count.max(1) as f64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use host::ekf_slam::LandmarkInfo;
    use nalgebra::Matrix2;

    fn tree(id: u32, center_m: [f64; 2], radius_m: f64) -> Landmark {
        Landmark {
            id,
            center_m,
            radius_m,
        }
    }

    fn record(position_in_map: [f64; 2], diameter_m: f64) -> MappedLandmark {
        MappedLandmark {
            position_in_map,
            covariance: Matrix2::identity(),
            info: LandmarkInfo::first_seen(Some(diameter_m)),
        }
    }

    #[test]
    fn counts_second_records_and_records_of_no_tree() {
        let trees = [
            tree(0, [0.0, 0.0], 0.5),
            tree(1, [10.0, 0.0], 0.3),
            tree(2, [0.0, 10.0], 0.2),
        ];
        // The map is the world shifted by (1, 0): its records lie at tree − (1, 0).
        let map = [
            record([-1.1, 0.0], 1.0),
            record([-0.6, 0.3], 0.5),
            record([9.0, 0.0], 0.6),
            record([4.0, 4.0], 0.4),
        ];
        let quality = MapQuality::new(&map, &trees, |[x, y]| [x + 1.0, y]);
        assert_eq!(quality.landmarks, 4);
        assert_eq!(quality.trees, 3);
        assert_eq!(quality.trees_mapped, 2);
        assert_eq!(quality.trees_mapped_more_than_once, 1);
        assert_eq!(quality.extra_records, 1);
        assert_eq!(quality.spurious, 1);
        let expected_m = ((0.01 + 0.16 + 0.09 + 0.0) / 3.0f64).sqrt();
        assert!((quality.rms_error_m - expected_m).abs() < 1e-12);
        assert!((quality.mean_diameter_ratio - (1.0 + 0.5 + 1.0) / 3.0).abs() < 1e-12);
    }
}
