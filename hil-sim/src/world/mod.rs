//! A minimal 2D world for range sensing: what a laser scanner emulator measures.
//!
//! Frames: the world frame is a right-handed plane frame with `x` east and `y` north, in
//! metres; angles are in radians, counter-clockwise from `+x`. A [`SensorPose`] places a
//! sensor in that frame: its position and the direction its forward axis points to.
//!
//! * [`World`]: the one query range sensors need, [`World::ray_cast`].
//! * [`Shape`] ([`shape`]): segments and circles, each intersected exactly with a ray.
//! * [`Room`] ([`room`]): a world made of shapes, with a built-in default room.
//! * [`GeoDatum`] ([`geo`]): local east/north metres to latitude/longitude, for GNSS emulators.
//! * [`ShapeWorld`] ([`shape_world`]): many shapes behind a grid index, for large worlds.
//! * [`CameraView`] ([`camera_view`]): what a camera on the robot sees, rendered.
//! * [`Scenario`] ([`scenario`]): a seeded world ([`indoor`] office floor or [`outdoor`]
//!   park, each a [`Layout`] with [`Landmark`]s and a [`Route`]) and the robot's true
//!   [`Trajectory`] of [`RobotState`]s round it, driven by [`PurePursuit`].

pub mod aerial;
pub mod camera_view;
pub mod geo;
pub mod indoor;
pub mod landmark;
pub mod layout;
pub mod outdoor;
pub mod pose;
pub mod pure_pursuit;
pub mod robot_state;
pub mod room;
pub mod route;
pub mod scenario;
pub mod shape;
pub mod shape_world;
pub mod trajectory;
pub mod walkers;

pub use camera_view::{CameraRigOptions, CameraView, Mover};
pub use geo::GeoDatum;
pub use landmark::Landmark;
pub use layout::Layout;
pub use pose::SensorPose;
pub use pure_pursuit::PurePursuit;
pub use robot_state::RobotState;
pub use room::Room;
pub use route::Route;
pub use scenario::{ParseWorldKindError, Scenario, WorldKind};
pub use shape::Shape;
pub use shape_world::ShapeWorld;
pub use trajectory::Trajectory;
pub use walkers::Walkers;

/// Something rays can be cast into.
pub trait World {
    /// Distance in metres from `origin_m` along the ray at `angle_rad` (world frame, counter-
    /// clockwise from `+x`) to the first surface hit, or `None` when nothing lies within
    /// `max_range_m`. An origin inside a closed shape sees that shape's boundary.
    fn ray_cast(&self, origin_m: [f64; 2], angle_rad: f64, max_range_m: f64) -> Option<f64>;
}

impl<W: World + ?Sized> World for &W {
    fn ray_cast(&self, origin_m: [f64; 2], angle_rad: f64, max_range_m: f64) -> Option<f64> {
        (**self).ray_cast(origin_m, angle_rad, max_range_m)
    }
}

impl<W: World + ?Sized> World for Box<W> {
    fn ray_cast(&self, origin_m: [f64; 2], angle_rad: f64, max_range_m: f64) -> Option<f64> {
        (**self).ray_cast(origin_m, angle_rad, max_range_m)
    }
}
