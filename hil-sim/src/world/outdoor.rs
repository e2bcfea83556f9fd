//! A seeded park: trees round a looping path, a building, a few garden walls and benches.
//!
//! The park is a `W` × `H` rectangle (120–180 m by 100–160 m) with its south-west corner at
//! the origin, open to the outside (no fence). Its parts, in the order of
//! [`Layout::shapes`]:
//!
//! * the path: a closed loop of 9–12 straight legs round the park's centre, its corners
//!   jittered on an ellipse spanning about two thirds of the park; this is the route;
//! * one building inside the loop, a rectangle or an L (10–28 m by 10–20 m, any
//!   orientation), at least 8 m from the path;
//! * 2–4 garden walls (4–12 m segments) at least 3 m from the path;
//! * 4–8 benches (1.6 m × 0.5 m rectangles) 3 m beside the path, facing it;
//! * 170–230 trees, the landmarks: circles of radius 0.2–1.0 m (small ones more common),
//!   about 60 % lining the path 3–15 m from it, the rest scattered; trunks stay at least
//!   2.5 m from the path, 1 m from each other and from everything else.
//!
//! Nothing but open ground lies within 2.2 m of the path's centre line.

use core::f64::consts::TAU;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::landmark::Landmark;
use super::layout::Layout;
use super::route::Route;
use super::shape::Shape;
use super::shape_world::distance_to_shape_m;

/// Space trunks keep from the path centre line, metres.
const TREE_PATH_CLEARANCE_M: f64 = 2.5;
/// Space between trunks, and between a trunk and any other obstacle, metres.
const TREE_SPACING_M: f64 = 1.0;
/// Distance of a bench's centre from the path centre line, metres.
const BENCH_OFFSET_M: f64 = 3.0;
/// Spacing of the points checked along the path when placing obstacles, metres.
const PATH_SAMPLE_M: f64 = 0.5;
/// Heights of the building's walls, the garden walls and the benches, metres.
const BUILDING_HEIGHT_M: f64 = 8.0;
const GARDEN_WALL_HEIGHT_M: f64 = 1.8;
const BENCH_HEIGHT_M: f64 = 0.45;

/// A trunk's height up to its crown, by its radius (thicker trees are taller), metres.
pub fn trunk_height_m(radius_m: f64) -> f64 {
    2.0 + 4.0 * radius_m
}

/// A crown's radius, by its trunk's radius, metres: the crown is a ball whose centre is
/// three quarters of its radius above the trunk's top.
pub fn crown_radius_m(trunk_radius_m: f64) -> f64 {
    1.2 + 3.0 * trunk_radius_m
}

/// The park for `seed`, described in the [module documentation](self).
pub fn generate(seed: u64) -> Layout {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rng = &mut rng;
    let size_m = [
        rng.random_range(120.0..180.0),
        rng.random_range(100.0..160.0),
    ];
    let center_m = [size_m[0] / 2.0, size_m[1] / 2.0];

    let route = path_loop(rng, center_m, size_m);
    let samples_m: Vec<[f64; 2]> = (0..(route.length_m() / PATH_SAMPLE_M).ceil() as usize)
        .map(|i| route.point_at(i as f64 * PATH_SAMPLE_M))
        .chain(route.waypoints_m().iter().copied())
        .collect();
    let clear_of_path = |shapes: &[Shape], min_m: f64| {
        samples_m
            .iter()
            .all(|&p| shapes.iter().all(|s| distance_to_shape_m(s, p) >= min_m))
    };

    let building_m = building_outline(rng, center_m, size_m, &clear_of_path);
    let mut shapes = closed_polygon(&building_m);
    let mut heights_m = vec![BUILDING_HEIGHT_M; shapes.len()];

    for _ in 0..rng.random_range(2..=4) {
        for _ in 0..30 {
            let mid_m = [
                rng.random_range(5.0..size_m[0] - 5.0),
                rng.random_range(5.0..size_m[1] - 5.0),
            ];
            let half_m = rng.random_range(2.0..6.0);
            let angle_rad: f64 = rng.random_range(0.0..TAU);
            let (sin, cos) = angle_rad.sin_cos();
            let wall = Shape::Segment {
                a_m: [mid_m[0] - half_m * cos, mid_m[1] - half_m * sin],
                b_m: [mid_m[0] + half_m * cos, mid_m[1] + half_m * sin],
            };
            if clear_of_path(&[wall], 3.0) && clear_of(&wall, &shapes, 2.0) {
                shapes.push(wall);
                heights_m.push(GARDEN_WALL_HEIGHT_M);
                break;
            }
        }
    }

    for _ in 0..rng.random_range(4..=8) {
        for _ in 0..30 {
            let s_m = rng.random_range(0.0..route.length_m());
            let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let bench = bench_outline(&route, s_m, side);
            let bench_shapes = closed_polygon(&bench);
            let clear = bench_shapes
                .iter()
                .all(|part| clear_of(part, &shapes, TREE_SPACING_M));
            if clear_of_path(&bench_shapes, 2.2) && clear {
                heights_m.extend(bench_shapes.iter().map(|_| BENCH_HEIGHT_M));
                shapes.extend(bench_shapes);
                break;
            }
        }
    }

    let landmarks = plant_trees(rng, size_m, &route, &shapes, &building_m);
    shapes.extend(landmarks.iter().map(Landmark::shape));
    heights_m.extend(landmarks.iter().map(|tree| trunk_height_m(tree.radius_m)));
    Layout {
        shapes,
        heights_m,
        landmarks,
        route,
    }
}

/// The path: 9–12 corners on a jittered ellipse round `center_m`, in either direction.
fn path_loop(rng: &mut ChaCha8Rng, center_m: [f64; 2], size_m: [f64; 2]) -> Route {
    let corners = rng.random_range(9..=12);
    let radii_m = [
        size_m[0] * rng.random_range(0.30..0.36),
        size_m[1] * rng.random_range(0.30..0.36),
    ];
    let phase_rad: f64 = rng.random_range(0.0..TAU);
    let turn = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let spacing_rad = TAU / corners as f64;
    let waypoints_m = (0..corners)
        .map(|i| {
            // Jitter below half the spacing keeps the corners in angular order, so the loop
            // never crosses itself.
            let angle_rad =
                phase_rad + turn * (i as f64 + rng.random_range(-0.25..0.25)) * spacing_rad;
            let stretch = rng.random_range(0.88..1.12);
            [
                center_m[0] + stretch * radii_m[0] * angle_rad.cos(),
                center_m[1] + stretch * radii_m[1] * angle_rad.sin(),
            ]
        })
        .collect();
    Route::closed(waypoints_m)
}

/// Corners of the building: a rectangle or an L near the park's centre that `clear_of_path`
/// accepts at 8 m; a 10 m × 8 m block at the centre if no candidate fits.
fn building_outline(
    rng: &mut ChaCha8Rng,
    center_m: [f64; 2],
    size_m: [f64; 2],
    clear_of_path: &impl Fn(&[Shape], f64) -> bool,
) -> Vec<[f64; 2]> {
    for _ in 0..100 {
        let half_m = [rng.random_range(5.0..14.0), rng.random_range(5.0..10.0)];
        let mut local_m = vec![
            [-half_m[0], -half_m[1]],
            [half_m[0], -half_m[1]],
            [half_m[0], half_m[1]],
            [-half_m[0], half_m[1]],
        ];
        if rng.random_bool(0.5) {
            // Cut a notch out of the north-east corner to make an L.
            let notch_m = [
                2.0 * half_m[0] * rng.random_range(0.4..0.6),
                2.0 * half_m[1] * rng.random_range(0.4..0.6),
            ];
            local_m.splice(
                2..3,
                [
                    [half_m[0], half_m[1] - notch_m[1]],
                    [half_m[0] - notch_m[0], half_m[1] - notch_m[1]],
                    [half_m[0] - notch_m[0], half_m[1]],
                ],
            );
        }
        let origin_m = [
            center_m[0] + size_m[0] * rng.random_range(-0.1..0.1),
            center_m[1] + size_m[1] * rng.random_range(-0.1..0.1),
        ];
        let outline_m = place(&local_m, origin_m, rng.random_range(0.0..TAU));
        if clear_of_path(&closed_polygon(&outline_m), 8.0) {
            return outline_m;
        }
    }
    let fallback_m = [[-5.0, -4.0], [5.0, -4.0], [5.0, 4.0], [-5.0, 4.0]];
    place(&fallback_m, center_m, 0.0)
}

/// A bench 1.6 m × 0.5 m, long side along the path, `side` (±1: left or right) of the path
/// point at arc length `s_m`.
fn bench_outline(route: &Route, s_m: f64, side: f64) -> Vec<[f64; 2]> {
    let on_path_m = route.point_at(s_m);
    let dir = route.direction_at(s_m);
    let left = [-dir[1], dir[0]];
    let center_m = [
        on_path_m[0] + side * BENCH_OFFSET_M * left[0],
        on_path_m[1] + side * BENCH_OFFSET_M * left[1],
    ];
    let local_m = [[-0.8, -0.25], [0.8, -0.25], [0.8, 0.25], [-0.8, 0.25]];
    place(&local_m, center_m, dir[1].atan2(dir[0]))
}

/// Trees, in planting order, for a park already holding `obstacles` and a building with
/// corners `building_m`.
fn plant_trees(
    rng: &mut ChaCha8Rng,
    size_m: [f64; 2],
    route: &Route,
    obstacles: &[Shape],
    building_m: &[[f64; 2]],
) -> Vec<Landmark> {
    let target = rng.random_range(170..=230);
    let mut trees: Vec<Landmark> = Vec::with_capacity(target);
    for _ in 0..40 * target {
        if trees.len() == target {
            break;
        }
        let u: f64 = rng.random_range(0.0..1.0);
        let radius_m = 0.2 + 0.8 * u * u;
        let center_m = if rng.random_bool(0.6) {
            // Lining the path.
            let s_m = rng.random_range(0.0..route.length_m());
            let on_path_m = route.point_at(s_m);
            let dir = route.direction_at(s_m);
            let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let offset_m = side * rng.random_range(TREE_PATH_CLEARANCE_M + radius_m..15.0);
            [
                on_path_m[0] - offset_m * dir[1],
                on_path_m[1] + offset_m * dir[0],
            ]
        } else {
            [
                rng.random_range(2.0..size_m[0] - 2.0),
                rng.random_range(2.0..size_m[1] - 2.0),
            ]
        };
        let inside_park = (0..2).all(|k| (1.0..size_m[k] - 1.0).contains(&center_m[k]));
        let fits = inside_park
            && route.distance_m(center_m) - radius_m >= TREE_PATH_CLEARANCE_M
            && !inside_polygon(center_m, building_m)
            && obstacles
                .iter()
                .all(|s| distance_to_shape_m(s, center_m) - radius_m >= TREE_SPACING_M)
            && trees.iter().all(|t| {
                let gap_m = (t.center_m[0] - center_m[0]).hypot(t.center_m[1] - center_m[1]);
                gap_m - t.radius_m - radius_m >= TREE_SPACING_M
            });
        if fits {
            trees.push(Landmark {
                // Cannot truncate: at most a few hundred trees.
                id: trees.len() as u32,
                center_m,
                radius_m,
            });
        }
    }
    trees
}

/// `local_m` rotated by `angle_rad` and moved to `origin_m`.
fn place(local_m: &[[f64; 2]], origin_m: [f64; 2], angle_rad: f64) -> Vec<[f64; 2]> {
    let (sin, cos) = angle_rad.sin_cos();
    local_m
        .iter()
        .map(|p| {
            [
                origin_m[0] + cos * p[0] - sin * p[1],
                origin_m[1] + sin * p[0] + cos * p[1],
            ]
        })
        .collect()
}

/// The sides of the polygon with corners `corners_m`, the last joined to the first.
fn closed_polygon(corners_m: &[[f64; 2]]) -> Vec<Shape> {
    (0..corners_m.len())
        .map(|i| Shape::Segment {
            a_m: corners_m[i],
            b_m: corners_m[(i + 1) % corners_m.len()],
        })
        .collect()
}

/// Whether every point along `part` (sampled every half metre if it is a segment) keeps
/// `min_m` from each of `shapes`.
fn clear_of(part: &Shape, shapes: &[Shape], min_m: f64) -> bool {
    let (a_m, b_m, radius_m) = match *part {
        Shape::Segment { a_m, b_m } => (a_m, b_m, 0.0),
        Shape::Circle { center_m, radius_m } => (center_m, center_m, radius_m),
    };
    let len_m = (b_m[0] - a_m[0]).hypot(b_m[1] - a_m[1]);
    let n = (len_m / 0.5).ceil().max(1.0) as usize;
    (0..=n).all(|i| {
        let f = i as f64 / n as f64;
        let p = [
            a_m[0] + f * (b_m[0] - a_m[0]),
            a_m[1] + f * (b_m[1] - a_m[1]),
        ];
        shapes
            .iter()
            .all(|s| distance_to_shape_m(s, p) - radius_m >= min_m)
    })
}

/// Whether `point_m` lies inside the polygon with corners `corners_m` (crossing number).
fn inside_polygon(point_m: [f64; 2], corners_m: &[[f64; 2]]) -> bool {
    let mut inside = false;
    for i in 0..corners_m.len() {
        let a = corners_m[i];
        let b = corners_m[(i + 1) % corners_m.len()];
        if (a[1] > point_m[1]) != (b[1] > point_m[1]) {
            let x_cross = a[0] + (point_m[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if point_m[0] < x_cross {
                inside = !inside;
            }
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;

    #[test]
    fn size_and_contents() {
        for seed in 0..10 {
            let layout = generate(seed);
            let world = crate::world::ShapeWorld::new(layout.shapes.clone());
            let (min_m, max_m) = world.bounds_m();
            let across_m = (max_m[0] - min_m[0]).max(max_m[1] - min_m[1]);
            assert!(
                (100.0..=200.0).contains(&across_m),
                "seed {seed}: {across_m} m"
            );
            assert!(layout.landmarks.len() >= 150, "seed {seed}");
            for (i, tree) in layout.landmarks.iter().enumerate() {
                assert_eq!(tree.id as usize, i);
                assert!((0.2..=1.0).contains(&tree.radius_m));
            }
            let radii: Vec<f64> = layout.landmarks.iter().map(|t| t.radius_m).collect();
            assert!(radii.iter().any(|&r| r < 0.3) && radii.iter().any(|&r| r > 0.8));
        }
    }

    #[test]
    fn polygon_helpers() {
        let l_shape = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 2.0],
            [2.0, 2.0],
            [2.0, 4.0],
            [0.0, 4.0],
        ];
        assert!(inside_polygon([1.0, 3.0], &l_shape));
        assert!(!inside_polygon([3.0, 3.0], &l_shape));
        assert_eq!(closed_polygon(&l_shape).len(), 6);
        let turned = place(&[[1.0, 0.0]], [10.0, 0.0], FRAC_PI_2);
        assert!((turned[0][0] - 10.0).abs() < 1e-12 && (turned[0][1] - 1.0).abs() < 1e-12);
    }
}
