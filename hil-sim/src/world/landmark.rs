//! Point-like features a landmark-based SLAM method can map: tree trunks and pillars.

/// A round landmark in the world frame (also present in the world as a [`super::Shape::Circle`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark {
    /// Identifier, unique within a scenario, numbered from 0 in generation order.
    pub id: u32,
    /// Centre (east, north), world frame, metres.
    pub center_m: [f64; 2],
    /// Radius, metres.
    pub radius_m: f64,
}

impl Landmark {
    /// The shape the landmark occupies in the world.
    pub fn shape(&self) -> super::Shape {
        super::Shape::Circle {
            center_m: self.center_m,
            radius_m: self.radius_m,
        }
    }
}
