//! Where a sensor stands in the world frame (see [`super`] for the frame conventions).

/// A sensor's pose in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorPose {
    /// East coordinate, metres.
    pub x_m: f64,
    /// North coordinate, metres.
    pub y_m: f64,
    /// Direction of the sensor's forward axis, radians counter-clockwise from `+x`.
    pub heading_rad: f64,
}

impl SensorPose {
    /// A pose at (`x_m`, `y_m`) facing `heading_rad`.
    pub const fn new(x_m: f64, y_m: f64, heading_rad: f64) -> SensorPose {
        SensorPose {
            x_m,
            y_m,
            heading_rad,
        }
    }

    /// The position as an array, as [`super::World::ray_cast`] takes it.
    pub const fn position_m(&self) -> [f64; 2] {
        [self.x_m, self.y_m]
    }

    /// The world-frame direction of a ray at `bearing_rad` in the sensor frame
    /// (counter-clockwise from the forward axis).
    pub fn world_angle_rad(&self, bearing_rad: f64) -> f64 {
        self.heading_rad + bearing_rad
    }
}

impl Default for SensorPose {
    /// The middle of the default [`super::Room`], facing north (`+y`).
    fn default() -> Self {
        SensorPose::new(6.0, 3.0, core::f64::consts::FRAC_PI_2)
    }
}
