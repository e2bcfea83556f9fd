//! One laser scan as the matchers see it: beam end points in the robot frame, in beam order.
//!
//! Beam order matters: the matchers draw a scan as a polyline joining consecutive valid beams,
//! so a beam without a return (`None`) breaks the line. The sensor is taken to sit at the robot
//! origin, looking along x (x forward, y left, angles counter-clockwise).

/// Beam end points in the robot frame, metres, one entry per beam in scan order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scan {
    points_in_robot: Vec<Option<[f64; 2]>>,
}

impl Scan {
    /// Builds a scan from end points in the robot frame (metres), `None` for a beam without a
    /// return. Points with a non-finite coordinate are stored as `None`.
    pub fn from_points_in_robot(points_in_robot: Vec<Option<[f64; 2]>>) -> Self {
        let points_in_robot = points_in_robot
            .into_iter()
            .map(|point| point.filter(|p| p[0].is_finite() && p[1].is_finite()))
            .collect();
        Scan { points_in_robot }
    }

    /// Builds a scan from ranges: beam `i` points at `start_angle_rad + i * angle_step_rad`
    /// (counter-clockwise from x) and ends `ranges_m[i]` metres from the sensor.
    ///
    /// A range that is not finite, not positive, or above `max_range_m` is a beam without a
    /// return (the SICK reports "no echo" as its maximum value).
    pub fn from_ranges(
        ranges_m: &[f64],
        start_angle_rad: f64,
        angle_step_rad: f64,
        max_range_m: f64,
    ) -> Self {
        let points_in_robot = ranges_m
            .iter()
            .enumerate()
            .map(|(beam, &range_m)| {
                let valid = range_m.is_finite() && range_m > 0.0 && range_m <= max_range_m;
                valid.then(|| {
                    let angle_rad = start_angle_rad + beam as f64 * angle_step_rad;
                    let (sin, cos) = angle_rad.sin_cos();
                    [range_m * cos, range_m * sin]
                })
            })
            .collect();
        Scan::from_points_in_robot(points_in_robot)
    }

    /// The beam end points in the robot frame (metres), `None` for beams without a return.
    pub fn points_in_robot(&self) -> &[Option<[f64; 2]>] {
        &self.points_in_robot
    }

    /// Number of beams, with or without a return.
    pub fn len(&self) -> usize {
        self.points_in_robot.len()
    }

    /// True if the scan has no beams at all.
    pub fn is_empty(&self) -> bool {
        self.points_in_robot.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn test_from_ranges() {
        let scan = Scan::from_ranges(&[1.0, 0.0, 2.0, 9.0, f64::NAN], -FRAC_PI_2, FRAC_PI_2, 8.0);
        let points = scan.points_in_robot();
        assert_eq!(points.len(), 5);
        let [x, y] = points[0].unwrap_or([9.9, 9.9]);
        assert!(x.abs() < 1e-12 && (y + 1.0).abs() < 1e-12);
        assert_eq!(points[1], None);
        let [x, y] = points[2].unwrap_or([9.9, 9.9]);
        assert!(x.abs() < 1e-12 && (y - 2.0).abs() < 1e-12);
        assert_eq!(points[3], None);
        assert_eq!(points[4], None);
    }

    #[test]
    fn test_non_finite_points_are_dropped() {
        let scan = Scan::from_points_in_robot(vec![Some([f64::INFINITY, 0.0]), Some([1.0, 2.0])]);
        assert_eq!(scan.points_in_robot(), &[None, Some([1.0, 2.0])]);
    }
}
