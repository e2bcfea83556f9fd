//! Point-to-line ICP: a scan's end points aligned on a [`PointMap`] to a fraction of a
//! centimetre.
//!
//! Each iteration pairs every end point with the nearest map point within the stage's
//! correspondence distance and takes one Gauss–Newton step on the distances along the map
//! points' normals (Huber-weighted, slightly damped so that a corridor, which fixes the pose
//! only across it, does not make the step singular). The stages shrink the correspondence
//! distance, so a guess some decimetres off is pulled in first and the last stage uses only
//! close pairs. A finer stage that cannot start (fewer than [`IcpOptions::min_pairs`] pairs:
//! far, sparse or rough surfaces, whose end points lie decimetres apart) ends the alignment
//! where the coarser stages left it, and its information then counts the pairs of the last
//! stage that ran. The result carries the fraction of end points that then lie within
//! [`IcpOptions::inlier_m`] of the map: how well the scan fits.
//!
//! Between iterations an end point moves by a fraction of a millimetre, so each one remembers
//! its nearest map point and how far every other map point lay ([`Correspondence`]); while
//! the remembered point is still nearer than any other can have come, it is the nearest
//! without a search. The pairs are exactly those a search would make.
//!
//! A [`PosePrior`] (local tracking's motion prior) can hold the pose near a prediction: it
//! enters each step as one more measurement, weighted as the distances are (its standard
//! deviations against [`IcpOptions::huber_m`]), so it decides only where the end points say
//! nothing: along a corridor, whose walls leave the pose free to slide.

use nalgebra::{Matrix2, Matrix3, Vector3};

use super::point_map::{MapPoint, PointMap};
use crate::geometry::{Pose2, wrap_angle_rad};

/// How the alignment runs.
#[derive(Clone, Debug, PartialEq)]
pub struct IcpOptions {
    /// Correspondence distance of each stage, metres, largest first.
    pub stages_m: Vec<f64>,
    /// Gauss–Newton steps per stage at most.
    pub iterations_per_stage: usize,
    /// Huber threshold of the point-to-line distance, metres.
    pub huber_m: f64,
    /// An end point this close to a map point counts as fitting, metres.
    pub inlier_m: f64,
    /// Fewer pairs than this make no step: no alignment in the first stage, or in a stage
    /// already under way, and the end of the alignment when a finer stage cannot start.
    pub min_pairs: usize,
}

impl Default for IcpOptions {
    fn default() -> Self {
        IcpOptions {
            stages_m: vec![0.6, 0.3, 0.15, 0.08],
            iterations_per_stage: 8,
            huber_m: 0.03,
            inlier_m: 0.1,
            min_pairs: 10,
        }
    }
}

/// A Gaussian prior on the pose being aligned: `map_from_robot` is expected at `mean`, with
/// standard deviations `sigma` (translation in any direction, m; heading, rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosePrior {
    /// The expected `map_from_robot`.
    pub mean: Pose2,
    /// Standard deviations: translation (m), rotation (rad).
    pub sigma: [f64; 2],
}

impl PosePrior {
    /// The prior's information, in units of the squared point-to-line distance whose noise
    /// is `huber_m` (the scale [`align_near`] weighs the distances in).
    fn information(&self, huber_m: f64) -> Vector3<f64> {
        let [sigma_m, sigma_rad] = self.sigma;
        let h2 = huber_m * huber_m;
        Vector3::new(
            h2 / (sigma_m * sigma_m),
            h2 / (sigma_m * sigma_m),
            h2 / (sigma_rad * sigma_rad),
        )
    }

    /// `pose − mean`, the heading wrapped.
    fn deviation(&self, pose: Pose2) -> Vector3<f64> {
        Vector3::new(
            pose.x_m - self.mean.x_m,
            pose.y_m - self.mean.y_m,
            wrap_angle_rad(pose.theta_rad - self.mean.theta_rad),
        )
    }
}

/// An aligned scan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcpMatch {
    /// `map_from_robot` after alignment.
    pub map_from_robot: Pose2,
    /// Fraction of the end points within [`IcpOptions::inlier_m`] of a map point.
    pub inlier_fraction: f64,
    /// RMS point-to-line distance of those end points, metres.
    pub rms_m: f64,
    /// `Σ w J Jᵀ` over those end points at the final pose (over those paired within the last
    /// stage that ran when a finer one could not start; Huber weights `w`, `J` the
    /// derivative of the point-to-line distance with respect to `(x_m, y_m, theta_rad)` of
    /// `map_from_robot`, the translation taken in the map frame): the information the
    /// alignment holds about the pose per unit variance of the distances. Along a corridor it
    /// is weak, as the alignment is.
    pub information: Matrix3<f64>,
}

impl IcpMatch {
    /// [`Self::information`] about a small motion of the robot in its own frame,
    /// `(x_m, y_m, theta_rad)`: a motion `(δt, δθ)` there is `(R δt, δθ)` in the map frame.
    pub fn information_in_robot(&self) -> Matrix3<f64> {
        let (sin, cos) = self.map_from_robot.theta_rad.sin_cos();
        let mut to_map = Matrix3::identity();
        to_map
            .fixed_view_mut::<2, 2>(0, 0)
            .copy_from(&Matrix2::new(cos, -sin, sin, cos));
        to_map.transpose() * self.information * to_map
    }
}

/// Aligns `points_in_robot` on `map`, starting from `guess` (`map_from_robot`). `None` when
/// too few points find a partner in the first stage, or a stage under way loses them.
pub fn align(
    map: &PointMap,
    points_in_robot: &[[f64; 2]],
    guess: Pose2,
    options: &IcpOptions,
) -> Option<IcpMatch> {
    align_near(map, points_in_robot, guess, options, None)
}

/// [`align`], held near `prior` where the end points leave the pose free (the module
/// documentation). The returned information is the end points' alone.
pub fn align_near(
    map: &PointMap,
    points_in_robot: &[[f64; 2]],
    guess: Pose2,
    options: &IcpOptions,
    prior: Option<&PosePrior>,
) -> Option<IcpMatch> {
    if points_in_robot.is_empty() || map.is_empty() {
        return None;
    }
    let mut pose = guess;
    // Searched out to this distance, a remembered answer serves every stage.
    let search_m = options
        .stages_m
        .iter()
        .copied()
        .chain([options.inlier_m])
        .fold(0.0, f64::max)
        + SEARCH_MARGIN_M;
    let mut correspondences = vec![Correspondence::default(); points_in_robot.len()];
    // The correspondence distance of the last stage run to its end, and whether a finer one
    // could not start.
    let mut completed_m: Option<f64> = None;
    let mut ended_early = false;
    'stages: for &stage_m in &options.stages_m {
        for iteration in 0..options.iterations_per_stage {
            let step = gauss_newton_step(
                map,
                points_in_robot,
                &mut correspondences,
                pose,
                Pairing {
                    max_distance_m: stage_m,
                    search_m,
                },
                options,
                prior,
            );
            let Some(step) = step else {
                if iteration == 0 && completed_m.is_some() {
                    ended_early = true;
                    break 'stages;
                }
                return None;
            };
            pose = Pose2::new(
                pose.x_m + step[0],
                pose.y_m + step[1],
                wrap_angle_rad(pose.theta_rad + step[2]),
            );
            if step[0].hypot(step[1]) < 1e-5 && step[2].abs() < 1e-6 {
                break;
            }
        }
        completed_m = Some(stage_m);
    }
    // What the alignment knows comes from the pairs it ended on: within the inlier distance,
    // or within the last stage that ran when a finer one could not start.
    let information_m = match completed_m {
        Some(stage_m) if ended_early => stage_m.max(options.inlier_m),
        _ => options.inlier_m,
    };
    let inlier_sq = options.inlier_m * options.inlier_m;
    let (mut inliers, mut pairs, mut sum_sq) = (0usize, 0usize, 0.0);
    let mut information = Matrix3::zeros();
    let (sin, cos) = pose.theta_rad.sin_cos();
    for (&p, correspondence) in points_in_robot.iter().zip(&mut correspondences) {
        let moved = pose.transform_point(p);
        if let Some(q) = correspondence.nearest_within(map, moved, information_m, search_m) {
            let [qx, qy] = q.point;
            let [nx, ny] = q.normal;
            let residual = nx * (moved[0] - qx) + ny * (moved[1] - qy);
            pairs += 1;
            let jacobian = distance_jacobian(q.normal, p, sin, cos);
            information +=
                huber_weight(residual, options.huber_m) * jacobian * jacobian.transpose();
            let (dx, dy) = (qx - moved[0], qy - moved[1]);
            if !ended_early || dx * dx + dy * dy <= inlier_sq {
                inliers += 1;
                sum_sq += residual * residual;
            }
        }
    }
    if pairs < options.min_pairs && ended_early {
        return None;
    }
    Some(IcpMatch {
        map_from_robot: pose,
        inlier_fraction: inliers as f64 / points_in_robot.len() as f64,
        rms_m: if inliers > 0 {
            (sum_sq / inliers as f64).sqrt()
        } else {
            f64::INFINITY
        },
        information,
    })
}

/// How much farther than the largest correspondence distance an end point's nearest map
/// points are searched, metres: what it may move before it must search again.
const SEARCH_MARGIN_M: f64 = 0.05;

/// An end point's nearest map point, as last searched.
#[derive(Clone, Copy, Debug, Default)]
struct Correspondence {
    /// Where the end point was then, in the map frame; `None` before the first search.
    searched_at: Option<[f64; 2]>,
    /// The nearest map point within the search distance then, by number.
    nearest: Option<usize>,
    /// Every other map point lay at least this far then, metres.
    others_m: f64,
}

impl Correspondence {
    /// The map point nearest to `moved` (the end point's position now) if it lies within
    /// `max_distance_m`: [`PointMap::nearest_within`], searching out to `search_m` only when
    /// the last answer may no longer hold.
    fn nearest_within<'a>(
        &mut self,
        map: &'a PointMap,
        moved: [f64; 2],
        max_distance_m: f64,
        search_m: f64,
    ) -> Option<&'a MapPoint> {
        let max_sq = max_distance_m * max_distance_m;
        if let Some(then) = self.searched_at {
            // No other point can have come nearer than this (less a hair for rounding).
            let (dx, dy) = (moved[0] - then[0], moved[1] - then[1]);
            let others_m = self.others_m - (dx * dx + dy * dy).sqrt() - 1e-9;
            match self.nearest.and_then(|index| map.points().get(index)) {
                Some(q) => {
                    let (dx, dy) = (q.point[0] - moved[0], q.point[1] - moved[1]);
                    let distance_sq = dx * dx + dy * dy;
                    if others_m > 0.0 && distance_sq < others_m * others_m {
                        return (distance_sq <= max_sq).then_some(q);
                    }
                }
                None if others_m > max_distance_m => return None,
                None => {}
            }
        }
        let (nearest, others_sq) = map.nearest_two_within(moved, search_m);
        *self = Correspondence {
            searched_at: Some(moved),
            nearest,
            others_m: others_sq.sqrt(),
        };
        let q = map.points().get(nearest?)?;
        let (dx, dy) = (q.point[0] - moved[0], q.point[1] - moved[1]);
        (dx * dx + dy * dy <= max_sq).then_some(q)
    }
}

/// The derivative of the distance of `point_in_robot`, moved by a pose with heading
/// `(sin, cos)`, along `normal`, with respect to the pose's `(x_m, y_m, theta_rad)`.
fn distance_jacobian(
    normal: [f64; 2],
    point_in_robot: [f64; 2],
    sin: f64,
    cos: f64,
) -> Vector3<f64> {
    let ([nx, ny], [px, py]) = (normal, point_in_robot);
    // d(moved)/dθ = (-sin px - cos py, cos px - sin py).
    Vector3::new(
        nx,
        ny,
        nx * (-sin * px - cos * py) + ny * (cos * px - sin * py),
    )
}

/// The Huber weight of a distance `residual_m` with threshold `huber_m`.
fn huber_weight(residual_m: f64, huber_m: f64) -> f64 {
    if residual_m.abs() <= huber_m {
        1.0
    } else {
        huber_m / residual_m.abs()
    }
}

/// The pairs a step pairs within a stage: an end point's nearest map point within
/// `max_distance_m`, searched out to `search_m`.
#[derive(Clone, Copy, Debug)]
struct Pairing {
    max_distance_m: f64,
    search_m: f64,
}

/// One damped Gauss–Newton step `[dx, dy, dθ]` on the pairs `pairing` makes, and `prior`.
fn gauss_newton_step(
    map: &PointMap,
    points_in_robot: &[[f64; 2]],
    correspondences: &mut [Correspondence],
    pose: Pose2,
    pairing: Pairing,
    options: &IcpOptions,
    prior: Option<&PosePrior>,
) -> Option<[f64; 3]> {
    let Pairing {
        max_distance_m,
        search_m,
    } = pairing;
    let (sin, cos) = pose.theta_rad.sin_cos();
    let mut hessian = Matrix3::<f64>::zeros();
    let mut gradient = Vector3::<f64>::zeros();
    let mut pairs = 0usize;
    for (&[px, py], correspondence) in points_in_robot.iter().zip(correspondences) {
        let moved = [
            cos * px - sin * py + pose.x_m,
            sin * px + cos * py + pose.y_m,
        ];
        let Some(q) = correspondence.nearest_within(map, moved, max_distance_m, search_m) else {
            continue;
        };
        let [qx, qy] = q.point;
        let [nx, ny] = q.normal;
        let residual = nx * (moved[0] - qx) + ny * (moved[1] - qy);
        let jacobian = distance_jacobian(q.normal, [px, py], sin, cos);
        let weight = huber_weight(residual, options.huber_m);
        hessian += weight * jacobian * jacobian.transpose();
        gradient += weight * residual * jacobian;
        pairs += 1;
    }
    if pairs < options.min_pairs {
        return None;
    }
    if let Some(prior) = prior {
        let information = prior.information(options.huber_m);
        if information.iter().all(|i| i.is_finite()) {
            hessian += Matrix3::from_diagonal(&information);
            gradient += information.component_mul(&prior.deviation(pose));
        }
    }
    let damping = 1e-6 * hessian.trace().max(1e-9);
    hessian += Matrix3::identity() * damping;
    let step = hessian.cholesky()?.solve(&(-gradient));
    Some([step[0], step[1], step[2]])
}

#[cfg(test)]
mod tests {
    use super::super::point_map::{PointMapOptions, points_with_normals};
    use super::*;
    use crate::scan_match::Scan;
    use crate::scan_match::synthetic::{WallInMap, cast_front_scan, polygon_walls};

    #[test]
    fn recovers_an_offset_pose_in_a_room() {
        let walls = polygon_walls(&[
            [-4.0, -3.0],
            [5.0, -3.0],
            [5.0, 2.0],
            [1.0, 4.0],
            [-4.0, 4.0],
        ]);
        let truth = Pose2::new(0.4, -0.3, 0.25);
        let reference = cast_front_scan(&walls, Pose2::IDENTITY);
        let scan = cast_front_scan(&walls, truth);
        let mut map = PointMap::new(PointMapOptions::default());
        map.insert_scan(&reference, Pose2::IDENTITY);
        let points: Vec<[f64; 2]> = points_with_normals(&scan, &PointMapOptions::default())
            .into_iter()
            .map(|(p, _)| p)
            .collect();
        let found = align(&map, &points, Pose2::IDENTITY, &IcpOptions::default());
        let found = found.unwrap_or(IcpMatch {
            map_from_robot: Pose2::IDENTITY,
            inlier_fraction: 0.0,
            rms_m: 1.0,
            information: Matrix3::zeros(),
        });
        let error = truth.inverse() * found.map_from_robot;
        assert!(error.x_m.hypot(error.y_m) < 0.005, "{error:?}");
        assert!(error.theta_rad.abs() < 0.1f64.to_radians(), "{error:?}");
        assert!(found.inlier_fraction > 0.8, "{found:?}");
    }

    proptest::proptest! {
        #[test]
        fn prop_a_remembered_correspondence_is_what_a_search_finds(
            walls in proptest::collection::vec((-3.0..3.0f64, -3.0..3.0f64, 0.0..3.2f64), 1..6),
            start in (-3.0..3.0f64, -3.0..3.0f64),
            moves in proptest::collection::vec(
                (-0.05..0.05f64, -0.05..0.05f64, 0.0..0.7f64, proptest::bool::weighted(0.1)),
                1..40,
            ),
        ) {
            // Short walls of points 2 cm apart, their normals left aside.
            let mut map = PointMap::new(PointMapOptions::default());
            let points: Vec<Option<[f64; 2]>> = walls
                .iter()
                .flat_map(|&(x, y, angle)| {
                    (0..20).map(move |k| {
                        let along = 0.02 * f64::from(k);
                        Some([x + along * angle.cos(), y + along * angle.sin()])
                    })
                })
                .collect();
            map.insert_scan(&Scan::from_points_in_robot(points), Pose2::IDENTITY);
            let mut correspondence = Correspondence::default();
            let mut at = [start.0, start.1];
            for (dx, dy, max_m, jump) in moves {
                at = if jump { [at[1] * 0.9, at[0]] } else { [at[0] + dx, at[1] + dy] };
                let searched = map.nearest_within(at, max_m).map(|q| q.point);
                let remembered = correspondence.nearest_within(&map, at, max_m, 0.75);
                proptest::prop_assert_eq!(remembered.map(|q| q.point), searched);
            }
        }
    }

    #[test]
    fn a_finer_stage_without_pairs_keeps_what_the_coarser_ones_found() {
        // Rough surfaces: every end point lies 5 cm along its beam off the wall, alternately
        // short and long, so a stage pairing within 1 mm cannot start.
        let walls = polygon_walls(&[[-4.0, -3.0], [5.0, -3.0], [5.0, 2.0], [-4.0, 4.0]]);
        let truth = Pose2::new(0.3, -0.2, 0.1);
        let reference = cast_front_scan(&walls, Pose2::IDENTITY);
        let mut map = PointMap::new(PointMapOptions::default());
        map.insert_scan(&reference, Pose2::IDENTITY);
        let points: Vec<[f64; 2]> = cast_front_scan(&walls, truth)
            .points_in_robot()
            .iter()
            .flatten()
            .enumerate()
            .map(|(k, &[x, y])| {
                let scale = 1.0 + if k % 2 == 0 { 0.05 } else { -0.05 } / x.hypot(y);
                [x * scale, y * scale]
            })
            .collect();
        let options = IcpOptions {
            stages_m: vec![0.6, 0.3, 0.001],
            ..IcpOptions::default()
        };
        let found = align(&map, &points, Pose2::IDENTITY, &options);
        let Some(found) = found else {
            panic!("the coarse stages' alignment was dropped");
        };
        let error = truth.inverse() * found.map_from_robot;
        assert!(error.x_m.hypot(error.y_m) < 0.03, "{error:?}");
        assert!(error.theta_rad.abs() < 0.5f64.to_radians(), "{error:?}");
        // Its information is that of the pairs of the 0.3 m stage, where it ended.
        assert!(found.information[(2, 2)] > 0.0, "{found:?}");
        // A first stage that cannot start makes no alignment.
        let only_fine = IcpOptions {
            stages_m: vec![0.001],
            ..IcpOptions::default()
        };
        assert!(align(&map, &points, Pose2::IDENTITY, &only_fine).is_none());
    }

    #[test]
    fn an_empty_map_aligns_nothing() {
        let map = PointMap::new(PointMapOptions::default());
        assert!(align(&map, &[[1.0, 0.0]], Pose2::IDENTITY, &IcpOptions::default()).is_none());
    }

    #[test]
    fn a_prior_holds_the_pose_along_a_corridor_and_not_across_it() {
        // Two walls 3 m apart and 40 m long, their ends beyond the 20 m range: the end points
        // fix the pose across the corridor and in heading, and nothing along it.
        let walls: Vec<WallInMap> =
            vec![[[-40.0, -1.5], [40.0, -1.5]], [[-40.0, 1.5], [40.0, 1.5]]];
        let truth = Pose2::new(0.0, 0.0, 0.0);
        let options = PointMapOptions::default();
        let mut map = PointMap::new(options);
        map.insert_scan(&cast_front_scan(&walls, Pose2::IDENTITY), Pose2::IDENTITY);
        let points: Vec<[f64; 2]> = points_with_normals(&cast_front_scan(&walls, truth), &options)
            .into_iter()
            .map(|(p, _)| p)
            .collect();
        // The prediction is 0.3 m along and 0.1 m across the corridor from the truth; the
        // alignment starts 0.2 m farther along.
        let prior = PosePrior {
            mean: Pose2::new(0.3, 0.1, 0.0),
            sigma: [0.03, 1f64.to_radians()],
        };
        let icp = IcpOptions::default();
        let held = align_near(&map, &points, Pose2::new(0.5, 0.1, 0.0), &icp, Some(&prior))
            .expect("aligned");
        let pose = held.map_from_robot;
        assert!((pose.x_m - 0.3).abs() < 0.01, "{pose:?}");
        assert!(pose.y_m.abs() < 0.01, "{pose:?}");
        assert!(pose.theta_rad.abs() < 1e-3, "{pose:?}");
        // Without it the alignment stays wherever it started along the corridor.
        let free = align(&map, &points, Pose2::new(0.5, 0.1, 0.0), &icp).expect("aligned");
        assert!(
            (free.map_from_robot.x_m - 0.5).abs() < 0.01,
            "{:?}",
            free.map_from_robot
        );
    }
}
