//! A room made of [`Shape`]s, and the built-in default room the emulators use.
//!
//! The default room ([`Room::default`]) is 12 m (x, east) by 8 m (y, north) with its
//! south-west corner at the origin, two round pillars and a box:
//!
//! ```text
//!  y=8 +------------------------------------------+
//!      |                                          |
//!      |        (O) pillar r 0.30 m               |
//!      |       (3.0, 5.5)           [box]         |
//!      |                       8.5..10.0 x 5.0..6.0|
//!      |                 (O) pillar r 0.20 m      |
//!      |                (7.5, 4.5)                |
//!      |                                          |
//!  y=0 +------------------------------------------+
//!     x=0                                       x=12
//! ```

use super::World;
use super::shape::Shape;

/// Width of the default room (along x), metres.
pub const DEFAULT_WIDTH_M: f64 = 12.0;
/// Depth of the default room (along y), metres.
pub const DEFAULT_DEPTH_M: f64 = 8.0;

/// A static 2D world: a set of shapes.
#[derive(Debug, Clone, PartialEq)]
pub struct Room {
    shapes: Vec<Shape>,
}

impl Room {
    /// A room without anything in it.
    pub fn empty() -> Room {
        Room { shapes: Vec::new() }
    }

    /// An empty rectangular room of `width_m` × `depth_m`, south-west corner at the origin.
    pub fn rectangle(width_m: f64, depth_m: f64) -> Room {
        Room::empty().with_box([0.0, 0.0], [width_m, depth_m])
    }

    /// The default room described in the [module documentation](self).
    pub fn default_room() -> Room {
        Room::rectangle(DEFAULT_WIDTH_M, DEFAULT_DEPTH_M)
            .with_pillar([3.0, 5.5], 0.30)
            .with_pillar([7.5, 4.5], 0.20)
            .with_box([8.5, 5.0], [10.0, 6.0])
    }

    /// Adds a round pillar.
    pub fn with_pillar(mut self, center_m: [f64; 2], radius_m: f64) -> Room {
        self.shapes.push(Shape::Circle { center_m, radius_m });
        self
    }

    /// Adds an axis-aligned box with corners `min_m` and `max_m`.
    pub fn with_box(mut self, min_m: [f64; 2], max_m: [f64; 2]) -> Room {
        self.shapes.extend(Shape::rectangle(min_m, max_m));
        self
    }

    /// Adds any shape.
    pub fn with_shape(mut self, shape: Shape) -> Room {
        self.shapes.push(shape);
        self
    }

    /// The shapes.
    pub fn shapes(&self) -> &[Shape] {
        &self.shapes
    }
}

impl Default for Room {
    /// The default room ([`Room::default_room`]).
    fn default() -> Self {
        Room::default_room()
    }
}

impl World for Room {
    fn ray_cast(&self, origin_m: [f64; 2], angle_rad: f64, max_range_m: f64) -> Option<f64> {
        let dir = [angle_rad.cos(), angle_rad.sin()];
        self.shapes
            .iter()
            .filter_map(|shape| shape.intersect(origin_m, dir))
            .filter(|&t| t <= max_range_m)
            .min_by(f64::total_cmp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn walls_of_the_default_room() {
        let room = Room::default_room();
        // From (6, 3): east wall 6 m away, west wall 6 m, south wall 3 m.
        let east = room.ray_cast([6.0, 3.0], 0.0, 80.0).unwrap();
        let west = room.ray_cast([6.0, 3.0], PI, 80.0).unwrap();
        let south = room.ray_cast([6.0, 3.0], -FRAC_PI_2, 80.0).unwrap();
        assert!((east - 6.0).abs() < 1e-9);
        assert!((west - 6.0).abs() < 1e-9);
        assert!((south - 3.0).abs() < 1e-9);
        assert_eq!(room.ray_cast([6.0, 3.0], 0.0, 5.0), None);
    }

    #[test]
    fn pillar_and_box_shadow_the_walls() {
        let room = Room::default_room();
        // Straight north from (7.5, 3.0): the 0.2 m pillar at (7.5, 4.5).
        let d = room.ray_cast([7.5, 3.0], FRAC_PI_2, 80.0).unwrap();
        assert!((d - 1.3).abs() < 1e-9);
        // Straight north from (9.0, 3.0): the box's south face at y = 5.
        let d = room.ray_cast([9.0, 3.0], FRAC_PI_2, 80.0).unwrap();
        assert!((d - 2.0).abs() < 1e-9);
    }

    #[test]
    fn empty_room_sees_nothing() {
        assert_eq!(Room::empty().ray_cast([0.0, 0.0], 1.0, 100.0), None);
    }
}
