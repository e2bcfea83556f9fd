//! What the front end reports: a landmark observation in range and bearing from the sensor,
//! the form an EKF SLAM's range-bearing observation model takes.

/// One landmark observation, sensor frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Feature {
    /// Distance from the sensor to the landmark's point (a trunk's centre, a corner's vertex),
    /// metres.
    pub range_m: f64,
    /// Direction of that point, radians counter-clockwise from the sensor's `x` axis.
    pub bearing_rad: f64,
    /// What was seen, with its shape.
    pub kind: FeatureKind,
}

/// The kind of landmark and its shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FeatureKind {
    /// A tree trunk or pole; the feature's point is the trunk's centre.
    Tree {
        /// Trunk diameter, metres.
        diameter_m: f64,
        /// Root mean square distance of the returns to the trunk's circle, metres.
        rms_residual_m: f64,
        /// Returns on the trunk.
        num_points: usize,
        /// Part of the trunk may be hidden by a nearer object or the scan's edge (reported
        /// only when asked for, see [`super::TreeOptions::keep_occluded`]).
        occluded: bool,
    },
    /// Two walls meeting; the feature's point is the vertex.
    Corner {
        /// Direction of the bisector from the vertex between the walls, sensor frame,
        /// radians.
        orientation_rad: f64,
        /// Angle between the walls, radians.
        angle_rad: f64,
        /// True for an outside corner (a building's), false for an inside one (a room's).
        convex: bool,
    },
}

impl Feature {
    /// A feature at `point_in_sensor` (metres), of `kind`.
    pub fn from_point_in_sensor(point_in_sensor: [f64; 2], kind: FeatureKind) -> Self {
        Feature {
            range_m: point_in_sensor[0].hypot(point_in_sensor[1]),
            bearing_rad: point_in_sensor[1].atan2(point_in_sensor[0]),
            kind,
        }
    }

    /// The feature's point in the sensor frame, metres.
    pub fn point_in_sensor(&self) -> [f64; 2] {
        let (sin, cos) = self.bearing_rad.sin_cos();
        [self.range_m * cos, self.range_m * sin]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_point_round_trip() {
        let kind = FeatureKind::Corner {
            orientation_rad: 0.0,
            angle_rad: 1.5,
            convex: false,
        };
        let feature = Feature::from_point_in_sensor([-3.0, 4.0], kind);
        assert!((feature.range_m - 5.0).abs() < 1e-12);
        let [x, y] = feature.point_in_sensor();
        assert!((x + 3.0).abs() < 1e-12 && (y - 4.0).abs() < 1e-12);
    }
}
