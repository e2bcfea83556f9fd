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
    /// Each obstacle's height above the ground, metres (a tree's trunk up to its crown), in
    /// the order of `shapes`: what a camera sees of it.
    pub heights_m: Vec<f64>,
    /// The round obstacles meant as landmarks (each also in `shapes`).
    pub landmarks: Vec<Landmark>,
    /// A closed loop through free space for the robot to drive.
    pub route: Route,
}
