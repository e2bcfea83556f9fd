//! The geometry every module shares: planar poses and the frames they connect.
//!
//! * [`Pose2`]: a rigid transform of the plane, used both as a pose and as a change of frame;
//!   [`wrap_angle_rad`] keeps angles in `(-pi, pi]`.
//!
//! # Frames
//!
//! Names say the frame a value is expressed in (`pose_in_map`, `point_in_robot`), and
//! transforms say both (`map_from_robot`, which is the same thing as the robot's
//! `pose_in_map`). The frames of the host:
//!
//! | frame | what it is fixed to |
//! |---|---|
//! | `sensor` | the laser: x along its 90° beam, y to its left |
//! | `robot` | the robot: x forward, y left, z up |
//! | `camera` | the camera: x right, y down, z forward |
//! | `submap` / `local_map` | a submap or EKF local map, at the robot's pose when it began |
//! | `map` | the global SLAM frame, at the robot's first pose unless geo-referenced |
//! | `enu` | a local metric frame at the GPS datum: x east, y north, z up |
//! | `wgs84` | latitude, longitude and height on the WGS84 ellipsoid |
//! | `image` | pixels of a geo-referenced image: column right, row down |
//!
//! All lengths are metres and all angles radians, counter-clockwise from x.

mod pose2;

pub use pose2::{Pose2, wrap_angle_rad};
