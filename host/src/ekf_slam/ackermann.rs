//! Odometry-driven motion of a car-like (Ackermann) vehicle: the speed measured at a rear
//! wheel and the steering angle, as on the Victoria Park vehicle (Guivant and Nebot 2001).
//!
//! The robot frame is the centre of the rear axle, `x` forward. With wheelbase `L` and the
//! speed measured on a rear wheel `H` to the left of the axle centre, the axle-centre speed
//! is `v = v_wheel / (1 − tan(α) · H / L)` and the turn rate `ω = v · tan(α) / L`.
//!
//! With online calibration the robot block grows two entries: a speed scale `k` (true speed
//! = `k` × measured) and a steering offset `δ` (true steering = measured + `δ`), each a slow
//! random walk, so wheel-radius and steering-alignment errors are estimated from the
//! landmarks instead of bending the map.

use nalgebra::{DMatrix, DVector};

use super::motion_model::{MotionModel, MotionPrediction, midpoint_step};
use crate::geometry::Pose2;

/// Rear-wheel speed and steering angle over one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AckermannInput {
    /// Speed measured at the encoder wheel, metres per second.
    pub wheel_speed_mps: f64,
    /// Steering angle, radians, positive to the left.
    pub steer_rad: f64,
}

/// The car's dimensions that the motion model uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AckermannGeometry {
    /// Wheelbase `L`, metres.
    pub wheelbase_m: f64,
    /// Offset `H` of the encoder wheel to the left of the rear-axle centre, metres.
    pub encoder_offset_m: f64,
}

/// Odometry noise and calibration settings of the car model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AckermannModel {
    /// The car's dimensions.
    pub geometry: AckermannGeometry,
    /// Standard deviation of the measured wheel speed, metres per second.
    pub sigma_speed_mps: f64,
    /// Standard deviation of the measured steering angle, radians.
    pub sigma_steer_rad: f64,
    /// Estimate speed scale and steering offset online.
    pub calibrate: bool,
    /// Prior standard deviation of the speed scale (dimensionless).
    pub sigma_scale: f64,
    /// Prior standard deviation of the steering offset, radians.
    pub sigma_steer_offset_rad: f64,
    /// Random-walk density of the speed scale, per √s.
    pub scale_walk_per_sqrt_s: f64,
    /// Random-walk density of the steering offset, radians per √s.
    pub steer_offset_walk_rad_per_sqrt_s: f64,
}

impl AckermannModel {
    /// A model with the given geometry and default noise, calibrating online.
    pub fn new(geometry: AckermannGeometry) -> AckermannModel {
        AckermannModel {
            geometry,
            sigma_speed_mps: 0.1,
            sigma_steer_rad: 1.5f64.to_radians(),
            calibrate: true,
            sigma_scale: 0.05,
            sigma_steer_offset_rad: 2f64.to_radians(),
            scale_walk_per_sqrt_s: 1e-4,
            steer_offset_walk_rad_per_sqrt_s: 1e-4,
        }
    }

    /// Axle-centre speed and turn rate for measured `wheel_speed_mps` with scale `k` and
    /// true steering `steer_rad`, with their derivatives with respect to the wheel speed and
    /// the steering: `(v, ω, dv/dwheel, dω/dwheel, dv/dsteer, dω/dsteer)`.
    fn kinematics(&self, wheel_speed_mps: f64, scale: f64, steer_rad: f64) -> [f64; 6] {
        let l = self.geometry.wheelbase_m;
        let c = self.geometry.encoder_offset_m / l;
        let tan = steer_rad.tan();
        let sec2 = 1.0 + tan * tan;
        let denominator = 1.0 - tan * c;
        let dv_dwheel = scale / denominator;
        let v = wheel_speed_mps * dv_dwheel;
        let omega = v * tan / l;
        let dv_dsteer = v * c * sec2 / denominator;
        let domega_dsteer = dv_dsteer * tan / l + v * sec2 / l;
        let domega_dwheel = dv_dwheel * tan / l;
        [v, omega, dv_dwheel, domega_dwheel, dv_dsteer, domega_dsteer]
    }
}

impl MotionModel for AckermannModel {
    type Input = AckermannInput;

    fn robot_dim(&self) -> usize {
        if self.calibrate { 5 } else { 3 }
    }

    fn initial_robot(&self, pose: Pose2) -> (DVector<f64>, DMatrix<f64>) {
        let dim = self.robot_dim();
        let mut mean = DVector::zeros(dim);
        mean.rows_mut(0, 3)
            .copy_from_slice(&[pose.x_m, pose.y_m, pose.theta_rad]);
        let mut covariance = DMatrix::zeros(dim, dim);
        if self.calibrate {
            mean[3] = 1.0;
            covariance[(3, 3)] = self.sigma_scale.powi(2);
            covariance[(4, 4)] = self.sigma_steer_offset_rad.powi(2);
        }
        (mean, covariance)
    }

    fn predict(&self, robot: &DVector<f64>, input: &AckermannInput, dt_s: f64) -> MotionPrediction {
        let dim = self.robot_dim();
        let (scale, offset) = if self.calibrate {
            (robot[3], robot[4])
        } else {
            (1.0, 0.0)
        };
        let [v, omega, dv_dwheel, domega_dwheel, dv_dsteer, domega_dsteer] =
            self.kinematics(input.wheel_speed_mps, scale, input.steer_rad + offset);
        let pose = Pose2 {
            x_m: robot[0],
            y_m: robot[1],
            theta_rad: robot[2],
        };
        let (next, d) = midpoint_step(pose, v, omega, dt_s);
        // Derivative of the new pose (row) through speed and turn rate.
        let through = |row: usize, dv: f64, domega: f64| d[row][1] * dv + d[row][2] * domega;

        let mut f = DMatrix::identity(dim, dim);
        let mut g = DMatrix::zeros(dim, 2);
        for row in 0..3 {
            f[(row, 2)] = d[row][0];
            g[(row, 0)] = through(row, dv_dwheel, domega_dwheel);
            g[(row, 1)] = through(row, dv_dsteer, domega_dsteer);
            if self.calibrate {
                // v and ω are proportional to the scale.
                let dv_dscale = if scale.abs() > f64::EPSILON {
                    v / scale
                } else {
                    0.0
                };
                let domega_dscale = if scale.abs() > f64::EPSILON {
                    omega / scale
                } else {
                    0.0
                };
                f[(row, 3)] = through(row, dv_dscale, domega_dscale);
                f[(row, 4)] = through(row, dv_dsteer, domega_dsteer);
            }
        }
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![
            self.sigma_speed_mps.powi(2),
            self.sigma_steer_rad.powi(2),
        ]));
        let mut q = &g * noise * g.transpose();
        let mut next_robot = DVector::zeros(dim);
        next_robot
            .rows_mut(0, 3)
            .copy_from_slice(&[next.x_m, next.y_m, next.theta_rad]);
        if self.calibrate {
            next_robot[3] = scale;
            next_robot[4] = offset;
            q[(3, 3)] += self.scale_walk_per_sqrt_s.powi(2) * dt_s;
            q[(4, 4)] += self.steer_offset_walk_rad_per_sqrt_s.powi(2) * dt_s;
        }
        MotionPrediction {
            robot: next_robot,
            f,
            q,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> AckermannModel {
        AckermannModel::new(AckermannGeometry {
            wheelbase_m: 2.83,
            encoder_offset_m: 0.76,
        })
    }

    #[test]
    fn straight_drive_moves_forward() {
        let model = model();
        let (robot, _) = model.initial_robot(Pose2::IDENTITY);
        let input = AckermannInput {
            wheel_speed_mps: 2.0,
            steer_rad: 0.0,
        };
        let p = model.predict(&robot, &input, 0.5);
        assert!((p.robot[0] - 1.0).abs() < 1e-12 && p.robot[1].abs() < 1e-12);
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let model = model();
        let robot = DVector::from_vec(vec![1.0, 2.0, 0.4, 1.02, 0.01]);
        let input = AckermannInput {
            wheel_speed_mps: 3.0,
            steer_rad: 0.2,
        };
        let p = model.predict(&robot, &input, 0.1);
        let eps = 1e-7;
        for col in 0..5 {
            let mut plus = robot.clone();
            plus[col] += eps;
            let mut minus = robot.clone();
            minus[col] -= eps;
            let numeric = (model.predict(&plus, &input, 0.1).robot
                - model.predict(&minus, &input, 0.1).robot)
                / (2.0 * eps);
            for row in 0..5 {
                assert!(
                    (p.f[(row, col)] - numeric[row]).abs() < 1e-6,
                    "F[{row},{col}]"
                );
            }
        }
    }

    #[test]
    fn turning_left_increases_heading() {
        let model = model();
        let (robot, _) = model.initial_robot(Pose2::IDENTITY);
        let input = AckermannInput {
            wheel_speed_mps: 2.0,
            steer_rad: 0.1,
        };
        let p = model.predict(&robot, &input, 1.0);
        assert!(p.robot[2] > 0.0 && p.robot[1] > 0.0);
    }
}
