//! The landmark front end: one range scan in, trunk and corner observations out.
//!
//! The recipe, one stage per module:
//!
//! 1. [`super::segmentation`]: cut the scan into clusters at range jumps and missing returns;
//! 2. [`super::tree`]: take each small cluster that a circle explains, and that touches no
//!    occlusion edge, for a trunk;
//! 3. [`super::line_split`] and [`super::corner`]: split the other clusters into lines by
//!    split-and-merge and report where consecutive lines meet at roughly a right angle.
//!
//! Every input is safe: ranges that are not returns are skipped, and no stage panics or
//! loops without bound on any scan or options.

use serde::{Deserialize, Serialize};

use super::corner::{CornerOptions, find_corners};
use super::feature::{Feature, FeatureKind};
use super::line_split::{LineSplitOptions, split_into_lines};
use super::range_scan::RangeScan;
use super::segmentation::{SegmentationOptions, segment_scan};
use super::tree::{TreeOptions, detect_tree};

/// Everything the front end can be told; the defaults suit a 0.5°–1° scanner outdoors and
/// indoors.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FrontEndOptions {
    /// Cutting the scan into clusters.
    pub segmentation: SegmentationOptions,
    /// Accepting a cluster as a trunk.
    pub tree: TreeOptions,
    /// Splitting a cluster into lines.
    pub line_split: LineSplitOptions,
    /// Accepting two lines as a corner.
    pub corner: CornerOptions,
}

/// The trunks and corners in `scan`, in beam order, as range and bearing from the sensor (see
/// the [module documentation](self)).
pub fn extract_features(scan: &RangeScan, options: &FrontEndOptions) -> Vec<Feature> {
    let mut features = Vec::new();
    for cluster in segment_scan(scan, &options.segmentation) {
        // A trunk: a convex arc in a small cluster.
        if let Some(tree) = detect_tree(scan, &cluster, &options.tree) {
            let kind = FeatureKind::Tree {
                diameter_m: tree.diameter_m,
                rms_residual_m: tree.rms_residual_m,
                num_points: tree.num_points,
                occluded: tree.occluded,
            };
            features.push(Feature::from_point_in_sensor(tree.center_in_sensor, kind));
            continue;
        }
        // Corners: walls meeting at roughly a right angle.
        let lines = split_into_lines(&cluster.points_in_sensor, &options.line_split);
        for corner in find_corners(&lines, &options.corner) {
            let kind = FeatureKind::Corner {
                orientation_rad: corner.orientation_rad,
                angle_rad: corner.angle_rad,
                convex: corner.convex,
            };
            features.push(Feature::from_point_in_sensor(corner.vertex_in_sensor, kind));
        }
    }
    features
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::test_scene::{Scene, Shape};
    use proptest::prelude::*;
    use std::f64::consts::FRAC_PI_2;

    /// A 180° scan at `step_deg` of `scene`, 40 m range, noise `sigma_m`.
    fn scan_of(scene: &Scene, step_deg: f64, sigma_m: f64, seed: u64) -> RangeScan {
        let num_beams = (180.0 / step_deg).round() as usize + 1;
        scene.cast(
            -FRAC_PI_2,
            step_deg.to_radians(),
            num_beams,
            40.0,
            sigma_m,
            seed,
        )
    }

    fn trees(features: &[Feature]) -> Vec<(Feature, f64)> {
        features
            .iter()
            .filter_map(|f| match f.kind {
                FeatureKind::Tree { diameter_m, .. } => Some((*f, diameter_m)),
                FeatureKind::Corner { .. } => None,
            })
            .collect()
    }

    fn distance_m(a: [f64; 2], b: [f64; 2]) -> f64 {
        (a[0] - b[0]).hypot(a[1] - b[1])
    }

    #[test]
    fn test_tree_at_ten_metres() {
        let center_m = [8.0, 6.0];
        let scene = Scene::new(vec![Shape::Circle {
            center_m,
            radius_m: 0.3,
        }]);
        for step_deg in [0.5, 1.0] {
            let features = extract_features(
                &scan_of(&scene, step_deg, 0.0, 0),
                &FrontEndOptions::default(),
            );
            let found = trees(&features);
            assert_eq!(found.len(), 1, "{step_deg}°: {features:?}");
            let (tree, diameter_m) = found[0];
            assert!(
                distance_m(tree.point_in_sensor(), center_m) < 0.02,
                "{tree:?}"
            );
            assert!((diameter_m - 0.6).abs() < 0.05, "{tree:?}");
        }
    }

    /// Centre and diameter errors with 1 cm range noise, over 50 seeds: a 0.6 m trunk at 10 m
    /// (about 7 returns at 0.5°) stays within 5 cm in centre and 10 cm in diameter.
    #[test]
    fn test_tree_with_range_noise() {
        let center_m = [8.0, -6.0];
        let scene = Scene::new(vec![Shape::Circle {
            center_m,
            radius_m: 0.3,
        }]);
        let (mut worst_center_m, mut worst_diameter_m, mut found) = (0.0f64, 0.0f64, 0);
        for seed in 0..50 {
            let features = extract_features(
                &scan_of(&scene, 0.5, 0.01, seed),
                &FrontEndOptions::default(),
            );
            for (tree, diameter_m) in trees(&features) {
                found += 1;
                worst_center_m = worst_center_m.max(distance_m(tree.point_in_sensor(), center_m));
                worst_diameter_m = worst_diameter_m.max((diameter_m - 0.6).abs());
            }
        }
        assert!(found >= 48, "found in {found} of 50 scans");
        assert!(worst_center_m < 0.05, "centre off by {worst_center_m} m");
        assert!(
            worst_diameter_m < 0.1,
            "diameter off by {worst_diameter_m} m"
        );
    }

    #[test]
    fn test_two_trees_side_by_side() {
        let scene = Scene::new(vec![
            Shape::Circle {
                center_m: [10.0, -0.8],
                radius_m: 0.25,
            },
            Shape::Circle {
                center_m: [10.0, 0.8],
                radius_m: 0.4,
            },
        ]);
        let features = extract_features(&scan_of(&scene, 0.5, 0.0, 0), &FrontEndOptions::default());
        let found = trees(&features);
        assert_eq!(found.len(), 2, "{features:?}");
        assert!(distance_m(found[0].0.point_in_sensor(), [10.0, -0.8]) < 0.02);
        assert!(distance_m(found[1].0.point_in_sensor(), [10.0, 0.8]) < 0.02);
    }

    #[test]
    fn test_wall_is_no_tree() {
        for (a_m, b_m) in [
            ([6.0, -10.0], [6.0, 10.0]),
            ([4.0, 0.5], [5.0, 1.5]),
            ([3.0, -1.0], [9.0, 0.5]),
        ] {
            let scene = Scene::new(vec![Shape::Segment { a_m, b_m }]);
            for seed in 0..5 {
                let features = extract_features(
                    &scan_of(&scene, 0.5, 0.01, seed),
                    &FrontEndOptions::default(),
                );
                assert!(trees(&features).is_empty(), "{a_m:?}–{b_m:?}: {features:?}");
            }
        }
    }

    #[test]
    fn test_l_shaped_corner() {
        let vertex_m = [7.0, 3.0];
        let scene = Scene::new(vec![
            Shape::Segment {
                a_m: [7.0, -4.0],
                b_m: vertex_m,
            },
            Shape::Segment {
                a_m: vertex_m,
                b_m: [1.0, 3.0],
            },
        ]);
        for (step_deg, sigma_m) in [(0.5, 0.0), (1.0, 0.0), (0.5, 0.01), (1.0, 0.01)] {
            let features = extract_features(
                &scan_of(&scene, step_deg, sigma_m, 3),
                &FrontEndOptions::default(),
            );
            assert_eq!(features.len(), 1, "{step_deg}°, {sigma_m} m: {features:?}");
            let corner = features[0];
            assert!(
                distance_m(corner.point_in_sensor(), vertex_m) < 0.05,
                "{corner:?}"
            );
            let FeatureKind::Corner {
                orientation_rad,
                angle_rad,
                convex,
            } = corner.kind
            else {
                panic!("not a corner: {corner:?}");
            };
            assert!(
                (angle_rad - FRAC_PI_2).abs() < 2f64.to_radians(),
                "{corner:?}"
            );
            assert!((orientation_rad + 135f64.to_radians()).abs() < 2f64.to_radians());
            assert!(!convex);
        }
    }

    #[test]
    fn test_empty_scans() {
        let options = FrontEndOptions::default();
        assert!(extract_features(&RangeScan::default(), &options).is_empty());
        let nothing = RangeScan::new(vec![40.0; 361], -FRAC_PI_2, 0.5f64.to_radians(), 40.0);
        assert!(extract_features(&nothing, &options).is_empty());
    }

    #[test]
    fn test_hostile_values_do_not_panic() {
        let options = FrontEndOptions::default();
        let ranges_m = vec![
            f64::NAN,
            -1.0,
            0.0,
            5.0,
            5.0,
            f64::INFINITY,
            5.0,
            f64::NEG_INFINITY,
            1e300,
            5.0,
            5.0,
            5.0,
        ];
        for step_rad in [0.0, 0.01, -0.01, f64::NAN, 1e300] {
            let scan = RangeScan::new(ranges_m.clone(), -1.0, step_rad, 40.0);
            let _ = extract_features(&scan, &options);
        }
        let nan_options = FrontEndOptions {
            segmentation: SegmentationOptions {
                min_surface_angle_rad: f64::NAN,
                range_sigma_m: f64::NAN,
                min_points: 0,
            },
            tree: TreeOptions {
                max_cluster_width_m: f64::INFINITY,
                min_radius_m: f64::NAN,
                min_fit_points: 0,
                free_space_tolerance_m: f64::NAN,
                ..TreeOptions::default()
            },
            line_split: LineSplitOptions {
                split_distance_m: -1.0,
            },
            corner: CornerOptions {
                min_line_points: 0,
                min_line_length_m: -1.0,
                ..CornerOptions::default()
            },
        };
        let scan = scan_of(
            &Scene::new(vec![Shape::Circle {
                center_m: [3.0, 0.0],
                radius_m: 0.5,
            }]),
            1.0,
            0.0,
            0,
        );
        let _ = extract_features(&scan, &nan_options);
    }

    proptest! {
        #[test]
        fn prop_any_scan_is_safe(
            ranges_m in prop::collection::vec(
                prop_oneof![
                    -5.0..45.0f64,
                    Just(f64::NAN),
                    Just(f64::INFINITY),
                    Just(-0.0),
                ],
                0..200,
            ),
            first_angle_rad in -4.0..4.0f64,
            step_rad in -0.05..0.05f64,
        ) {
            let scan = RangeScan::new(ranges_m, first_angle_rad, step_rad, 40.0);
            for feature in extract_features(&scan, &FrontEndOptions::default()) {
                prop_assert!(feature.range_m.is_finite() && feature.bearing_rad.is_finite());
            }
        }

        #[test]
        fn prop_smooth_scan_is_safe(
            base_m in 0.5..30.0f64,
            bumps in prop::collection::vec(-0.3..0.3f64, 1..300),
        ) {
            // Slowly varying ranges exercise long clusters, fits and splits.
            let mut range_m = base_m;
            let ranges_m: Vec<f64> = bumps.iter().map(|b| { range_m = (range_m + b).max(0.1); range_m }).collect();
            let scan = RangeScan::new(ranges_m, -FRAC_PI_2, 0.5f64.to_radians(), 40.0);
            for feature in extract_features(&scan, &FrontEndOptions::default()) {
                prop_assert!(feature.range_m.is_finite() && feature.bearing_rad.is_finite());
            }
        }
    }
}
