//! One laser scan as the landmark front end sees it: ranges in beam order, in the sensor frame.
//!
//! The front end needs the beam geometry, not only end points: segmentation scales its
//! breakpoint distance with the angle between beams, the pole estimate widens a chord by one
//! beam step, and the tree test checks that a fitted trunk does not cover beams that missed it.
//! [`crate::scan_match::Scan`] keeps end points only (and a beam without a return loses its
//! angle), so this type keeps the ranges and the angles that produced them.
//!
//! Sensor frame: `x` forward, `y` left, angles counter-clockwise from `x`. Beam `i` points at
//! `first_angle_rad + i * angle_step_rad`. A range is a return when it is finite, positive and
//! below `max_range_m`; anything else (NaN, infinity, zero, negative, the sensor's "no echo"
//! maximum) is a beam without a return.

/// Ranges of one scan in beam order, with the beam geometry that produced them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RangeScan {
    ranges_m: Vec<f64>,
    first_angle_rad: f64,
    angle_step_rad: f64,
    max_range_m: f64,
}

impl RangeScan {
    /// A scan whose beam `i` points at `first_angle_rad + i * angle_step_rad` (sensor frame,
    /// counter-clockwise from `x`) and measured `ranges_m[i]` metres.
    ///
    /// Ranges at or above `max_range_m`, non-finite or not positive are beams without a return.
    /// Non-finite angles make every beam a beam without a return; `angle_step_rad` may be
    /// negative (a clockwise scan).
    pub fn new(
        ranges_m: Vec<f64>,
        first_angle_rad: f64,
        angle_step_rad: f64,
        max_range_m: f64,
    ) -> Self {
        RangeScan {
            ranges_m,
            first_angle_rad,
            angle_step_rad,
            max_range_m,
        }
    }

    /// As [`RangeScan::new`], from single-precision ranges (as some drivers deliver them).
    pub fn from_f32(
        ranges_m: &[f32],
        first_angle_rad: f64,
        angle_step_rad: f64,
        max_range_m: f64,
    ) -> Self {
        let ranges_m = ranges_m.iter().map(|&r| f64::from(r)).collect();
        RangeScan::new(ranges_m, first_angle_rad, angle_step_rad, max_range_m)
    }

    /// Number of beams, with or without a return.
    pub fn len(&self) -> usize {
        self.ranges_m.len()
    }

    /// True if the scan has no beams at all.
    pub fn is_empty(&self) -> bool {
        self.ranges_m.is_empty()
    }

    /// The raw ranges as given, metres, including beams without a return.
    pub fn ranges_m(&self) -> &[f64] {
        &self.ranges_m
    }

    /// Angle of beam 0, radians, sensor frame.
    pub fn first_angle_rad(&self) -> f64 {
        self.first_angle_rad
    }

    /// Angle from one beam to the next, radians (negative for a clockwise scan).
    pub fn angle_step_rad(&self) -> f64 {
        self.angle_step_rad
    }

    /// Ranges at or above this are beams without a return, metres.
    pub fn max_range_m(&self) -> f64 {
        self.max_range_m
    }

    /// Angle of beam `beam`, radians, sensor frame (also for beams past the end, which the
    /// front end uses for the missing neighbours of the outer beams).
    pub fn beam_angle_rad(&self, beam: usize) -> f64 {
        self.first_angle_rad + beam as f64 * self.angle_step_rad
    }

    /// Range of beam `beam` in metres if it is a return; `None` for a beam without a return or
    /// an index past the end.
    pub fn range_m(&self, beam: usize) -> Option<f64> {
        let range_m = *self.ranges_m.get(beam)?;
        let angle_ok = self.beam_angle_rad(beam).is_finite();
        let is_return =
            angle_ok && range_m.is_finite() && range_m > 0.0 && range_m < self.max_range_m;
        is_return.then_some(range_m)
    }

    /// End point of beam `beam` in the sensor frame (metres), if it is a return.
    pub fn point_in_sensor(&self, beam: usize) -> Option<[f64; 2]> {
        let range_m = self.range_m(beam)?;
        let (sin, cos) = self.beam_angle_rad(beam).sin_cos();
        Some([range_m * cos, range_m * sin])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn test_returns_and_no_returns() {
        let scan = RangeScan::new(
            vec![1.0, 0.0, -2.0, 8.0, 9.0, f64::NAN, f64::INFINITY, 2.0],
            -FRAC_PI_2,
            FRAC_PI_2,
            8.0,
        );
        assert_eq!(scan.len(), 8);
        assert_eq!(scan.range_m(0), Some(1.0));
        for beam in 1..7 {
            assert_eq!(scan.range_m(beam), None, "beam {beam}");
        }
        assert_eq!(scan.range_m(7), Some(2.0));
        assert_eq!(scan.range_m(8), None);
        let [x, y] = scan.point_in_sensor(0).unwrap_or([9.9, 9.9]);
        assert!(x.abs() < 1e-12 && (y + 1.0).abs() < 1e-12);
    }

    #[test]
    fn test_non_finite_geometry_has_no_returns() {
        let scan = RangeScan::new(vec![1.0, 2.0], f64::NAN, 0.01, 10.0);
        assert_eq!(scan.point_in_sensor(0), None);
        let scan = RangeScan::new(vec![1.0, 2.0], 0.0, 0.01, f64::NAN);
        assert_eq!(scan.range_m(1), None);
    }

    #[test]
    fn test_from_f32() {
        let scan = RangeScan::from_f32(&[1.5, f32::NAN], 0.0, 0.1, 4.0);
        assert_eq!(scan.range_m(0), Some(1.5));
        assert_eq!(scan.range_m(1), None);
    }
}
