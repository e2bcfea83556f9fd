//! Relations built from a reference trajectory, for logs that come with corrected poses but
//! without published relations: the reference's own relative poses become the "true" ones.
//!
//! Two kinds of pairs of poses `(i, j)`, `i < j`, indices in time order:
//!
//! * consecutive: `j = i + 1`. They measure local accuracy (what scan matching delivers).
//! * revisits: `j - i >= min_revisit_gap_scans` and the two reference poses within
//!   `max_revisit_distance_m` and `max_revisit_angle_rad` of each other: the robot came back to
//!   a place, so the pair measures whether loops were closed. A long run through the same
//!   corridors has many such pairs (of the order of the number of scans times the number of
//!   passes); if there are more than `max_revisits`, every `stride`-th of them in `(i, j)` order
//!   is kept, with `stride = ceil(found / max_revisits)`, so the set stays deterministic and
//!   bounded. [`ReferenceRelations`] reports how many were found and kept, and the stride.
//!
//! The result is only as true as the reference: a relation measures agreement with it.

use serde::{Deserialize, Serialize};

use super::relation::Relation;
use super::trajectory::{StampedPose, Trajectory};

/// Which pairs of reference poses become relations.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceRelationOptions {
    /// Whether every pair of consecutive poses `(i, i + 1)` becomes a relation.
    pub consecutive: bool,
    /// Smallest index difference `j - i` of a revisit (at least 2 is used, so revisits never
    /// repeat consecutive pairs).
    pub min_revisit_gap_scans: usize,
    /// Largest distance between the two reference positions of a revisit, metres.
    pub max_revisit_distance_m: f64,
    /// Largest difference between the two reference headings of a revisit, radians.
    pub max_revisit_angle_rad: f64,
    /// At most this many revisits are kept (0 builds none); see the module docs for how they
    /// are thinned.
    pub max_revisits: usize,
}

impl Default for ReferenceRelationOptions {
    /// Consecutive pairs, and revisits at least 50 scans apart within 2 m and 45°, at most
    /// 20 000 of them.
    fn default() -> Self {
        ReferenceRelationOptions {
            consecutive: true,
            min_revisit_gap_scans: 50,
            max_revisit_distance_m: 2.0,
            max_revisit_angle_rad: 45_f64.to_radians(),
            max_revisits: 20_000,
        }
    }
}

/// Relations built from a reference trajectory, and how they were chosen.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ReferenceRelations {
    /// The relations: consecutive pairs first (by `i`), then the kept revisits (by `(i, j)`).
    /// Not serialized.
    #[serde(skip)]
    pub relations: Vec<Relation>,
    /// Number of consecutive-pair relations.
    pub consecutive: usize,
    /// Number of pairs that met the revisit conditions.
    pub revisits_found: usize,
    /// Number of revisit relations kept.
    pub revisits_kept: usize,
    /// Every `revisit_stride`-th revisit found was kept (1: all of them).
    pub revisit_stride: usize,
}

impl ReferenceRelations {
    /// Builds relations from the poses of `reference` (in its time order) as chosen by
    /// `options`; each relation's true motion is `inverse(pose_i) * pose_j` of the reference.
    ///
    /// The revisit search compares every pair of poses, so it takes time quadratic in the
    /// number of poses (about 11 million pose pairs for 4 800 scans).
    pub fn build(reference: &Trajectory, options: &ReferenceRelationOptions) -> Self {
        let poses = reference.poses();
        let relation = |i: usize, j: usize| {
            Relation::new(
                poses[i].timestamp_s,
                poses[j].timestamp_s,
                poses[i].pose_in_map.inverse() * poses[j].pose_in_map,
            )
        };
        let mut relations: Vec<Relation> = Vec::new();
        if options.consecutive {
            relations.extend((1..poses.len()).map(|j| relation(j - 1, j)));
        }
        let consecutive = relations.len();

        let revisits_found = revisits(poses, options).count();
        let revisit_stride = if options.max_revisits == 0 {
            0
        } else {
            revisits_found.div_ceil(options.max_revisits).max(1)
        };
        if revisit_stride > 0 {
            relations.extend(
                revisits(poses, options)
                    .step_by(revisit_stride)
                    .map(|(i, j)| relation(i, j)),
            );
        }
        let revisits_kept = relations.len() - consecutive;
        ReferenceRelations {
            relations,
            consecutive,
            revisits_found,
            revisits_kept,
            revisit_stride,
        }
    }
}

/// Every revisit `(i, j)` of `poses` under `options`, in `(i, j)` order.
fn revisits<'a>(
    poses: &'a [StampedPose],
    options: &'a ReferenceRelationOptions,
) -> impl Iterator<Item = (usize, usize)> + 'a {
    let gap = options.min_revisit_gap_scans.max(2);
    (0..poses.len()).flat_map(move |i| {
        (i.saturating_add(gap)..poses.len())
            .filter(move |&j| {
                let i_from_j = poses[i].pose_in_map.inverse() * poses[j].pose_in_map;
                // `<=` is false for NaN, so a pose with a NaN component is never a revisit.
                i_from_j.x_m.hypot(i_from_j.y_m) <= options.max_revisit_distance_m
                    && i_from_j.theta_rad.abs() <= options.max_revisit_angle_rad
            })
            .map(move |j| (i, j))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluation::{PairingOptions, evaluate_relations};
    use crate::geometry::Pose2;
    use std::f64::consts::TAU;

    /// `laps` laps of a circle of radius 5 m, `per_lap` poses a lap, heading along the circle,
    /// one pose every 0.1 s.
    fn circle(per_lap: usize, laps: usize) -> Trajectory {
        (0..per_lap * laps)
            .map(|k| {
                let angle = TAU * k as f64 / per_lap as f64;
                let pose = Pose2::new(5.0 * angle.cos(), 5.0 * angle.sin(), angle + TAU / 4.0);
                StampedPose::new(0.1 * k as f64, pose)
            })
            .collect()
    }

    #[test]
    fn test_consecutive_pairs() {
        let reference = circle(100, 1);
        let options = ReferenceRelationOptions {
            max_revisits: 0,
            ..ReferenceRelationOptions::default()
        };
        let built = ReferenceRelations::build(&reference, &options);
        assert_eq!(built.consecutive, 99);
        assert_eq!(built.relations.len(), 99);
        assert_eq!((built.revisits_kept, built.revisit_stride), (0, 0));
        // Consecutive poses on the circle are one chord apart and turned by 3.6°.
        let relation = built.relations[10];
        assert_eq!((relation.t1_s, relation.t2_s), (1.0, 0.1 * 11.0));
        let chord_m = 2.0 * 5.0 * (TAU / 200.0).sin();
        let step = relation.true_from1_to2;
        assert!((step.x_m.hypot(step.y_m) - chord_m).abs() < 1e-12);
        assert!((step.theta_rad - TAU / 100.0).abs() < 1e-12);
    }

    #[test]
    fn test_revisits_on_a_loop() {
        // Two laps of 100 poses, 0.314 m apart, so pose i and pose i + 100 are at the same
        // place with the same heading. Poses g apart in index are d = g mod 100 (or 100 - that)
        // apart along the circle, 10 sin(d π / 100) m apart and turned 3.6 d degrees: within
        // 2 m (and then well within 45°) means d <= 6. With 200 poses there are 200 - g pairs
        // g apart, and g >= 50 leaves g in 94..=106 (one lap later) and 194..=199 (almost two).
        let reference = circle(100, 2);
        let options = ReferenceRelationOptions {
            consecutive: false,
            ..ReferenceRelationOptions::default()
        };
        let built = ReferenceRelations::build(&reference, &options);
        let expected: usize = (94..=106).chain(194..=199).map(|g| 200 - g).sum();
        assert_eq!(expected, 1300 + 21);
        assert_eq!(built.revisits_found, expected);
        assert_eq!(built.revisits_kept, expected);
        assert_eq!(built.revisit_stride, 1);
        assert_eq!(built.consecutive, 0);
        let first = built.relations[0];
        assert_eq!((first.t1_s, first.t2_s), (0.0, 0.1 * 94.0));
        for relation in &built.relations {
            let motion = relation.true_from1_to2;
            assert!(motion.x_m.hypot(motion.y_m) <= 2.0);
            assert!(motion.theta_rad.abs() <= 45_f64.to_radians());
            assert!(relation.t2_s - relation.t1_s >= 0.1 * 50.0 - 1e-9);
        }
        // The reference scores zero on its own relations.
        let evaluation =
            evaluate_relations(&built.relations, &reference, &PairingOptions::default());
        assert_eq!(evaluation.covered, expected);
        assert!(evaluation.summary.max_translation_m < 1e-9);
    }

    #[test]
    fn test_revisit_limits() {
        // Pose 0 at the origin facing +x; then 60 poses far away; then pose 61 back 1.5 m from
        // the origin facing 60° left.
        let mut poses = vec![StampedPose::new(0.0, Pose2::IDENTITY)];
        poses.extend(
            (1..=60).map(|k| StampedPose::new(k as f64, Pose2::new(100.0 + k as f64, 0.0, 0.0))),
        );
        poses.push(StampedPose::new(
            61.0,
            Pose2::new(0.0, 1.5, 60_f64.to_radians()),
        ));
        let reference = Trajectory::new(poses);
        let count = |options: ReferenceRelationOptions| {
            ReferenceRelations::build(&reference, &options).revisits_found
        };
        let defaults = ReferenceRelationOptions::default();
        assert_eq!(count(defaults), 0);
        let wide = ReferenceRelationOptions {
            max_revisit_angle_rad: 61_f64.to_radians(),
            ..defaults
        };
        assert_eq!(count(wide), 1);
        let near = ReferenceRelationOptions {
            max_revisit_distance_m: 1.4,
            ..wide
        };
        assert_eq!(count(near), 0);
        let far_apart_in_time = ReferenceRelationOptions {
            min_revisit_gap_scans: 62,
            ..wide
        };
        assert_eq!(count(far_apart_in_time), 0);
    }

    #[test]
    fn test_too_many_revisits_are_thinned_by_a_stride() {
        let reference = circle(100, 2);
        let all = ReferenceRelations::build(&reference, &ReferenceRelationOptions::default());
        let options = ReferenceRelationOptions {
            max_revisits: 100,
            ..ReferenceRelationOptions::default()
        };
        let thinned = ReferenceRelations::build(&reference, &options);
        assert_eq!(thinned.revisits_found, all.revisits_found);
        let stride = all.revisits_found.div_ceil(100);
        assert_eq!(thinned.revisit_stride, stride);
        assert!(thinned.revisits_kept <= 100);
        assert_eq!(thinned.revisits_kept, all.revisits_found.div_ceil(stride));
        assert_eq!(thinned.consecutive, 199);
        // The kept ones are every stride-th of the full list, and the build is repeatable.
        let all_revisits = &all.relations[all.consecutive..];
        let kept = &thinned.relations[thinned.consecutive..];
        for (k, relation) in kept.iter().enumerate() {
            assert_eq!(*relation, all_revisits[k * stride]);
        }
        assert_eq!(ReferenceRelations::build(&reference, &options), thinned);
    }

    #[test]
    fn test_serializes_the_counts_only() {
        let built = ReferenceRelations::build(&circle(10, 1), &ReferenceRelationOptions::default());
        let json = serde_json::to_string(&built).expect("plain numbers serialize");
        assert_eq!(
            json,
            r#"{"consecutive":9,"revisits_found":0,"revisits_kept":0,"revisit_stride":1}"#
        );
    }
}
