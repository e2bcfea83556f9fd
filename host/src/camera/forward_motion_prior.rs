//! A camera that looks forward from a ground vehicle moves along its optical axis.
//!
//! A single camera measures its motion only through the features, and with features on one
//! side of the road (a wall, parked cars, a row of trees) the images of a camera driving
//! straight on and of one sliding sideways while it turns are close: the filter can explain
//! the forward motion as sideways velocity and a yaw, and its heading runs away (tens of
//! degrees in seconds, while every feature keeps matching). A wheeled vehicle cannot slide
//! sideways or move up off the ground: the velocity of a camera looking forward from it
//! points along the optical axis, up to the sideslip of a turn (the camera ahead of the axle
//! the vehicle turns about) and the pitch of the ground. The filter is told so each frame
//! ([`super::MonoEkf::update_forward_motion`]), as a vehicle's odometry would tell it.
//!
//! The prior is on the direction of the velocity, not its size, so it holds whatever scale a
//! single camera's map has. A hand-held camera, or one looking sideways, has no such prior.

/// How closely the camera's motion follows its optical axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForwardMotionPrior {
    /// Standard deviation of the angle between the camera's velocity and its optical axis,
    /// sideways and up or down, rad.
    pub sideslip_sigma_rad: f64,
}

impl Default for ForwardMotionPrior {
    /// [`Self::DEFAULT_SIDESLIP_DEG`].
    fn default() -> Self {
        ForwardMotionPrior {
            sideslip_sigma_rad: Self::DEFAULT_SIDESLIP_DEG.to_radians(),
        }
    }
}

impl ForwardMotionPrior {
    /// The default standard deviation of the sideslip, degrees: a car's camera a metre or two
    /// ahead of its rear axle on a turn of 20–30 m radius, or a robot turning as it drives.
    pub const DEFAULT_SIDESLIP_DEG: f64 = 3.0;

    /// The prior of a camera whose velocity leaves its optical axis by `sideslip_deg`
    /// degrees (standard deviation); `None` for 0, a camera that may move in any direction.
    ///
    /// # Errors
    /// A sideslip that is negative, not a number, or 90° or more.
    pub fn from_sideslip_deg(sideslip_deg: f64) -> Result<Option<Self>, String> {
        if !(sideslip_deg.is_finite() && (0.0..90.0).contains(&sideslip_deg)) {
            return Err(format!(
                "the sideslip must be 0 (any direction) or more degrees, below 90, not \
                 {sideslip_deg}"
            ));
        }
        Ok((sideslip_deg > 0.0).then(|| ForwardMotionPrior {
            sideslip_sigma_rad: sideslip_deg.to_radians(),
        }))
    }

    /// The sideslip of `prior` in degrees, as [`Self::from_sideslip_deg`] takes it (0: none).
    pub fn sideslip_deg(prior: Option<Self>) -> f64 {
        prior.map_or(0.0, |prior| prior.sideslip_sigma_rad.to_degrees())
    }

    /// The standard deviation of the camera's sideways and vertical velocity, for a camera
    /// moving at `speed` (in the map's units a second).
    pub fn sigma_of_speed(&self, speed: f64) -> f64 {
        self.sideslip_sigma_rad.tan() * speed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sideslip_in_degrees_round_trips_and_zero_is_no_prior() {
        let prior = ForwardMotionPrior::from_sideslip_deg(4.0).unwrap();
        assert!((ForwardMotionPrior::sideslip_deg(prior) - 4.0).abs() < 1e-12);
        assert_eq!(ForwardMotionPrior::from_sideslip_deg(0.0), Ok(None));
        assert_eq!(ForwardMotionPrior::sideslip_deg(None), 0.0);
        for bad in [-1.0, 90.0, f64::NAN, f64::INFINITY] {
            assert!(ForwardMotionPrior::from_sideslip_deg(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_sideways_sigma_scales_with_the_speed() {
        let prior = ForwardMotionPrior {
            sideslip_sigma_rad: 45f64.to_radians(),
        };
        assert!((prior.sigma_of_speed(2.0) - 2.0).abs() < 1e-12);
        assert_eq!(prior.sigma_of_speed(0.0), 0.0);
    }
}
