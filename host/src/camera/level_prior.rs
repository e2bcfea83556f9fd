//! A camera mounted level on a ground robot: its roll and pitch stay within the ground's
//! slope, whatever the images say.
//!
//! One camera observes its tilt only through the features, and a filter that drifts in tilt
//! while it keeps tracking (a few degrees a second once it starts) tilts its whole path out
//! of the ground plane. On a ground robot the camera's mounting and the ground bound the tilt,
//! as an inertial unit's gravity would: the filter is told each frame that the camera's x
//! (right) and z (forward) axes are horizontal ([`super::MonoEkf::update_level`]).
//!
//! The robot's tilt is one slope for as long as it drives over it, not a fresh draw each
//! frame, so the frames within [`LevelPrior::correlation_s`] together carry what one
//! measurement of [`LevelPrior::tilt_sigma_rad`] carries: each frame's is `√(T / dt)` times
//! wider. A hand-held camera, or a sequence from an unknown rig, has no such prior.

use nalgebra::{UnitQuaternion, Vector3};

/// The level frame of a camera oriented `world_from_camera` in a world whose y axis is down:
/// turned from the world by the camera's heading (the direction of its optical axis) about
/// the vertical only, so that its y axis stays down. A local map of a camera held level
/// starts in this frame.
pub fn level_frame(world_from_camera: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let forward = world_from_camera * Vector3::z();
    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), forward.x.atan2(forward.z))
}

/// How level the camera is held.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelPrior {
    /// Standard deviation of the camera's roll and pitch from level, rad: the slope of the
    /// ground and the robot rocking on it.
    pub tilt_sigma_rad: f64,
    /// The time over which the tilt changes (a slope driven onto and off), s.
    pub correlation_s: f64,
}

impl Default for LevelPrior {
    /// [`Self::DEFAULT_TILT_DEG`] over 2 s: paved and grassy ground of a campus at walking
    /// speed.
    fn default() -> Self {
        LevelPrior {
            tilt_sigma_rad: Self::DEFAULT_TILT_DEG.to_radians(),
            correlation_s: 2.0,
        }
    }
}

impl LevelPrior {
    /// The default standard deviation of the tilt, degrees.
    pub const DEFAULT_TILT_DEG: f64 = 3.0;

    /// The prior of a camera whose tilt has a standard deviation of `tilt_deg` degrees, over
    /// the default correlation time; `None` for 0, a camera not held level.
    ///
    /// # Errors
    /// A tilt that is negative or not a number.
    pub fn from_tilt_deg(tilt_deg: f64) -> Result<Option<Self>, String> {
        if !(tilt_deg.is_finite() && tilt_deg >= 0.0) {
            return Err(format!(
                "the tilt must be 0 (not held level) or more degrees, not {tilt_deg}"
            ));
        }
        Ok((tilt_deg > 0.0).then(|| LevelPrior {
            tilt_sigma_rad: tilt_deg.to_radians(),
            ..LevelPrior::default()
        }))
    }

    /// The tilt of `level` in degrees, as [`Self::from_tilt_deg`] takes it (0: not held level).
    pub fn tilt_deg(level: Option<Self>) -> f64 {
        level.map_or(0.0, |level| level.tilt_sigma_rad.to_degrees())
    }

    /// The standard deviation of one frame's tilt measurement, rad, `dt_s` after the frame
    /// before: over the correlation time, the frames' information adds up to one
    /// measurement of [`Self::tilt_sigma_rad`] (never narrower than that one).
    pub fn sigma_per_frame_rad(&self, dt_s: f64) -> f64 {
        let frames = if dt_s > 0.0 {
            (self.correlation_s / dt_s).max(1.0)
        } else {
            1.0
        };
        self.tilt_sigma_rad * frames.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_frame_keeps_the_heading_and_drops_the_tilt() {
        let heading = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -2.0);
        let tilted = heading
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.1)
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -0.05);
        let frame = level_frame(tilted);
        assert!(frame.angle_to(&heading) < 1e-12);
        assert!(((frame * Vector3::y()) - Vector3::y()).norm() < 1e-12);
    }

    #[test]
    fn a_tilt_in_degrees_round_trips_and_zero_is_not_held_level() {
        let level = LevelPrior::from_tilt_deg(2.5).unwrap();
        assert!((LevelPrior::tilt_deg(level) - 2.5).abs() < 1e-12);
        assert_eq!(LevelPrior::from_tilt_deg(0.0), Ok(None));
        assert_eq!(LevelPrior::tilt_deg(None), 0.0);
        assert!(LevelPrior::from_tilt_deg(-1.0).is_err());
        assert!(LevelPrior::from_tilt_deg(f64::NAN).is_err());
    }

    #[test]
    fn the_frames_within_the_correlation_time_carry_one_measurement() {
        let prior = LevelPrior {
            tilt_sigma_rad: 0.05,
            correlation_s: 2.0,
        };
        let sigma = prior.sigma_per_frame_rad(0.1);
        let information_over_2_s = 20.0 / (sigma * sigma);
        assert!((information_over_2_s - 1.0 / (0.05 * 0.05)).abs() < 1e-6);
        // Frames further apart than the correlation time are each one measurement.
        assert_eq!(prior.sigma_per_frame_rad(5.0), 0.05);
        assert_eq!(prior.sigma_per_frame_rad(0.0), 0.05);
    }
}
