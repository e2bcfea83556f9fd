//! Range-bearing observations of point landmarks by a sensor mounted on the robot.
//!
//! The sensor sits at the pose `sensor_in_robot`. For a robot pose `p` and a
//! landmark `l` (both in the filter's frame) with sensor pose `s = p ⊕ sensor_in_robot`:
//! `range = |l − s_xy|`, `bearing = atan2(l_y − s_y, l_x − s_x) − s_θ` (wrapped into
//! `(−π, π]`, counter-clockwise from the sensor's forward axis).

use nalgebra::{Matrix2, Matrix2x3, Vector2};

use super::frames::{compose_pose, transform_point};
use crate::geometry::{Pose2, wrap_angle_rad};

/// One landmark seen in a scan, in the sensor frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkObservation {
    /// Distance from the sensor to the landmark's centre, metres.
    pub range_m: f64,
    /// Direction of the landmark's centre, radians counter-clockwise from the sensor's
    /// forward axis.
    pub bearing_rad: f64,
    /// Diameter of the landmark (a trunk), metres, when the front end measured it.
    pub diameter_m: Option<f64>,
}

/// The expected observation of a landmark and its Jacobians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictedObservation {
    /// Expected `[range_m, bearing_rad]`.
    pub z: Vector2<f64>,
    /// Jacobian with respect to the robot pose.
    pub d_pose: Matrix2x3<f64>,
    /// Jacobian with respect to the landmark position.
    pub d_landmark: Matrix2<f64>,
}

/// A range-bearing sensor and its noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeBearingModel {
    /// The sensor's pose on the robot.
    pub sensor_in_robot: Pose2,
    /// Standard deviation of a range, metres.
    pub sigma_range_m: f64,
    /// Standard deviation of a bearing, radians.
    pub sigma_bearing_rad: f64,
}

impl Default for RangeBearingModel {
    /// A sensor at the robot origin, 0.1 m and 1°.
    fn default() -> Self {
        RangeBearingModel {
            sensor_in_robot: Pose2::IDENTITY,
            sigma_range_m: 0.1,
            sigma_bearing_rad: 1f64.to_radians(),
        }
    }
}

impl RangeBearingModel {
    /// The measurement noise covariance.
    pub fn noise(&self) -> Matrix2<f64> {
        Matrix2::new(
            self.sigma_range_m.powi(2),
            0.0,
            0.0,
            self.sigma_bearing_rad.powi(2),
        )
    }

    /// The expected observation of `landmark` from `pose`, or `None` when the landmark lies
    /// on the sensor (no defined bearing).
    pub fn predict(&self, pose: Pose2, landmark: [f64; 2]) -> Option<PredictedObservation> {
        let (sensor, d_sensor_d_pose, _) = compose_pose(pose, self.sensor_in_robot);
        let dx = landmark[0] - sensor.x_m;
        let dy = landmark[1] - sensor.y_m;
        let q = dx * dx + dy * dy;
        if q < 1e-12 {
            return None;
        }
        let range = q.sqrt();
        let bearing = wrap_angle_rad(dy.atan2(dx) - sensor.theta_rad);
        // Derivatives with respect to the landmark; those with respect to the sensor position
        // are their negatives, and the bearing also falls by one per radian of sensor heading.
        let d_landmark = Matrix2::new(dx / range, dy / range, -dy / q, dx / q);
        let d_sensor = Matrix2x3::new(-dx / range, -dy / range, 0.0, dy / q, -dx / q, -1.0);
        Some(PredictedObservation {
            z: Vector2::new(range, bearing),
            d_pose: d_sensor * d_sensor_d_pose,
            d_landmark,
        })
    }

    /// Where a landmark observed at `range_m`, `bearing_rad` from `pose` lies, with the
    /// Jacobians of that position with respect to the pose (2 × 3) and to the observation
    /// (2 × 2).
    pub fn landmark_position(
        &self,
        pose: Pose2,
        range_m: f64,
        bearing_rad: f64,
    ) -> ([f64; 2], Matrix2x3<f64>, Matrix2<f64>) {
        let (sin, cos) = bearing_rad.sin_cos();
        let in_sensor = [range_m * cos, range_m * sin];
        let (sensor, d_sensor_d_pose, _) = compose_pose(pose, self.sensor_in_robot);
        let (position, d_sensor, d_point) = transform_point(sensor, in_sensor);
        let d_point_d_obs = Matrix2::new(cos, -range_m * sin, sin, range_m * cos);
        (
            position,
            d_sensor * d_sensor_d_pose,
            d_point * d_point_d_obs,
        )
    }

    /// The innovation `z − ẑ` with the bearing wrapped.
    pub fn innovation(
        observed: &LandmarkObservation,
        predicted: &PredictedObservation,
    ) -> Vector2<f64> {
        Vector2::new(
            observed.range_m - predicted.z[0],
            wrap_angle_rad(observed.bearing_rad - predicted.z[1]),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: RangeBearingModel = RangeBearingModel {
        sensor_in_robot: Pose2 {
            x_m: 0.95,
            y_m: -0.5,
            theta_rad: 0.1,
        },
        sigma_range_m: 0.1,
        sigma_bearing_rad: 0.01,
    };

    const POSE: Pose2 = Pose2 {
        x_m: 3.0,
        y_m: -1.0,
        theta_rad: 2.0,
    };

    /// `pose` with entry `col` (`x_m`, `y_m`, `theta_rad`) moved by `delta`.
    fn nudged(pose: Pose2, col: usize, delta: f64) -> Pose2 {
        let mut nudged = pose;
        match col {
            0 => nudged.x_m += delta,
            1 => nudged.y_m += delta,
            _ => nudged.theta_rad += delta,
        }
        nudged
    }

    #[test]
    fn inverse_then_predict_round_trips() {
        let pose = POSE;
        let (landmark, _, _) = MODEL.landmark_position(pose, 12.0, -0.7);
        let predicted = MODEL.predict(pose, landmark).unwrap();
        assert!((predicted.z[0] - 12.0).abs() < 1e-9);
        assert!((predicted.z[1] + 0.7).abs() < 1e-9);
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let pose = POSE;
        let landmark = [-5.0, 4.0];
        let p = MODEL.predict(pose, landmark).unwrap();
        let eps = 1e-7;
        for col in 0..3 {
            let plus = nudged(pose, col, eps);
            let minus = nudged(pose, col, -eps);
            let numeric = (MODEL.predict(plus, landmark).unwrap().z
                - MODEL.predict(minus, landmark).unwrap().z)
                / (2.0 * eps);
            assert!((p.d_pose.column(col) - numeric).amax() < 1e-6);
        }
        for col in 0..2 {
            let mut plus = landmark;
            plus[col] += eps;
            let mut minus = landmark;
            minus[col] -= eps;
            let numeric = (MODEL.predict(pose, plus).unwrap().z
                - MODEL.predict(pose, minus).unwrap().z)
                / (2.0 * eps);
            assert!((p.d_landmark.column(col) - numeric).amax() < 1e-6);
        }
        let (_, d_pose, d_obs) = MODEL.landmark_position(pose, 7.0, 0.3);
        for col in 0..3 {
            let plus = nudged(pose, col, eps);
            let minus = nudged(pose, col, -eps);
            let a = MODEL.landmark_position(plus, 7.0, 0.3).0;
            let b = MODEL.landmark_position(minus, 7.0, 0.3).0;
            assert!(((a[0] - b[0]) / (2.0 * eps) - d_pose[(0, col)]).abs() < 1e-6);
            assert!(((a[1] - b[1]) / (2.0 * eps) - d_pose[(1, col)]).abs() < 1e-6);
        }
        let a = MODEL.landmark_position(pose, 7.0 + eps, 0.3).0;
        let b = MODEL.landmark_position(pose, 7.0 - eps, 0.3).0;
        assert!(((a[0] - b[0]) / (2.0 * eps) - d_obs[(0, 0)]).abs() < 1e-6);
    }

    #[test]
    fn landmark_on_the_sensor_has_no_prediction() {
        let pose = Pose2::IDENTITY;
        let (sensor, _, _) = compose_pose(pose, MODEL.sensor_in_robot);
        assert!(MODEL.predict(pose, [sensor.x_m, sensor.y_m]).is_none());
    }
}
