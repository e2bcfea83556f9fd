//! A seeded office floor: rooms along a ring of corridors, driven round by the robot.
//!
//! The floor is a `W` × `H` rectangle (28–36 m by 20–28 m) with its south-west corner at the
//! origin. A frame of rooms 3.5–4.5 m deep lines the outer walls; inside it a ring of
//! corridors (1.8–2.4 m wide) surrounds a central block of rooms. One of the south and north
//! corridors is a hall 4–5 m wide with a row of round pillars (the landmarks, radius
//! 0.15–0.3 m) along each of its walls, 0.8 m out from the wall and clear of doors. With
//! some seeds a cross corridor cuts the central block in two, giving a second loop.
//!
//! ```text
//!  +-------------------------------------------+
//!  |   rooms (north row, corners included)     |
//!  +-----+-----------------------------+-------+
//!  |     |           corridor          |       |
//!  |  r  |   +---------+ c +---------+ |   r   |
//!  |  o  |   | central | r | central | |   o   |
//!  |  o  |   |  block  | o |  block  | |   o   |
//!  |  m  |   +---------+ s +---------+ |   m   |
//!  |  s  |    o    o    hall    o    o |   s   |
//!  |     |  o    o     o     o     o   |       |
//!  +-----+-----------------------------+-------+
//!  |   rooms (south row, corners included)     |
//!  +-------------------------------------------+
//! ```
//!
//! Every room has one door (0.9–1.2 m) onto a corridor, and about half of the rooms hold a
//! box. The route follows the corridor centre lines: once round the ring, or, with a cross
//! corridor, a figure of eight through it (both loops, the cross corridor twice). Nothing
//! stands within 0.9 m of a corridor centre line.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::landmark::Landmark;
use super::layout::Layout;
use super::route::Route;
use super::shape::Shape;

/// Narrowest room along its corridor, metres.
const MIN_ROOM_WIDTH_M: f64 = 3.0;
/// Widest room along its corridor (except where a row ends), metres.
const MAX_ROOM_WIDTH_M: f64 = 5.5;
/// Space between a door and the next wall, metres.
const DOOR_MARGIN_M: f64 = 0.3;
/// Distance of a hall pillar's centre from the wall it stands along, metres.
const PILLAR_OFFSET_M: f64 = 0.8;
/// Height of the walls and pillars, metres.
const STOREY_HEIGHT_M: f64 = 2.6;

/// The office floor for `seed`, described in the [module documentation](self).
pub fn generate(seed: u64) -> Layout {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rng = &mut rng;
    let width_m = rng.random_range(28.0..36.0);
    let height_m = rng.random_range(20.0..28.0);
    let depth_m = rng.random_range(3.5..4.5);
    let hall_m = rng.random_range(4.0..5.0);
    let hall_south = rng.random_bool(0.5);
    let mut corridor = || rng.random_range(1.8..2.4);
    let (west_m, east_m) = (corridor(), corridor());
    let (south_m, north_m) = if hall_south {
        (hall_m, corridor())
    } else {
        (corridor(), hall_m)
    };

    let mut floor = Floor::default();
    floor
        .shapes
        .extend(Shape::rectangle([0.0, 0.0], [width_m, height_m]));

    // The frame of rooms along the outer walls. The south and north rows own the corners.
    let x_span = [depth_m, width_m - depth_m];
    let y_span = [depth_m, height_m - depth_m];
    let south_row = Rect::new([0.0, 0.0], [width_m, depth_m]);
    let north_row = Rect::new([0.0, height_m - depth_m], [width_m, height_m]);
    floor.room_row(rng, south_row, Side::North, x_span);
    floor.room_row(rng, north_row, Side::South, x_span);
    let west_row = Rect::new([0.0, depth_m], [depth_m, height_m - depth_m]);
    let east_row = Rect::new([width_m - depth_m, depth_m], [width_m, height_m - depth_m]);
    floor.room_row(rng, west_row, Side::East, y_span);
    floor.room_row(rng, east_row, Side::West, y_span);

    // Corridor centre lines.
    let x_west = depth_m + west_m / 2.0;
    let x_east = width_m - depth_m - east_m / 2.0;
    let y_south = depth_m + south_m / 2.0;
    let y_north = height_m - depth_m - north_m / 2.0;

    // The central block, maybe cut by a cross corridor.
    let block = Rect::new(
        [depth_m + west_m, depth_m + south_m],
        [width_m - depth_m - east_m, height_m - depth_m - north_m],
    );
    let block_width_m = block.max[0] - block.min[0];
    let cross = (block_width_m >= 12.0 && rng.random_bool(0.7)).then(|| {
        let cross_m = rng.random_range(1.8..2.4);
        let x_m = block.min[0] + block_width_m * rng.random_range(0.35..0.65);
        (x_m, cross_m)
    });
    let waypoints_m = match cross {
        None => {
            floor.block(rng, block);
            vec![
                [(x_west + x_east) / 2.0, y_south],
                [x_east, y_south],
                [x_east, y_north],
                [x_west, y_north],
                [x_west, y_south],
            ]
        }
        Some((x_cross, cross_m)) => {
            let west_block = Rect::new(block.min, [x_cross - cross_m / 2.0, block.max[1]]);
            let east_block = Rect::new([x_cross + cross_m / 2.0, block.min[1]], block.max);
            floor.block(rng, west_block);
            floor.block(rng, east_block);
            // A figure of eight: the east loop, down the cross corridor, the west loop, and
            // down the cross corridor again.
            vec![
                [x_cross, y_south],
                [x_east, y_south],
                [x_east, y_north],
                [x_cross, y_north],
                [x_cross, y_south],
                [x_west, y_south],
                [x_west, y_north],
                [x_cross, y_north],
            ]
        }
    };
    // A colonnade along each wall of the hall, in front of the wall between openings, clear
    // of the corridor corners and junctions.
    let (outer_wall_m, inner_wall_m, into_hall) = if hall_south {
        (depth_m, block.min[1], 1.0)
    } else {
        (height_m - depth_m, block.max[1], -1.0)
    };
    let limits_m = [x_west + 1.5, x_east - 1.5];
    let junction: Vec<[f64; 2]> = cross
        .map(|(x_m, cross_m)| [x_m - cross_m / 2.0 - 0.5, x_m + cross_m / 2.0 + 0.5])
        .into_iter()
        .collect();
    floor.colonnade(rng, outer_wall_m, into_hall, limits_m, &[]);
    floor.colonnade(rng, inner_wall_m, -into_hall, limits_m, &junction);

    let waypoints_m = if rng.random_bool(0.5) {
        reversed_loop(waypoints_m)
    } else {
        waypoints_m
    };

    Layout {
        heights_m: vec![STOREY_HEIGHT_M; floor.shapes.len()],
        shapes: floor.shapes,
        landmarks: floor.landmarks,
        route: Route::closed(waypoints_m),
    }
}

/// The same loop driven the other way round from the same start.
fn reversed_loop(mut waypoints_m: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    waypoints_m[1..].reverse();
    waypoints_m
}

/// A side of an axis-aligned rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    South,
    North,
    West,
    East,
}

impl Side {
    /// The axis the side runs along (0 = x, 1 = y).
    fn along_axis(self) -> usize {
        match self {
            Side::South | Side::North => 0,
            Side::West | Side::East => 1,
        }
    }

    fn opposite(self) -> Side {
        match self {
            Side::South => Side::North,
            Side::North => Side::South,
            Side::West => Side::East,
            Side::East => Side::West,
        }
    }
}

/// An axis-aligned rectangle, world frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    min: [f64; 2],
    max: [f64; 2],
}

impl Rect {
    fn new(min: [f64; 2], max: [f64; 2]) -> Rect {
        Rect { min, max }
    }

    /// The coordinate (across the side's axis) of `side`.
    fn edge_m(&self, side: Side) -> f64 {
        match side {
            Side::South => self.min[1],
            Side::North => self.max[1],
            Side::West => self.min[0],
            Side::East => self.max[0],
        }
    }
}

/// The point `along_m` on `axis` and `across_m` on the other axis.
fn point(axis: usize, along_m: f64, across_m: f64) -> [f64; 2] {
    if axis == 0 {
        [along_m, across_m]
    } else {
        [across_m, along_m]
    }
}

/// A wall parallel to `axis` from `from_m` to `to_m`, at `across_m` on the other axis.
fn wall(axis: usize, from_m: f64, to_m: f64, across_m: f64) -> Shape {
    Shape::Segment {
        a_m: point(axis, from_m, across_m),
        b_m: point(axis, to_m, across_m),
    }
}

/// The floor under construction.
#[derive(Debug, Default)]
struct Floor {
    shapes: Vec<Shape>,
    landmarks: Vec<Landmark>,
    /// Every door so far: the axis its wall runs along, the wall's coordinate on the other
    /// axis, and the opening's extent along the wall.
    doors: Vec<(usize, f64, [f64; 2])>,
}

impl Floor {
    /// Adds a round pillar, which is also a landmark.
    fn pillar(&mut self, center_m: [f64; 2], radius_m: f64) {
        let landmark = Landmark {
            // Cannot truncate: a floor holds a few dozen pillars.
            id: self.landmarks.len() as u32,
            center_m,
            radius_m,
        };
        self.shapes.push(landmark.shape());
        self.landmarks.push(landmark);
    }

    /// Pillars standing `PILLAR_OFFSET_M` from the wall along x at `wall_y_m` (towards
    /// `into` = ±1 in y), at most one in front of each stretch of wall between door
    /// openings (and the extra `openings_m`), 0.6 m clear of them, within `limits_m` in x.
    fn colonnade(
        &mut self,
        rng: &mut ChaCha8Rng,
        wall_y_m: f64,
        into: f64,
        limits_m: [f64; 2],
        openings_m: &[[f64; 2]],
    ) {
        let mut gaps_m: Vec<[f64; 2]> = self
            .doors
            .iter()
            .filter(|(axis, across_m, _)| *axis == 0 && (across_m - wall_y_m).abs() < 1e-9)
            .map(|door| door.2)
            .chain(openings_m.iter().copied())
            .collect();
        gaps_m.sort_by(|a, b| a[0].total_cmp(&b[0]));
        let mut from_m = limits_m[0];
        let mut stretches_m = Vec::new();
        for gap in &gaps_m {
            stretches_m.push([from_m, gap[0].min(limits_m[1])]);
            from_m = from_m.max(gap[1]);
        }
        stretches_m.push([from_m, limits_m[1]]);
        for stretch in stretches_m {
            let radius_m = rng.random_range(0.15..0.3);
            let lo_m = stretch[0] + 0.6 + radius_m;
            let hi_m = stretch[1] - 0.6 - radius_m;
            if lo_m < hi_m && rng.random_bool(0.8) {
                let x_m = rng.random_range(lo_m..hi_m);
                self.pillar([x_m, wall_y_m + into * PILLAR_OFFSET_M], radius_m);
            }
        }
    }

    /// Divides `rect` into rooms side by side, each with a door in its `facing` wall where
    /// that wall lies within `door_span_m` (along the wall). Adds the facing wall and the
    /// partitions, not the other three sides.
    fn room_row(&mut self, rng: &mut ChaCha8Rng, rect: Rect, facing: Side, door_span_m: [f64; 2]) {
        let axis = facing.along_axis();
        let facing_m = rect.edge_m(facing);
        let back_m = rect.edge_m(facing.opposite());
        let inward = (back_m - facing_m).signum();

        // Partitions, so that every room has at least MIN_ROOM_WIDTH_M of door span.
        let mut bounds_m = vec![rect.min[axis]];
        let mut at_m = door_span_m[0];
        loop {
            at_m += rng.random_range(MIN_ROOM_WIDTH_M..MAX_ROOM_WIDTH_M);
            if at_m > door_span_m[1] - MIN_ROOM_WIDTH_M {
                break;
            }
            bounds_m.push(at_m);
            self.shapes.push(wall(1 - axis, facing_m, back_m, at_m));
        }
        bounds_m.push(rect.max[axis]);

        let mut doors_m = Vec::new();
        for room in bounds_m.windows(2) {
            let lo_m = room[0].max(door_span_m[0]) + DOOR_MARGIN_M;
            let hi_m = room[1].min(door_span_m[1]) - DOOR_MARGIN_M;
            let door_m = rng.random_range(0.9..1.2);
            if hi_m - lo_m > door_m {
                let start_m = rng.random_range(lo_m..hi_m - door_m);
                doors_m.push([start_m, start_m + door_m]);
                self.doors
                    .push((axis, facing_m, [start_m, start_m + door_m]));
            }
            // A box somewhere in the room, away from the door side.
            if rng.random_bool(0.5) {
                let size_m = [rng.random_range(0.5..1.2), rng.random_range(0.5..1.0)];
                let along_m = [room[0] + 0.3, room[1] - 0.3 - size_m[0]];
                let (d0, d1) = (facing_m + inward * 1.2, back_m - inward * 0.3);
                let across_m = [d0.min(d1), d0.max(d1) - size_m[1]];
                if along_m[0] < along_m[1] && across_m[0] < across_m[1] {
                    let a = rng.random_range(along_m[0]..along_m[1]);
                    let c = rng.random_range(across_m[0]..across_m[1]);
                    let p0 = point(axis, a, c);
                    let p1 = point(axis, a + size_m[0], c + size_m[1]);
                    let min = [p0[0].min(p1[0]), p0[1].min(p1[1])];
                    let max = [p0[0].max(p1[0]), p0[1].max(p1[1])];
                    self.shapes.extend(Shape::rectangle(min, max));
                }
            }
        }

        // The facing wall with its door openings.
        let mut from_m = rect.min[axis];
        for door in &doors_m {
            self.shapes.push(wall(axis, from_m, door[0], facing_m));
            from_m = door[1];
        }
        self.shapes
            .push(wall(axis, from_m, rect.max[axis], facing_m));
    }

    /// A free-standing block of rooms surrounded by corridors: one row facing a long side,
    /// or two rows back to back when the block is deep enough.
    fn block(&mut self, rng: &mut ChaCha8Rng, rect: Rect) {
        let size_m = [rect.max[0] - rect.min[0], rect.max[1] - rect.min[1]];
        let long = if size_m[0] >= size_m[1] { 0 } else { 1 };
        let across = 1 - long;
        let (low, high) = if long == 0 {
            (Side::South, Side::North)
        } else {
            (Side::West, Side::East)
        };
        let span_m = [rect.min[long], rect.max[long]];
        // The two short ends.
        for end_m in span_m {
            self.shapes
                .push(wall(across, rect.min[across], rect.max[across], end_m));
        }
        if size_m[across] >= 7.0 {
            let mid_m = (rect.min[across] + rect.max[across]) / 2.0;
            let mut low_max = rect.max;
            low_max[across] = mid_m;
            let mut high_min = rect.min;
            high_min[across] = mid_m;
            self.room_row(rng, Rect::new(rect.min, low_max), low, span_m);
            self.room_row(rng, Rect::new(high_min, rect.max), high, span_m);
            self.shapes.push(wall(long, span_m[0], span_m[1], mid_m));
        } else {
            let facing = if rng.random_bool(0.5) { low } else { high };
            self.room_row(rng, rect, facing, span_m);
            let back_m = rect.edge_m(facing.opposite());
            self.shapes.push(wall(long, span_m[0], span_m[1], back_m));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_and_contents() {
        for seed in 0..20 {
            let layout = generate(seed);
            let world = crate::world::ShapeWorld::new(layout.shapes.clone());
            let (min_m, max_m) = world.bounds_m();
            let across_m = (max_m[0] - min_m[0]).max(max_m[1] - min_m[1]);
            assert!(
                (20.0..=40.0).contains(&across_m),
                "seed {seed}: {across_m} m"
            );
            assert!(layout.shapes.len() > 40, "seed {seed}");
            assert!(!layout.landmarks.is_empty(), "seed {seed}");
            for landmark in &layout.landmarks {
                assert!(layout.shapes.contains(&landmark.shape()));
            }
        }
    }

    #[test]
    fn some_seeds_have_a_cross_corridor() {
        let figure_eights = (0..20)
            .filter(|&seed| generate(seed).route.waypoints_m().len() == 8)
            .count();
        assert!((1..20).contains(&figure_eights), "{figure_eights}");
    }
}
