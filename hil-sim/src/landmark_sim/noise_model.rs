//! How noisy the simulated odometry and landmark observations are, and when the laser fires.
//!
//! All noise is zero-mean Gaussian and white: independent between draws, between steps and
//! between the two odometry channels and the two observation channels. The standard
//! deviations below are exactly those [`super::simulate()`] draws with, so a filter that uses
//! the same values models the data correctly.

use core::f64::consts::PI;

use host::ekf_slam::{DifferentialDriveModel, RangeBearingModel};
use host::geometry::Pose2;
use serde::{Deserialize, Serialize};

/// Noise and timing of a simulated landmark run. Every field has a working default
/// ([`NoiseModel::default`]); [`NoiseModel::noiseless`] keeps the timing and geometry and
/// zeroes every noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NoiseModel {
    /// Constant part of the standard deviation of the odometry speed, metres per second.
    /// Default 0.05 m/s.
    pub speed_sigma_mps: f64,
    /// Part of the standard deviation of the odometry speed proportional to the true speed's
    /// magnitude (dimensionless: metres per second of σ per metre per second of speed).
    /// Default 0.02.
    pub speed_sigma_per_speed: f64,
    /// Constant part of the standard deviation of the odometry yaw rate, radians per second.
    /// Default 0.5 °/s.
    pub yaw_rate_sigma_radps: f64,
    /// Part of the standard deviation of the odometry yaw rate proportional to the true yaw
    /// rate's magnitude (dimensionless). Default 0.02.
    pub yaw_rate_sigma_per_yaw_rate: f64,
    /// Standard deviation of the range to a landmark's centre, metres. Default 0.05 m.
    pub range_sigma_m: f64,
    /// Standard deviation of the bearing to a landmark's centre, radians. Default 0.5°.
    pub bearing_sigma_rad: f64,
    /// Time between laser scans, which is also the odometry interval, seconds.
    /// Default 0.2 s.
    pub laser_period_s: f64,
    /// Largest distance from the laser to a landmark's centre that is observed, metres.
    /// Default 30 m.
    pub max_range_m: f64,
    /// Full opening angle of the laser, centred on the robot's forward axis, radians; a
    /// landmark is observed when its centre's true bearing lies within half of it either
    /// side. Default π (180°).
    pub field_of_view_rad: f64,
}

impl Default for NoiseModel {
    fn default() -> Self {
        NoiseModel {
            speed_sigma_mps: 0.05,
            speed_sigma_per_speed: 0.02,
            yaw_rate_sigma_radps: 0.5_f64.to_radians(),
            yaw_rate_sigma_per_yaw_rate: 0.02,
            range_sigma_m: 0.05,
            bearing_sigma_rad: 0.5_f64.to_radians(),
            laser_period_s: 0.2,
            max_range_m: 30.0,
            field_of_view_rad: PI,
        }
    }
}

impl NoiseModel {
    /// The default timing and geometry with every standard deviation zero.
    pub fn noiseless() -> NoiseModel {
        NoiseModel {
            speed_sigma_mps: 0.0,
            speed_sigma_per_speed: 0.0,
            yaw_rate_sigma_radps: 0.0,
            yaw_rate_sigma_per_yaw_rate: 0.0,
            range_sigma_m: 0.0,
            bearing_sigma_rad: 0.0,
            ..NoiseModel::default()
        }
    }

    /// Standard deviation of the odometry speed when the robot moves at `speed_mps`:
    /// `speed_sigma_mps + speed_sigma_per_speed · |speed_mps|`, metres per second.
    ///
    /// The simulator evaluates it at the true speed; a filter only knows the measured one,
    /// which changes the result by `speed_sigma_per_speed` times the speed error (a few
    /// millimetres per second with the defaults).
    pub fn speed_sigma_at_mps(&self, speed_mps: f64) -> f64 {
        self.speed_sigma_mps + self.speed_sigma_per_speed * speed_mps.abs()
    }

    /// Standard deviation of the odometry yaw rate when the robot turns at `yaw_rate_radps`:
    /// `yaw_rate_sigma_radps + yaw_rate_sigma_per_yaw_rate · |yaw_rate_radps|`, radians per
    /// second (evaluated at the true yaw rate, as [`Self::speed_sigma_at_mps`]).
    pub fn yaw_rate_sigma_at_radps(&self, yaw_rate_radps: f64) -> f64 {
        self.yaw_rate_sigma_radps + self.yaw_rate_sigma_per_yaw_rate * yaw_rate_radps.abs()
    }

    /// The differential-drive model a filter predicts with on this noise: the same speed and
    /// yaw-rate standard deviations, and the model's own small sideways slip.
    pub fn motion_model(&self) -> DifferentialDriveModel {
        DifferentialDriveModel {
            sigma_speed_mps: self.speed_sigma_mps,
            sigma_yaw_rate_radps: self.yaw_rate_sigma_radps,
            sigma_speed_per_speed: self.speed_sigma_per_speed,
            sigma_yaw_rate_per_yaw_rate: self.yaw_rate_sigma_per_yaw_rate,
            ..DifferentialDriveModel::default()
        }
    }

    /// The range-bearing model a filter observes with on this noise: the laser at the robot
    /// origin, the same standard deviations.
    pub fn sensor_model(&self) -> RangeBearingModel {
        RangeBearingModel {
            sensor_in_robot: Pose2::IDENTITY,
            sigma_range_m: self.range_sigma_m,
            sigma_bearing_rad: self.bearing_sigma_rad,
        }
    }

    /// Checks that every standard deviation is finite and not negative, the laser period and
    /// maximum range are finite and positive, and the field of view lies in `(0, 2π]`.
    ///
    /// # Errors
    ///
    /// [`NoiseModelError`] naming the first field that breaks its rule.
    pub fn validate(&self) -> Result<(), NoiseModelError> {
        let sigmas = [
            ("speed_sigma_mps", self.speed_sigma_mps),
            ("speed_sigma_per_speed", self.speed_sigma_per_speed),
            ("yaw_rate_sigma_radps", self.yaw_rate_sigma_radps),
            (
                "yaw_rate_sigma_per_yaw_rate",
                self.yaw_rate_sigma_per_yaw_rate,
            ),
            ("range_sigma_m", self.range_sigma_m),
            ("bearing_sigma_rad", self.bearing_sigma_rad),
        ];
        for (field, value) in sigmas {
            if !(value.is_finite() && value >= 0.0) {
                return Err(NoiseModelError::NegativeSigma { field, value });
            }
        }
        let positive = [
            ("laser_period_s", self.laser_period_s),
            ("max_range_m", self.max_range_m),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(NoiseModelError::NotPositive { field, value });
            }
        }
        if !(self.field_of_view_rad > 0.0 && self.field_of_view_rad <= 2.0 * PI) {
            return Err(NoiseModelError::FieldOfView {
                value: self.field_of_view_rad,
            });
        }
        Ok(())
    }
}

/// A [`NoiseModel`] field outside its range.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum NoiseModelError {
    /// A standard deviation is negative or not finite.
    #[error("{field} must be a finite standard deviation of at least 0, got {value}")]
    NegativeSigma {
        /// The field's name.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// The laser period or the maximum range is not a positive finite number.
    #[error("{field} must be finite and positive, got {value}")]
    NotPositive {
        /// The field's name.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// The field of view is not in `(0, 2π]`.
    #[error("field_of_view_rad must lie in (0, 2π], got {value}")]
    FieldOfView {
        /// Its value.
        value: f64,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_documented_values() {
        let model = NoiseModel::default();
        assert_eq!(model.validate(), Ok(()));
        assert_eq!(NoiseModel::noiseless().validate(), Ok(()));
        assert!((model.speed_sigma_at_mps(2.0) - 0.09).abs() < 1e-12);
        assert!((model.speed_sigma_at_mps(-2.0) - 0.09).abs() < 1e-12);
        let expected_radps = 0.5_f64.to_radians() + 0.02 * 0.8;
        assert!((model.yaw_rate_sigma_at_radps(-0.8) - expected_radps).abs() < 1e-12);
        assert_eq!(model.field_of_view_rad, PI);
        assert_eq!(NoiseModel::noiseless().speed_sigma_at_mps(5.0), 0.0);
    }

    #[test]
    fn rejects_bad_fields() {
        let bad = NoiseModel {
            bearing_sigma_rad: -0.1,
            ..NoiseModel::default()
        };
        assert_eq!(
            bad.validate(),
            Err(NoiseModelError::NegativeSigma {
                field: "bearing_sigma_rad",
                value: -0.1
            })
        );
        let bad = NoiseModel {
            range_sigma_m: f64::NAN,
            ..NoiseModel::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(NoiseModelError::NegativeSigma {
                field: "range_sigma_m",
                ..
            })
        ));
        let bad = NoiseModel {
            laser_period_s: 0.0,
            ..NoiseModel::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(NoiseModelError::NotPositive {
                field: "laser_period_s",
                ..
            })
        ));
        let bad = NoiseModel {
            field_of_view_rad: 7.0,
            ..NoiseModel::default()
        };
        assert!(bad.validate().is_err());
        assert_eq!(
            bad.validate().map_err(|e| e.to_string()),
            Err("field_of_view_rad must lie in (0, 2π], got 7".to_owned())
        );
    }

    #[test]
    fn missing_fields_take_defaults() {
        let model: NoiseModel = serde_json::from_str(r#"{"range_sigma_m": 0.1}"#).unwrap();
        assert_eq!(
            model,
            NoiseModel {
                range_sigma_m: 0.1,
                ..NoiseModel::default()
            }
        );
    }
}
