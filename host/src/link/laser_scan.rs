//! A scan message from the board in SI units: the range words decoded to metres and the
//! sensor's 0°–180° angles turned into the sensor frame (`x` forward, `y` left).
//!
//! The board forwards the LMS2xx's range words untouched; this is the one place on the host
//! where they become metres.

use protocol::{MeasuringMode, RangeDecoder, ScanMsg};

use crate::landmarks::RangeScan;
use crate::scan_match::Scan;

/// One scan in metres and radians, in the sensor frame.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScan {
    /// Range of each beam, metres; NaN for a beam without a return.
    pub ranges_m: Vec<f64>,
    /// Angle of the first beam, radians, counter-clockwise from straight ahead.
    pub first_angle_rad: f64,
    /// Angle between two beams, radians.
    pub angle_step_rad: f64,
}

impl LaserScan {
    /// Decodes `msg`'s range words as coded in measuring `mode` (the board configures the
    /// factory default, [`MeasuringMode::DEFAULT`]); a mode without distances decodes with the
    /// 13-bit mask.
    pub fn from_msg(msg: &ScanMsg, mode: MeasuringMode) -> LaserScan {
        let decoder =
            RangeDecoder::new(mode, msg.unit).unwrap_or(RangeDecoder::with_mask(0x1FFF, msg.unit));
        let ranges_m = msg
            .values
            .iter()
            .map(|&word| {
                decoder
                    .range_mm(word)
                    .map_or(f64::NAN, |mm| f64::from(mm) * 1e-3)
            })
            .collect();
        LaserScan {
            ranges_m,
            // The sensor counts 0°–180° from its right with 90° straight ahead.
            first_angle_rad: (f64::from(msg.start_angle_cdeg) * 0.01 - 90.0).to_radians(),
            angle_step_rad: (f64::from(msg.step_angle_cdeg) * 0.01).to_radians(),
        }
    }

    /// The beam end points for the scan matcher, ignoring ranges above `max_range_m`.
    pub fn to_scan(&self, max_range_m: f64) -> Scan {
        Scan::from_ranges(
            &self.ranges_m,
            self.first_angle_rad,
            self.angle_step_rad,
            max_range_m,
        )
    }

    /// The ranges with their beam geometry for the landmark front end.
    pub fn to_range_scan(&self, max_range_m: f64) -> RangeScan {
        RangeScan::new(
            self.ranges_m.clone(),
            self.first_angle_rad,
            self.angle_step_rad,
            max_range_m,
        )
    }
}

#[cfg(test)]
mod tests {
    use protocol::RangeUnit;

    use super::*;

    fn message(values: &[u16], unit: RangeUnit, start_angle_cdeg: u16) -> ScanMsg {
        ScanMsg {
            stamp_us: 0,
            scan_counter: 0,
            start_angle_cdeg,
            step_angle_cdeg: 50,
            unit,
            count_word: values.len() as u16,
            values: values.iter().copied().collect(),
            status: 0,
            sensor_indices: None,
        }
    }

    #[test]
    fn words_become_metres_and_no_echo_nan() {
        let scan = LaserScan::from_msg(
            &message(&[1500, 0x1FFF, 0x2000 | 250], RangeUnit::Cm, 0),
            MeasuringMode::DEFAULT,
        );
        assert_eq!(scan.ranges_m[0], 15.0);
        assert!(scan.ranges_m[1].is_nan());
        // Flag bits above the distance mask are not part of the range.
        assert_eq!(scan.ranges_m[2], 2.5);
    }

    #[test]
    fn angles_are_in_the_sensor_frame() {
        let wide = LaserScan::from_msg(
            &message(&[1000; 3], RangeUnit::Mm, 0),
            MeasuringMode::DEFAULT,
        );
        assert!((wide.first_angle_rad + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((wide.angle_step_rad - 0.5f64.to_radians()).abs() < 1e-12);
        let narrow = LaserScan::from_msg(
            &message(&[1000; 3], RangeUnit::Mm, 4000),
            MeasuringMode::DEFAULT,
        );
        assert!((narrow.first_angle_rad + 50f64.to_radians()).abs() < 1e-12);
    }
}
