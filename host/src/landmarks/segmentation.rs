//! Scan segmentation by the adaptive breakpoint detector (Borges and Aldon, "Line Extraction
//! in 2D Range Images for Mobile Robotics", J. Intell. Robot. Syst. 40, 2004).
//!
//! Consecutive returns belong to one cluster when the distance between them is below
//!
//! ```text
//! D = min(r_a, r_b) · sin(Δφ) / sin(λ − Δφ) + 3 σ_r
//! ```
//!
//! where `Δφ` is the angle between the two beams, `λ` the most grazing angle between a beam and
//! a surface that still counts as one surface, and `σ_r` the range noise. The first term is how
//! far apart two returns on a surface seen at angle `λ` lie, so the threshold grows with range
//! the way the spacing of returns does (Dietmayer's threshold `C0 + C1 · r` has the same form).
//! A beam without a return always ends a cluster: the beam passed through the gap.
//!
//! Each cluster also records whether the object may continue, hidden, beyond either end: the
//! neighbouring beam hit something nearer (an occlusion edge), or the cluster touches the
//! first or last beam of the scan.

use serde::{Deserialize, Serialize};

use super::range_scan::RangeScan;

/// How a scan is cut into clusters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SegmentationOptions {
    /// `λ`: the most grazing angle between beam and surface at which consecutive returns still
    /// join, radians; 15°. Smaller joins more (walls seen edge-on stay whole, but a trunk can
    /// merge with what stands behind it); larger splits more.
    pub min_surface_angle_rad: f64,
    /// `σ_r`: standard deviation of a range, metres; 0.01. The threshold adds `3 σ_r`.
    pub range_sigma_m: f64,
    /// Clusters with fewer returns are dropped; 2.
    pub min_points: usize,
}

impl Default for SegmentationOptions {
    /// `λ` = 15°, `σ_r` = 1 cm, at least 2 returns.
    fn default() -> Self {
        SegmentationOptions {
            min_surface_angle_rad: 15f64.to_radians(),
            range_sigma_m: 0.01,
            min_points: 2,
        }
    }
}

/// Consecutive returns of one scan that lie on one surface, as [`segment_scan`] finds them.
#[derive(Clone, Debug, PartialEq)]
pub struct Cluster {
    /// First beam of the cluster.
    pub first_beam: usize,
    /// Last beam of the cluster (inclusive); every beam in `first_beam..=last_beam` is a
    /// return.
    pub last_beam: usize,
    /// End points of the beams `first_beam..=last_beam`, sensor frame, metres, in beam order.
    pub points_in_sensor: Vec<[f64; 2]>,
    /// The object may continue beyond `first_beam`, hidden: the beam before it hit something
    /// nearer, or `first_beam` is the scan's first beam.
    pub occluded_start: bool,
    /// The object may continue beyond `last_beam`, hidden: the beam after it hit something
    /// nearer, or `last_beam` is the scan's last beam.
    pub occluded_end: bool,
}

impl Cluster {
    /// Number of returns.
    pub fn len(&self) -> usize {
        self.points_in_sensor.len()
    }

    /// True if the cluster holds no returns (never for clusters from [`segment_scan`]).
    pub fn is_empty(&self) -> bool {
        self.points_in_sensor.is_empty()
    }

    /// Distance between the first and last return, metres (0 for an empty cluster).
    pub fn width_m(&self) -> f64 {
        match (self.points_in_sensor.first(), self.points_in_sensor.last()) {
            (Some(a), Some(b)) => (b[0] - a[0]).hypot(b[1] - a[1]),
            _ => 0.0,
        }
    }
}

/// Breakpoint distance `D` between returns at `range_a_m` and `range_b_m` on beams `step_rad`
/// apart (see the [module documentation](self)).
pub(crate) fn breakpoint_distance_m(
    range_a_m: f64,
    range_b_m: f64,
    step_rad: f64,
    options: &SegmentationOptions,
) -> f64 {
    let step_rad = step_rad.abs();
    // Beams wider apart than `λ` would give a negative or infinite threshold; keep the
    // denominator positive so such scans only split more.
    let denominator = (options.min_surface_angle_rad - step_rad).max(1e-3).sin();
    range_a_m.min(range_b_m) * step_rad.sin() / denominator + 3.0 * options.range_sigma_m
}

/// Cuts `scan` into clusters of consecutive returns (see the [module documentation](self)),
/// in beam order. Clusters with fewer than `options.min_points` returns are dropped, but still
/// occlude their neighbours.
pub fn segment_scan(scan: &RangeScan, options: &SegmentationOptions) -> Vec<Cluster> {
    let step_rad = scan.angle_step_rad();
    let mut clusters = Vec::new();
    let mut beam = 0;
    while beam < scan.len() {
        let Some(first_point) = scan.point_in_sensor(beam) else {
            beam += 1;
            continue;
        };
        let first_beam = beam;
        let mut points_in_sensor = vec![first_point];
        let mut last_point = first_point;
        while let Some(next_point) = scan.point_in_sensor(beam + 1) {
            let range_last_m = last_point[0].hypot(last_point[1]);
            let range_next_m = next_point[0].hypot(next_point[1]);
            let gap_m = (next_point[0] - last_point[0]).hypot(next_point[1] - last_point[1]);
            if gap_m > breakpoint_distance_m(range_last_m, range_next_m, step_rad, options) {
                break;
            }
            points_in_sensor.push(next_point);
            last_point = next_point;
            beam += 1;
        }
        let last_beam = beam;
        beam += 1;

        let nearer = |neighbour: Option<usize>, own_beam: usize| match neighbour {
            // The scan's edge: whatever lies beyond was not looked at.
            None => true,
            Some(n) => match (scan.range_m(n), scan.range_m(own_beam)) {
                (Some(neighbour_m), Some(own_m)) => neighbour_m < own_m,
                _ => false,
            },
        };
        let occluded_start = nearer(first_beam.checked_sub(1), first_beam);
        let after = (last_beam + 1 < scan.len()).then_some(last_beam + 1);
        let occluded_end = nearer(after, last_beam);
        if points_in_sensor.len() >= options.min_points {
            clusters.push(Cluster {
                first_beam,
                last_beam,
                points_in_sensor,
                occluded_start,
                occluded_end,
            });
        }
    }
    clusters
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::test_scene::{Scene, Shape};

    #[test]
    fn test_empty_scan() {
        let scan = RangeScan::new(Vec::new(), 0.0, 0.01, 10.0);
        assert!(segment_scan(&scan, &SegmentationOptions::default()).is_empty());
    }

    #[test]
    fn test_no_return_splits() {
        let scan = RangeScan::new(vec![5.0, 5.0, f64::NAN, 5.0, 5.0, 5.0], 0.0, 0.01, 10.0);
        let clusters = segment_scan(&scan, &SegmentationOptions::default());
        assert_eq!(clusters.len(), 2);
        assert_eq!((clusters[0].first_beam, clusters[0].last_beam), (0, 1));
        assert_eq!((clusters[1].first_beam, clusters[1].last_beam), (3, 5));
        // Scan edges count as occluders; a missing return does not.
        assert!(clusters[0].occluded_start && !clusters[0].occluded_end);
        assert!(!clusters[1].occluded_start && clusters[1].occluded_end);
    }

    #[test]
    fn test_range_jump_splits_and_marks_occlusion() {
        let ranges_m = vec![9.0, 9.0, 9.0, 4.0, 4.0, 4.0, 9.0, 9.0, 9.0];
        let scan = RangeScan::new(ranges_m, 0.0, 1f64.to_radians(), 30.0);
        let clusters = segment_scan(&scan, &SegmentationOptions::default());
        assert_eq!(clusters.len(), 3);
        assert!(
            clusters[0].occluded_end,
            "the near cluster hides the far one"
        );
        assert!(!clusters[1].occluded_start && !clusters[1].occluded_end);
        assert!(clusters[2].occluded_start);
    }

    #[test]
    fn test_threshold_grows_with_range() {
        let options = SegmentationOptions::default();
        let step_rad = 0.5f64.to_radians();
        let near_m = breakpoint_distance_m(2.0, 2.0, step_rad, &options);
        let far_m = breakpoint_distance_m(20.0, 20.0, step_rad, &options);
        assert!(far_m > 5.0 * near_m);
        // Two returns on a surface facing the sensor are well within the threshold.
        assert!(20.0 * step_rad < far_m);
    }

    #[test]
    fn test_wall_at_grazing_angle_stays_whole() {
        // A wall 45° to the beams, 3–8 m away.
        let scene = Scene::new(vec![Shape::Segment {
            a_m: [3.0, -3.0],
            b_m: [8.0, 2.0],
        }]);
        let scan = scene.cast(-60f64.to_radians(), 0.5f64.to_radians(), 241, 30.0, 0.0, 1);
        let clusters = segment_scan(&scan, &SegmentationOptions::default());
        assert_eq!(clusters.len(), 1);
    }
}
