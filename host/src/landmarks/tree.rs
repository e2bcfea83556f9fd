//! Tree trunks and poles: a convex arc facing the sensor, found in one small cluster.
//!
//! A cluster narrower than [`TreeOptions::max_cluster_width_m`] becomes a trunk when
//!
//! 1. a circle explains its returns, tried in this order:
//!    * with [`TreeOptions::min_fit_points`] returns or more, the least-squares circle of
//!      [`super::circle_fit`], centred behind the returns as seen from the sensor (a convex
//!      arc, not the inside of a curved wall);
//!    * with at most [`TreeOptions::max_chord_points`] returns (a thin pole at range, whose
//!      two or three returns a fit cannot judge under noise), the chord: the diameter is the
//!      chord between the outer returns widened by one beam spacing (the trunk's outline
//!      reaches on average half a beam beyond each outer return), and the centre lies on the
//!      chord's perpendicular bisector, behind the chord, so that the circle passes through
//!      both outer returns; the chord must face the sensor (a wall seen edge-on gives short
//!      clusters too, but along the beams);
//! 2. the circle is plausible: a radius within [`TreeOptions::min_radius_m`] and
//!    [`TreeOptions::max_radius_m`], returns within [`TreeOptions::max_rms_residual_m`] of it
//!    (root mean square), and agreement with the free space around it: every beam
//!    outside the cluster whose ray crosses the circle (shrunk by
//!    [`TreeOptions::free_space_tolerance_m`]) must have stopped at or before it. A flat or
//!    too large fit, whose outline would cover beams that saw through, fails here;
//! 3. all of it is seen: a cluster next to an occlusion edge (a nearer neighbour, or the
//!    scan's edge) may show only part of a trunk, which biases a chord's centre and diameter
//!    and a noisy fit's; such a trunk is dropped, unless [`TreeOptions::keep_occluded`] asks
//!    for it, flagged. A fitted circle that ends before the neighbouring beam is whole.
//!
//! Noise-free, three returns fix the circle exactly; with noise, the free-space check bounds a
//! three-return fit to the radii the beam pattern allows (a diameter between the chord and the
//! chord plus two beam spacings).

use serde::{Deserialize, Serialize};

use super::circle_fit::fit_circle;
use super::range_scan::RangeScan;
use super::segmentation::Cluster;

/// When a cluster is taken for a trunk.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TreeOptions {
    /// Clusters wider than this (first to last return) are not trunks, metres; 2.
    pub max_cluster_width_m: f64,
    /// Smallest accepted trunk radius, metres; 0.05.
    pub min_radius_m: f64,
    /// Largest accepted trunk radius, metres; 1.5.
    pub max_radius_m: f64,
    /// Largest accepted root mean square distance of the returns to the circle, metres; 0.03.
    pub max_rms_residual_m: f64,
    /// Clusters with at least this many returns (and at least three) get a circle fit; 3.
    pub min_fit_points: usize,
    /// Clusters with at most this many returns (and at least two) get the chord estimate when
    /// the fit is not tried or fails; 3.
    pub max_chord_points: usize,
    /// Levenberg–Marquardt steps after the algebraic fit; 10.
    pub fit_iterations: usize,
    /// Largest angle between a short cluster's chord and the perpendicular to its mean ray,
    /// radians; 45°.
    pub max_chord_tilt_rad: f64,
    /// Slack of the free-space check: the circle is shrunk by this much, and a beam counts as
    /// seeing through it when it reaches this far behind the circle, metres; 0.05.
    pub free_space_tolerance_m: f64,
    /// Also report trunks next to an occlusion edge, flagged as occluded; false.
    pub keep_occluded: bool,
}

impl Default for TreeOptions {
    /// Trunks 10 cm to 3 m across in clusters up to 2 m wide, fitted to 3 cm.
    fn default() -> Self {
        TreeOptions {
            max_cluster_width_m: 2.0,
            min_radius_m: 0.05,
            max_radius_m: 1.5,
            max_rms_residual_m: 0.03,
            min_fit_points: 3,
            max_chord_points: 3,
            fit_iterations: 10,
            max_chord_tilt_rad: 45f64.to_radians(),
            free_space_tolerance_m: 0.05,
            keep_occluded: false,
        }
    }
}

/// A trunk found in one cluster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tree {
    /// Centre of the trunk, sensor frame, metres.
    pub center_in_sensor: [f64; 2],
    /// Diameter, metres.
    pub diameter_m: f64,
    /// Root mean square distance of the returns to the trunk's circle, metres.
    pub rms_residual_m: f64,
    /// Returns on the trunk.
    pub num_points: usize,
    /// Part of the trunk may be hidden by a nearer object or the scan's edge (step 3 of the
    /// [module documentation](self)); true only with [`TreeOptions::keep_occluded`].
    pub occluded: bool,
}

/// The trunk `cluster` of `scan` shows, if it is one (see the [module documentation](self)).
pub fn detect_tree(scan: &RangeScan, cluster: &Cluster, options: &TreeOptions) -> Option<Tree> {
    let points = &cluster.points_in_sensor;
    let num_points = points.len();
    let narrow = cluster.width_m() <= options.max_cluster_width_m;
    if num_points < 2 || !narrow {
        return None;
    }
    // The circle fit first, then the chord; the first that passes every check is the trunk.
    let fitted = (num_points >= options.min_fit_points.max(3))
        .then(|| fit_estimate(points, options))
        .flatten();
    let chord = || {
        (num_points <= options.max_chord_points)
            .then(|| chord_estimate(scan, points, options))
            .flatten()
    };
    let plausible = |&(center_in_sensor, radius_m): &([f64; 2], f64)| {
        let in_front = center_in_sensor[0].hypot(center_in_sensor[1]) > radius_m;
        in_front
            && (options.min_radius_m..=options.max_radius_m).contains(&radius_m)
            && rms_residual_m(points, center_in_sensor, radius_m) <= options.max_rms_residual_m
            && free_space_agrees(scan, cluster, center_in_sensor, radius_m, options)
    };
    let ((center_in_sensor, radius_m), from_fit) = match fitted.filter(plausible) {
        Some(estimate) => (estimate, true),
        None => (chord().filter(plausible)?, false),
    };

    // A nearer neighbour (or the scan's edge) may hide part of the trunk, unless the fitted
    // circle ends before the neighbouring beam; a chord cannot tell.
    let neighbour_angle_rad = |offset: f64, beam: usize| {
        scan.first_angle_rad() + (beam as f64 + offset) * scan.angle_step_rad()
    };
    let hidden = |occluded_side: bool, angle_rad: f64| {
        occluded_side
            && (!from_fit || ray_crossing_m(angle_rad, center_in_sensor, radius_m).is_some())
    };
    let occluded = hidden(
        cluster.occluded_start,
        neighbour_angle_rad(-1.0, cluster.first_beam),
    ) || hidden(
        cluster.occluded_end,
        neighbour_angle_rad(1.0, cluster.last_beam),
    );
    if occluded && !options.keep_occluded {
        return None;
    }
    Some(Tree {
        center_in_sensor,
        diameter_m: 2.0 * radius_m,
        rms_residual_m: rms_residual_m(points, center_in_sensor, radius_m),
        num_points,
        occluded,
    })
}

/// Distance from the sensor along the ray at `angle_rad` to the circle (`center_in_sensor`,
/// `radius_m`), if the ray crosses it ahead.
fn ray_crossing_m(angle_rad: f64, center_in_sensor: [f64; 2], radius_m: f64) -> Option<f64> {
    let (sin, cos) = angle_rad.sin_cos();
    let along_m = cos * center_in_sensor[0] + sin * center_in_sensor[1];
    let to_center_squared_m2 = center_in_sensor[0].powi(2) + center_in_sensor[1].powi(2);
    let discriminant_m2 = along_m * along_m - (to_center_squared_m2 - radius_m * radius_m);
    (discriminant_m2 >= 0.0 && along_m > 0.0).then(|| along_m - discriminant_m2.sqrt())
}

/// Root mean square distance of `points` to the circle (`center_m`, `radius_m`), metres.
fn rms_residual_m(points: &[[f64; 2]], center_m: [f64; 2], radius_m: f64) -> f64 {
    let sum_squared_m2: f64 = points
        .iter()
        .map(|p| ((p[0] - center_m[0]).hypot(p[1] - center_m[1]) - radius_m).powi(2))
        .sum();
    (sum_squared_m2 / points.len().max(1) as f64).sqrt()
}

/// Centre and radius of the least-squares circle through `points`, if its centre lies behind
/// the points as seen from the sensor.
fn fit_estimate(points: &[[f64; 2]], options: &TreeOptions) -> Option<([f64; 2], f64)> {
    let fit = fit_circle(points, options.fit_iterations)?;
    let mean_range_m = points.iter().map(|p| p[0].hypot(p[1])).sum::<f64>() / points.len() as f64;
    let behind = fit.center_m[0].hypot(fit.center_m[1]) > mean_range_m;
    behind.then_some((fit.center_m, fit.radius_m))
}

/// Centre and radius of a thin pole from the chord of its few returns `points` (see the
/// [module documentation](self)).
fn chord_estimate(
    scan: &RangeScan,
    points: &[[f64; 2]],
    options: &TreeOptions,
) -> Option<([f64; 2], f64)> {
    let (first, last) = (points.first()?, points.last()?);
    let n = points.len() as f64;
    let mean = [
        points.iter().map(|p| p[0]).sum::<f64>() / n,
        points.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    let mean_range_m = mean[0].hypot(mean[1]);
    let chord = [last[0] - first[0], last[1] - first[1]];
    let chord_m = chord[0].hypot(chord[1]);
    if !(mean_range_m > 0.0 && chord_m > 0.0) {
        return None;
    }
    let ray = [mean[0] / mean_range_m, mean[1] / mean_range_m];
    // |chord · ray| is the sine of the chord's tilt from the perpendicular to the ray.
    let tilt_sin = ((chord[0] * ray[0] + chord[1] * ray[1]) / chord_m).abs();
    if tilt_sin > options.max_chord_tilt_rad.sin() {
        return None;
    }
    let beam_spacing_m = mean_range_m * scan.angle_step_rad().abs();
    let radius_m = 0.5 * (chord_m + beam_spacing_m);
    // The circle of that radius through both outer returns, on the far side of the chord.
    let middle = [(first[0] + last[0]) / 2.0, (first[1] + last[1]) / 2.0];
    let mut normal = [-chord[1] / chord_m, chord[0] / chord_m];
    if normal[0] * middle[0] + normal[1] * middle[1] < 0.0 {
        normal = [-normal[0], -normal[1]];
    }
    let behind_m = (radius_m * radius_m - chord_m * chord_m / 4.0)
        .max(0.0)
        .sqrt();
    let center_in_sensor = [
        middle[0] + behind_m * normal[0],
        middle[1] + behind_m * normal[1],
    ];
    center_in_sensor
        .iter()
        .all(|c| c.is_finite())
        .then_some((center_in_sensor, radius_m))
}

/// Whether every beam outside `cluster` whose ray crosses the circle (`center_in_sensor`,
/// `radius_m`, shrunk by the tolerance) stopped no farther than the circle plus the tolerance.
fn free_space_agrees(
    scan: &RangeScan,
    cluster: &Cluster,
    center_in_sensor: [f64; 2],
    radius_m: f64,
    options: &TreeOptions,
) -> bool {
    let tolerance_m = options.free_space_tolerance_m.max(0.0);
    let shrunk_m = radius_m - tolerance_m;
    if shrunk_m <= 0.0 {
        return true;
    }
    let crossing_m =
        |beam: usize| ray_crossing_m(scan.beam_angle_rad(beam), center_in_sensor, shrunk_m);
    let sees_through = |beam: usize| -> Option<bool> {
        let hit_m = crossing_m(beam)?;
        Some(
            scan.range_m(beam)
                .is_none_or(|range_m| range_m > hit_m + tolerance_m),
        )
    };
    // Walk outwards on both sides while the rays still cross the circle.
    let before_agrees = (0..cluster.first_beam)
        .rev()
        .map_while(&sees_through)
        .all(|through| !through);
    let after_agrees = (cluster.last_beam.saturating_add(1)..scan.len())
        .map_while(&sees_through)
        .all(|through| !through);
    before_agrees && after_agrees
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::segmentation::{SegmentationOptions, segment_scan};
    use crate::landmarks::test_scene::{Scene, Shape};
    use std::f64::consts::FRAC_PI_2;

    fn trees_in(scene: &Scene, step_deg: f64, sigma_m: f64, seed: u64) -> Vec<Tree> {
        let num_beams = (180.0 / step_deg) as usize + 1;
        let scan = scene.cast(
            -90f64.to_radians(),
            step_deg.to_radians(),
            num_beams,
            40.0,
            sigma_m,
            seed,
        );
        segment_scan(&scan, &SegmentationOptions::default())
            .iter()
            .filter_map(|c| detect_tree(&scan, c, &TreeOptions::default()))
            .collect()
    }

    #[test]
    fn test_pole_from_few_returns() {
        // 12 cm pole at 8 m: two or three returns at 0.5°.
        let scene = Scene::new(vec![Shape::Circle {
            center_m: [8.0, 0.3],
            radius_m: 0.06,
        }]);
        let trees = trees_in(&scene, 0.5, 0.0, 0);
        assert_eq!(trees.len(), 1, "{trees:?}");
        let tree = trees[0];
        assert!(tree.num_points <= 3);
        let spacing_m = 8.0 * 0.5f64.to_radians();
        assert!((tree.diameter_m - 0.12).abs() < spacing_m, "{tree:?}");
        let c = tree.center_in_sensor;
        assert!(
            (c[0] - 8.0).abs() < 0.05 && (c[1] - 0.3).abs() < 0.05,
            "{tree:?}"
        );
    }

    #[test]
    fn test_wall_edge_on_is_no_pole() {
        // A wall almost along the beams splits into short clusters; none is a pole.
        let scene = Scene::new(vec![Shape::Segment {
            a_m: [3.0, 1.0],
            b_m: [30.0, 2.5],
        }]);
        assert!(trees_in(&scene, 1.0, 0.0, 0).is_empty());
    }

    #[test]
    fn test_trunk_in_front_of_wall() {
        let scene = Scene::new(vec![
            Shape::Circle {
                center_m: [6.0, -1.0],
                radius_m: 0.3,
            },
            Shape::Segment {
                a_m: [9.0, -10.0],
                b_m: [9.0, 10.0],
            },
        ]);
        let trees = trees_in(&scene, 0.5, 0.0, 0);
        assert_eq!(trees.len(), 1, "{trees:?}");
        assert!((trees[0].diameter_m - 0.6).abs() < 0.01, "{trees:?}");
    }

    #[test]
    fn test_half_hidden_trunk() {
        // A pole in front hides the left part of the trunk.
        let scene = Scene::new(vec![
            Shape::Circle {
                center_m: [10.0, 0.0],
                radius_m: 0.5,
            },
            Shape::Circle {
                center_m: [5.0, 0.25],
                radius_m: 0.1,
            },
        ]);
        let trees = trees_in(&scene, 0.5, 0.0, 0);
        let far: Vec<_> = trees
            .iter()
            .filter(|t| t.center_in_sensor[0] > 8.0)
            .collect();
        assert!(far.is_empty(), "{trees:?}");

        let scan = scene.cast(-FRAC_PI_2, 0.5f64.to_radians(), 361, 40.0, 0.0, 0);
        let options = TreeOptions {
            keep_occluded: true,
            ..TreeOptions::default()
        };
        let kept: Vec<Tree> = segment_scan(&scan, &SegmentationOptions::default())
            .iter()
            .filter_map(|c| detect_tree(&scan, c, &options))
            .filter(|t| t.center_in_sensor[0] > 8.0)
            .collect();
        assert_eq!(kept.len(), 1, "{kept:?}");
        assert!(kept[0].occluded);
        assert!((kept[0].diameter_m - 1.0).abs() < 0.01, "{kept:?}");
    }
}
