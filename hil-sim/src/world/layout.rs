//! What a world generator produces: obstacles, the landmarks among them, and a route.

use super::landmark::Landmark;
use super::route::Route;
use super::shape::Shape;

/// A generated world before it is indexed and driven: see [`super::indoor`] and
/// [`super::outdoor`].
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Every obstacle, landmarks included, world frame.
    pub shapes: Vec<Shape>,
    /// The round obstacles meant as landmarks (each also in `shapes`).
    pub landmarks: Vec<Landmark>,
    /// A closed loop through free space for the robot to drive.
    pub route: Route,
}
