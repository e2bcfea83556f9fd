//! What the LMS2xx measures: one range per beam, cast into a [`World`] from the sensor's
//! pose, with Gaussian noise, coded as range words for the configured unit and measuring
//! mode (protocol notes §7.3).
//!
//! Beam directions follow the laser frame of [`super::lms_variant`]: a beam at laser angle
//! `a` (0°–180°) points at bearing `a − 90°` from the sensor's forward axis, counter-clockwise
//! positive, so 90° is straight ahead and 0° to the right.
//!
//! Coding: the noisy distance is rounded to the unit (mm or cm). No surface within
//! `max_range_m` gives the "no echo" code (all distance bits set: `1FFFh`, `3FFFh`, `7FFFh`,
//! `FFFFh`); a surface beyond what the distance bits can hold gives "measured value > maximum
//! value" (`…F7h`). Field, dazzle and reflector bits are left clear. In the energy mode `3Fh`
//! (and other modes without distances) a word is 200 for an echo and 0 without one.
//!
//! One normal sample is drawn per beam whether it hits or not, so the random sequence (and
//! with it every byte) depends only on the seed and the number of beams measured.

use protocol::RangeUnit;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use firmware::sick::MeasuringMode;

use super::lms_variant::Variant;
use crate::world::{SensorPose, World};

/// Default range noise (1 σ), metres: the LMS200's typical statistical error.
pub const DEFAULT_RANGE_SIGMA_M: f64 = 0.010;
/// Default maximum range, metres (LMS200 in the 80 m modes).
pub const DEFAULT_MAX_RANGE_M: f64 = 80.0;
/// Word of an echo in the energy mode.
const ENERGY_ECHO: u16 = 200;

/// The range measurement model. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct RangeModel<W> {
    /// The world measured.
    pub world: W,
    /// The sensor's pose in the world.
    pub pose: SensorPose,
    /// Range noise, 1 σ, metres.
    pub sigma_m: f64,
    /// Surfaces farther than this give no echo, metres.
    pub max_range_m: f64,
    rng: ChaCha8Rng,
}

impl<W: World> RangeModel<W> {
    /// A model of `world` seen from `pose`, with noise drawn from a generator seeded with
    /// `seed`.
    pub fn new(world: W, pose: SensorPose, sigma_m: f64, max_range_m: f64, seed: u64) -> Self {
        RangeModel {
            world,
            pose,
            sigma_m,
            max_range_m,
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// The noise-free distance seen by the beam at `beam_angle_cdeg` of the laser frame.
    pub fn true_range_m(&self, beam_angle_cdeg: u32) -> Option<f64> {
        let angle_rad = self.pose.world_angle_rad(beam_bearing_rad(beam_angle_cdeg));
        self.world
            .ray_cast(self.pose.position_m(), angle_rad, self.max_range_m)
    }

    /// One noisy measurement of the beam at `beam_angle_cdeg`, metres.
    pub fn measure_m(&mut self, beam_angle_cdeg: u32) -> Option<f64> {
        let z: f64 = StandardNormal.sample(&mut self.rng);
        self.true_range_m(beam_angle_cdeg)
            .map(|range_m| (range_m + z * self.sigma_m).max(0.0))
    }

    /// The range words of one complete scan of `variant`.
    pub fn scan_words(
        &mut self,
        variant: Variant,
        unit: RangeUnit,
        mode: MeasuringMode,
    ) -> Vec<u16> {
        (0..variant.values_per_scan())
            .map(|i| encode_range(self.measure_m(variant.beam_angle_cdeg(i)), unit, mode))
            .collect()
    }
}

/// Bearing from the sensor's forward axis (counter-clockwise) of the beam at laser angle
/// `beam_angle_cdeg`, radians.
pub fn beam_bearing_rad(beam_angle_cdeg: u32) -> f64 {
    (f64::from(beam_angle_cdeg) / 100.0 - 90.0).to_radians()
}

/// The range word for a distance (or no echo) in `unit` and `mode`.
pub fn encode_range(range_m: Option<f64>, unit: RangeUnit, mode: MeasuringMode) -> u16 {
    let Some(mask) = mode.distance_mask() else {
        return if range_m.is_some() { ENERGY_ECHO } else { 0 };
    };
    let Some(range_m) = range_m else {
        return mask;
    };
    let per_m = match unit {
        RangeUnit::Mm => 1_000.0,
        RangeUnit::Cm => 100.0,
    };
    // Codes from `mask - 8` up are reserved for "no valid measurement".
    let too_far = mask - 8;
    let value = (range_m * per_m).round();
    if value >= f64::from(too_far) {
        too_far
    } else {
        value as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Room;

    #[test]
    fn words_per_mode_and_unit() {
        let mm = RangeUnit::Mm;
        assert_eq!(encode_range(Some(1.2344), mm, MeasuringMode(0)), 1234);
        assert_eq!(
            encode_range(Some(1.2346), RangeUnit::Cm, MeasuringMode(0)),
            123
        );
        assert_eq!(encode_range(None, mm, MeasuringMode(0)), 0x1FFF);
        assert_eq!(encode_range(Some(9.0), mm, MeasuringMode(0)), 0x1FF7);
        assert_eq!(encode_range(Some(9.0), mm, MeasuringMode(4)), 9000);
        assert_eq!(encode_range(None, mm, MeasuringMode(4)), 0x3FFF);
        assert_eq!(encode_range(None, mm, MeasuringMode(6)), 0x7FFF);
        assert_eq!(encode_range(None, mm, MeasuringMode(0x0F)), 0xFFFF);
        assert_eq!(encode_range(Some(3.0), mm, MeasuringMode(0x3F)), 200);
    }

    #[test]
    fn beams_in_the_laser_frame() {
        // Facing north from (6, 3) in the default room: right = east wall, ahead = north
        // wall, left = west wall.
        let model = RangeModel::new(Room::default(), SensorPose::default(), 0.0, 80.0, 1);
        let right = model.true_range_m(0).unwrap();
        let ahead = model.true_range_m(9_000).unwrap();
        let left = model.true_range_m(18_000).unwrap();
        assert!((right - 6.0).abs() < 1e-9);
        assert!((ahead - 5.0).abs() < 1e-9);
        assert!((left - 6.0).abs() < 1e-9);
    }

    #[test]
    fn noise_is_seeded() {
        let scan = |seed| {
            let mut model =
                RangeModel::new(Room::default(), SensorPose::default(), 0.01, 80.0, seed);
            model.scan_words(Variant::new(180, 50), RangeUnit::Mm, MeasuringMode(0))
        };
        assert_eq!(scan(7), scan(7));
        assert_ne!(scan(7), scan(8));
        let words = scan(7);
        assert_eq!(words.len(), 361);
        assert!((i32::from(words[180]) - 5_000).abs() < 60);
    }
}
