//! The LMS2xx scan variant: field of view and angular resolution (protocol notes §6.2, §7.4,
//! §9), and the timing that follows from the 75 Hz mirror.
//!
//! Laser frame: value `i` of a scan lies at `start + i · resolution`, with start 0° for the
//! 180° field and 40° for the 100° field; 0° points to the sensor's right, 90° straight ahead
//! (the sensor's forward axis), 180° to its left: the scan runs counter-clockwise seen from
//! above.

/// Mirror rotation period: 1/75 s = 40 000/3 µs, kept as a fraction to avoid drift.
pub const ROTATION_US_NUMERATOR: u64 = 40_000;
/// Denominator of the mirror rotation period.
pub const ROTATION_US_DENOMINATOR: u64 = 3;

/// A field of view and angular resolution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Variant {
    /// Field of view: 100 or 180 degrees.
    pub angle_deg: u16,
    /// Angular resolution in hundredths of a degree: 25, 50 or 100.
    pub resolution_cdeg: u16,
}

impl Variant {
    /// 180° at 1°, the factory setting.
    pub const DEFAULT: Variant = Variant::new(180, 100);

    /// A variant (not checked; see [`Self::is_supported`]).
    pub const fn new(angle_deg: u16, resolution_cdeg: u16) -> Variant {
        Variant {
            angle_deg,
            resolution_cdeg,
        }
    }

    /// Whether an LMS200 accepts it: 180° at 1° or 0.5°, 100° at 1°, 0.5° or 0.25°.
    pub const fn is_supported(&self) -> bool {
        matches!(
            (self.angle_deg, self.resolution_cdeg),
            (180, 100) | (180, 50) | (100, 100) | (100, 50) | (100, 25)
        )
    }

    /// Values in a complete scan (181, 361, 101, 201 or 401).
    pub const fn values_per_scan(&self) -> u16 {
        if self.resolution_cdeg == 0 {
            return 0;
        }
        self.angle_deg * 100 / self.resolution_cdeg + 1
    }

    /// Angle of the first value, hundredths of a degree (0 or 4 000).
    pub const fn start_angle_cdeg(&self) -> u32 {
        (180 - if self.angle_deg > 180 {
            180
        } else {
            self.angle_deg
        }) as u32
            * 50
    }

    /// Angle of value `index` in the laser frame, hundredths of a degree.
    pub const fn beam_angle_cdeg(&self, index: u16) -> u32 {
        self.start_angle_cdeg() + index as u32 * self.resolution_cdeg as u32
    }

    /// Mirror rotations a complete scan takes: 1 (1°), 2 (0.5°) or 4 (0.25°).
    pub const fn rotations_per_scan(&self) -> u64 {
        match self.resolution_cdeg {
            25 => 4,
            50 => 2,
            _ => 1,
        }
    }

    /// Complete scans per second: 75, 37.5 or 18.75.
    pub fn scans_per_second(&self) -> f64 {
        75.0 / self.rotations_per_scan() as f64
    }
}

impl Default for Variant {
    fn default() -> Self {
        Variant::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry() {
        let v = Variant::new(180, 50);
        assert_eq!(v.values_per_scan(), 361);
        assert_eq!(v.beam_angle_cdeg(180), 9_000);
        assert_eq!(v.rotations_per_scan(), 2);
        let v = Variant::new(100, 25);
        assert_eq!((v.values_per_scan(), v.start_angle_cdeg()), (401, 4_000));
        assert_eq!(v.beam_angle_cdeg(400), 14_000);
        assert!(!Variant::new(180, 25).is_supported());
        assert!(Variant::DEFAULT.is_supported());
    }
}
