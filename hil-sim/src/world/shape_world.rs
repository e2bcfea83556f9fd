//! A [`World`] over any number of [`Shape`]s, indexed by a uniform grid.
//!
//! Every shape is registered in each grid cell its bounding box (grown by a micrometre to
//! absorb rounding at cell boundaries) overlaps. A ray walks the cells it crosses in order of
//! distance (Amanatides and Woo, "A Fast Voxel Traversal Algorithm for Ray Tracing", 1987),
//! intersects the shapes registered in each cell with [`Shape::intersect`], and stops at the
//! first cell whose far boundary lies at or beyond the nearest hit found so far.
//!
//! Contract: [`ShapeWorld::ray_cast`] returns exactly (bit for bit) what a loop over all
//! shapes returns, because it calls the same intersection routine on the same ray and only
//! skips shapes that cannot be hit before the answer.

use super::World;
use super::shape::Shape;

/// Growth of every bounding box before it is registered in the grid, metres.
const BOX_MARGIN_M: f64 = 1e-6;
/// Padding of the grid around the union of all bounding boxes, metres.
const GRID_PADDING_M: f64 = 1e-3;
/// Smallest cell size the automatic choice makes, metres.
const MIN_AUTO_CELL_M: f64 = 0.25;
/// Largest cell size the automatic choice makes, metres.
const MAX_AUTO_CELL_M: f64 = 8.0;
/// Upper bound on the number of cells along either axis.
const MAX_CELLS_PER_AXIS: usize = 1024;

/// A static world of shapes with a spatial index for fast ray casting.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeWorld {
    shapes: Vec<Shape>,
    grid: Grid,
}

/// A uniform grid over the shapes' bounding box; each cell lists the shapes that may touch it.
#[derive(Debug, Clone, PartialEq)]
struct Grid {
    /// South-west corner of cell (0, 0), world frame, metres.
    min_m: [f64; 2],
    /// Side of a square cell, metres.
    cell_m: f64,
    /// Number of cells along x and y.
    dims: [usize; 2],
    /// Shapes of cell `c` (row-major, x fastest) are `entries[cell_start[c]..cell_start[c + 1]]`.
    cell_start: Vec<usize>,
    /// Shape indices, grouped by cell.
    entries: Vec<u32>,
}

impl ShapeWorld {
    /// A world of `shapes` with a cell size chosen from their density (about one shape per
    /// cell, between 0.25 m and 8 m).
    pub fn new(shapes: Vec<Shape>) -> ShapeWorld {
        let (min_m, max_m) = bounds_m(&shapes);
        let area_m2 = (max_m[0] - min_m[0]) * (max_m[1] - min_m[1]);
        let count = shapes.len().max(1) as f64;
        let cell_m = (area_m2 / count)
            .sqrt()
            .clamp(MIN_AUTO_CELL_M, MAX_AUTO_CELL_M);
        ShapeWorld::with_cell_size(shapes, cell_m)
    }

    /// A world of `shapes` indexed with square cells of about `cell_m` metres (made larger
    /// if the grid would exceed 1024 cells along an axis).
    ///
    /// # Panics
    ///
    /// If `cell_m` is not a positive finite number, or there are more than `u32::MAX` shapes.
    pub fn with_cell_size(shapes: Vec<Shape>, cell_m: f64) -> ShapeWorld {
        assert!(
            cell_m.is_finite() && cell_m > 0.0,
            "cell size must be positive"
        );
        assert!(u32::try_from(shapes.len()).is_ok(), "too many shapes");
        let grid = Grid::build(&shapes, cell_m);
        ShapeWorld { shapes, grid }
    }

    /// The shapes, in the order they were given.
    pub fn shapes(&self) -> &[Shape] {
        &self.shapes
    }

    /// South-west and north-east corners of the box holding every shape, metres.
    pub fn bounds_m(&self) -> ([f64; 2], [f64; 2]) {
        bounds_m(&self.shapes)
    }

    /// Distance in metres from `point_m` to the nearest shape outline, negative inside a
    /// circle; `f64::INFINITY` in an empty world. Checks every shape (linear in their number).
    pub fn clearance_m(&self, point_m: [f64; 2]) -> f64 {
        self.shapes
            .iter()
            .map(|shape| distance_to_shape_m(shape, point_m))
            .fold(f64::INFINITY, f64::min)
    }
}

impl World for ShapeWorld {
    fn ray_cast(&self, origin_m: [f64; 2], angle_rad: f64, max_range_m: f64) -> Option<f64> {
        let dir = [angle_rad.cos(), angle_rad.sin()];
        let grid = &self.grid;
        let (t_enter, t_exit) = grid.clip(origin_m, dir)?;
        let t_start = t_enter.max(0.0);
        if t_start > t_exit || t_start > max_range_m {
            return None;
        }

        // Set up the cell walk at the point where the ray enters the grid (or its origin).
        let mut cell = [0usize; 2];
        let mut step = [0isize; 2];
        let mut t_next = [f64::INFINITY; 2];
        let mut t_delta = [f64::INFINITY; 2];
        for axis in 0..2 {
            let p_m = origin_m[axis] + t_start * dir[axis];
            let index = grid.index_along(axis, p_m);
            cell[axis] = index;
            let lower_m = grid.min_m[axis] + index as f64 * grid.cell_m;
            if dir[axis] > 0.0 {
                step[axis] = 1;
                t_next[axis] = (lower_m + grid.cell_m - origin_m[axis]) / dir[axis];
                t_delta[axis] = grid.cell_m / dir[axis];
            } else if dir[axis] < 0.0 {
                step[axis] = -1;
                t_next[axis] = (lower_m - origin_m[axis]) / dir[axis];
                t_delta[axis] = -grid.cell_m / dir[axis];
            }
        }

        let mut nearest: Option<f64> = None;
        loop {
            for &k in grid.cell_entries(cell) {
                let hit = self.shapes[k as usize]
                    .intersect(origin_m, dir)
                    .filter(|&t| t <= max_range_m && nearest.is_none_or(|best| t < best));
                if hit.is_some() {
                    nearest = hit;
                }
            }
            let t_cell_exit = t_next[0].min(t_next[1]);
            // Any closer hit would lie in a cell already visited; anything farther is out of
            // range.
            if nearest.is_some_and(|best| best <= t_cell_exit) || t_cell_exit > max_range_m {
                return nearest;
            }
            let axis = if t_next[0] < t_next[1] { 0 } else { 1 };
            let next = cell[axis] as isize + step[axis];
            if next < 0 || next >= grid.dims[axis] as isize {
                return nearest;
            }
            cell[axis] = next as usize;
            t_next[axis] += t_delta[axis];
        }
    }
}

impl Grid {
    fn build(shapes: &[Shape], cell_m: f64) -> Grid {
        let (min_m, max_m) = bounds_m(shapes);
        let extent_m = [max_m[0] - min_m[0], max_m[1] - min_m[1]];
        let limit = MAX_CELLS_PER_AXIS as f64;
        let cell_m = cell_m.max(extent_m[0] / limit).max(extent_m[1] / limit);
        let dims = extent_m.map(|e| ((e / cell_m).ceil() as usize).clamp(1, MAX_CELLS_PER_AXIS));
        let mut grid = Grid {
            min_m,
            cell_m,
            dims,
            cell_start: vec![0; dims[0] * dims[1] + 1],
            entries: Vec::new(),
        };

        // Two passes: count the shapes per cell, then place them (compressed rows).
        let mut counts = vec![0usize; dims[0] * dims[1]];
        for shape in shapes {
            grid.for_each_cell_of(shape, |c| counts[c] += 1);
        }
        for (c, count) in counts.iter().enumerate() {
            grid.cell_start[c + 1] = grid.cell_start[c] + count;
        }
        let mut fill = grid.cell_start.clone();
        grid.entries = vec![0; grid.cell_start[counts.len()]];
        for (k, shape) in shapes.iter().enumerate() {
            // Cannot truncate: `ShapeWorld::with_cell_size` checked the count fits in u32.
            let k = k as u32;
            let mut cells = Vec::new();
            grid.for_each_cell_of(shape, |c| cells.push(c));
            for c in cells {
                grid.entries[fill[c]] = k;
                fill[c] += 1;
            }
        }
        grid
    }

    /// Calls `f` with the index of every cell the grown bounding box of `shape` overlaps.
    fn for_each_cell_of(&self, shape: &Shape, mut f: impl FnMut(usize)) {
        let (lo_m, hi_m) = bounding_box_m(shape);
        let x0 = self.index_along(0, lo_m[0] - BOX_MARGIN_M);
        let x1 = self.index_along(0, hi_m[0] + BOX_MARGIN_M);
        let y0 = self.index_along(1, lo_m[1] - BOX_MARGIN_M);
        let y1 = self.index_along(1, hi_m[1] + BOX_MARGIN_M);
        for y in y0..=y1 {
            for x in x0..=x1 {
                f(y * self.dims[0] + x);
            }
        }
    }

    /// The index along `axis` of the cell holding coordinate `p_m`, clamped to the grid.
    fn index_along(&self, axis: usize, p_m: f64) -> usize {
        let index = ((p_m - self.min_m[axis]) / self.cell_m).floor();
        let last = (self.dims[axis] - 1) as f64;
        // `max` before `min` also maps NaN to 0.
        index.max(0.0).min(last) as usize
    }

    /// The shapes registered in `cell`.
    fn cell_entries(&self, cell: [usize; 2]) -> &[u32] {
        debug_assert!(cell[0] < self.dims[0] && cell[1] < self.dims[1]);
        let c = cell[1] * self.dims[0] + cell[0];
        &self.entries[self.cell_start[c]..self.cell_start[c + 1]]
    }

    /// Ray parameters where the ray `origin + t·dir` enters and leaves the grid (slab test),
    /// or `None` if the line misses it.
    fn clip(&self, origin_m: [f64; 2], dir: [f64; 2]) -> Option<(f64, f64)> {
        let mut t_enter = f64::NEG_INFINITY;
        let mut t_exit = f64::INFINITY;
        for axis in 0..2 {
            let lo_m = self.min_m[axis];
            let hi_m = lo_m + self.dims[axis] as f64 * self.cell_m;
            if dir[axis] == 0.0 {
                if origin_m[axis] < lo_m || origin_m[axis] > hi_m {
                    return None;
                }
            } else {
                let t0 = (lo_m - origin_m[axis]) / dir[axis];
                let t1 = (hi_m - origin_m[axis]) / dir[axis];
                t_enter = t_enter.max(t0.min(t1));
                t_exit = t_exit.min(t0.max(t1));
            }
        }
        (t_enter <= t_exit).then_some((t_enter, t_exit))
    }
}

/// Axis-aligned bounding box of `shape`: south-west and north-east corners, metres.
fn bounding_box_m(shape: &Shape) -> ([f64; 2], [f64; 2]) {
    match *shape {
        Shape::Segment { a_m, b_m } => (
            [a_m[0].min(b_m[0]), a_m[1].min(b_m[1])],
            [a_m[0].max(b_m[0]), a_m[1].max(b_m[1])],
        ),
        Shape::Circle { center_m, radius_m } => {
            let r = radius_m.abs();
            (
                [center_m[0] - r, center_m[1] - r],
                [center_m[0] + r, center_m[1] + r],
            )
        }
    }
}

/// The padded union of the bounding boxes of `shapes` (a small box at the origin when empty).
fn bounds_m(shapes: &[Shape]) -> ([f64; 2], [f64; 2]) {
    let mut lo_m = [f64::INFINITY; 2];
    let mut hi_m = [f64::NEG_INFINITY; 2];
    for shape in shapes {
        let (a, b) = bounding_box_m(shape);
        for axis in 0..2 {
            lo_m[axis] = lo_m[axis].min(a[axis]);
            hi_m[axis] = hi_m[axis].max(b[axis]);
        }
    }
    if shapes.is_empty() {
        return ([-GRID_PADDING_M; 2], [GRID_PADDING_M; 2]);
    }
    (
        lo_m.map(|v| v - GRID_PADDING_M),
        hi_m.map(|v| v + GRID_PADDING_M),
    )
}

/// Distance in metres from `point_m` to the outline of `shape`; for a circle, negative
/// inside (the distance a solid disc keeps from the point).
pub fn distance_to_shape_m(shape: &Shape, point_m: [f64; 2]) -> f64 {
    match *shape {
        Shape::Segment { a_m, b_m } => distance_to_segment_m(point_m, a_m, b_m),
        Shape::Circle { center_m, radius_m } => {
            (point_m[0] - center_m[0]).hypot(point_m[1] - center_m[1]) - radius_m
        }
    }
}

/// Distance in metres from `point_m` to the segment from `a_m` to `b_m`.
pub fn distance_to_segment_m(point_m: [f64; 2], a_m: [f64; 2], b_m: [f64; 2]) -> f64 {
    let edge = [b_m[0] - a_m[0], b_m[1] - a_m[1]];
    let to_p = [point_m[0] - a_m[0], point_m[1] - a_m[1]];
    let len2 = edge[0] * edge[0] + edge[1] * edge[1];
    let s = if len2 > 0.0 {
        ((to_p[0] * edge[0] + to_p[1] * edge[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (to_p[0] - s * edge[0]).hypot(to_p[1] - s * edge[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Room;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A cluttered test scene: random circles and segments, some long, some degenerate.
    fn random_shapes(rng: &mut ChaCha8Rng, count: usize) -> Vec<Shape> {
        (0..count)
            .map(|i| {
                let p = [rng.random_range(-30.0..30.0), rng.random_range(-30.0..30.0)];
                match i % 3 {
                    0 => Shape::Circle {
                        center_m: p,
                        radius_m: rng.random_range(0.05..1.5),
                    },
                    1 => Shape::Segment {
                        a_m: p,
                        b_m: [
                            p[0] + rng.random_range(-3.0..3.0),
                            p[1] + rng.random_range(-3.0..3.0),
                        ],
                    },
                    // Long axis-aligned walls.
                    _ => Shape::Segment {
                        a_m: p,
                        b_m: [p[0] + rng.random_range(-20.0..20.0), p[1]],
                    },
                }
            })
            .collect()
    }

    fn brute_force(shapes: &[Shape]) -> Room {
        shapes
            .iter()
            .fold(Room::empty(), |room, &shape| room.with_shape(shape))
    }

    #[test]
    fn same_nearest_hit_as_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for (count, cell_m) in [(1, 1.0), (60, 0.3), (300, 2.0), (300, 9.0)] {
            let shapes = random_shapes(&mut rng, count);
            let fast = ShapeWorld::with_cell_size(shapes.clone(), cell_m);
            let slow = brute_force(&shapes);
            for _ in 0..4000 {
                // Origins inside and outside the grid, any direction, short and long ranges.
                let origin = [rng.random_range(-45.0..45.0), rng.random_range(-45.0..45.0)];
                let angle = rng.random_range(-4.0..4.0);
                let range = rng.random_range(0.5..100.0);
                assert_eq!(
                    fast.ray_cast(origin, angle, range),
                    slow.ray_cast(origin, angle, range),
                    "origin {origin:?} angle {angle} range {range}"
                );
            }
        }
    }

    #[test]
    fn axis_aligned_rays_along_cell_boundaries() {
        let shapes: Vec<Shape> = Shape::rectangle([0.0, 0.0], [10.0, 8.0])
            .into_iter()
            .chain([Shape::Circle {
                center_m: [4.0, 4.0],
                radius_m: 1.0,
            }])
            .collect();
        let fast = ShapeWorld::with_cell_size(shapes.clone(), 1.0);
        let slow = brute_force(&shapes);
        for i in 0..=40 {
            let origin = [f64::from(i) * 0.25, 2.0];
            for angle in [
                0.0,
                core::f64::consts::FRAC_PI_2,
                core::f64::consts::PI,
                -1.0,
            ] {
                assert_eq!(
                    fast.ray_cast(origin, angle, 50.0),
                    slow.ray_cast(origin, angle, 50.0)
                );
            }
        }
    }

    #[test]
    fn empty_world_and_misses() {
        let empty = ShapeWorld::new(Vec::new());
        assert_eq!(empty.ray_cast([0.0, 0.0], 0.3, 100.0), None);
        assert_eq!(empty.clearance_m([1.0, 1.0]), f64::INFINITY);
        let wall = ShapeWorld::new(vec![Shape::Segment {
            a_m: [5.0, -1.0],
            b_m: [5.0, 1.0],
        }]);
        assert_eq!(wall.ray_cast([0.0, 0.0], 0.0, 4.0), None);
        assert_eq!(wall.ray_cast([0.0, 0.0], core::f64::consts::PI, 40.0), None);
        assert_eq!(wall.ray_cast([0.0, 0.0], 0.0, 40.0), Some(5.0));
    }

    #[test]
    fn clearance_to_segments_and_circles() {
        let world = ShapeWorld::new(vec![
            Shape::Segment {
                a_m: [0.0, 0.0],
                b_m: [4.0, 0.0],
            },
            Shape::Circle {
                center_m: [10.0, 0.0],
                radius_m: 1.0,
            },
        ]);
        assert!((world.clearance_m([2.0, 1.5]) - 1.5).abs() < 1e-12);
        assert!((world.clearance_m([-3.0, 4.0]) - 5.0).abs() < 1e-12);
        assert!((world.clearance_m([10.0, 0.5]) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn is_send_sync_clone() {
        fn check<T: Send + Sync + Clone>() {}
        check::<ShapeWorld>();
    }
}
