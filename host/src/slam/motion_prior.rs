//! What local tracking expects of the motion between two scans, and how sure it is of it.
//!
//! The motion is predicted from the odometry, or else taken to be the last one again; how far
//! the real motion strays from that differs from robot to robot and from log to log (a robot
//! that stops, turns on the spot and drives three metres between scans strays by metres; one
//! driving down a corridor by centimetres). The prior learns it: the deviation of every motion
//! tracking placed with confidence from its prediction (its innovation) feeds a running mean
//! of the squared deviations, in translation and in rotation, between a floor and a ceiling.
//! This is the innovation-based adaptive estimate of a filter's process noise (after Mehra
//! 1970, "On the identification of variances and adaptive Kalman filtering").
//!
//! The prior serves twice. It scores a candidate pose: a pose the prediction makes unlikely
//! must fit the submap that much better to be taken, as in Cartographer's real-time
//! correlative matcher, which weighs the match score against the distance from the prediction.
//! And it sets how wide the search for a lost scan must reach: three standard deviations.

use crate::geometry::Pose2;

/// How the motion prior starts and learns. See the [module documentation](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionPriorOptions {
    /// Standard deviation of the prediction before any motion was tracked: translation (m),
    /// rotation (rad).
    pub initial_sigma: [f64; 2],
    /// The learned standard deviation never drops below this: translation (m), rotation (rad).
    pub min_sigma: [f64; 2],
    /// Nor grows above this.
    pub max_sigma: [f64; 2],
    /// Weight of each new innovation in the running mean of squared innovations (0–1).
    pub learning_rate: f64,
    /// How many independent measurements a scan's fit stands for: the prior's negative
    /// log-likelihood, divided by this, is taken from a candidate's
    /// [`SubmapFit::tracking_score`](super::SubmapFit::tracking_score) (a share of the
    /// scanned surface). Neighbouring beams on one wall say one thing, so this is far below
    /// the number of beams.
    pub fit_measurements: f64,
}

impl Default for MotionPriorOptions {
    fn default() -> Self {
        MotionPriorOptions {
            initial_sigma: [0.5, 30f64.to_radians()],
            min_sigma: [0.5, 30f64.to_radians()],
            max_sigma: [3.0, 90f64.to_radians()],
            learning_rate: 0.1,
            fit_measurements: 10.0,
        }
    }
}

/// The learned uncertainty of the predicted motion. See the [module documentation](self).
#[derive(Clone, Copy, Debug)]
pub struct MotionPrior {
    options: MotionPriorOptions,
    /// Running mean of the squared innovation per translation axis, m².
    variance_translation_m2: f64,
    /// Running mean of the squared heading innovation, rad².
    variance_rotation_rad2: f64,
}

impl MotionPrior {
    /// A prior at its initial standard deviations.
    pub fn new(options: MotionPriorOptions) -> Self {
        let [sigma_m, sigma_rad] = options.initial_sigma;
        MotionPrior {
            options,
            variance_translation_m2: sigma_m * sigma_m,
            variance_rotation_rad2: sigma_rad * sigma_rad,
        }
    }

    /// The standard deviations of the prediction now: translation (m), rotation (rad).
    pub fn sigma(&self) -> [f64; 2] {
        [
            self.variance_translation_m2.sqrt(),
            self.variance_rotation_rad2.sqrt(),
        ]
    }

    /// The squared Mahalanobis distance of `pose` from `predicted` (both `local_from_robot`),
    /// the deviation taken in the predicted robot frame.
    pub fn squared_distance(&self, predicted: Pose2, pose: Pose2) -> f64 {
        let deviation = predicted.inverse() * pose;
        (deviation.x_m * deviation.x_m + deviation.y_m * deviation.y_m)
            / self.variance_translation_m2
            + deviation.theta_rad * deviation.theta_rad / self.variance_rotation_rad2
    }

    /// What a candidate `pose` loses against its fit for lying where it does: the prior's
    /// negative log-likelihood over [`MotionPriorOptions::fit_measurements`].
    ///
    /// The prior is heavy-tailed (a Cauchy distribution of the Mahalanobis distance `d`,
    /// `ln(1 + d²/2)`): motions mostly follow the prediction closely, but a robot does stop or
    /// turn back between two scans, and a right pose far from the prediction must remain
    /// within reach of a good fit.
    pub fn penalty(&self, predicted: Pose2, pose: Pose2) -> f64 {
        let squared = self.squared_distance(predicted, pose);
        (0.5 * squared).ln_1p() / self.options.fit_measurements.max(1.0)
    }

    /// Learns from a scan tracked with confidence at `pose`, predicted at `predicted`.
    pub fn learn(&mut self, predicted: Pose2, pose: Pose2) {
        let deviation = predicted.inverse() * pose;
        let rate = self.options.learning_rate.clamp(0.0, 1.0);
        let per_axis_m2 = 0.5 * (deviation.x_m * deviation.x_m + deviation.y_m * deviation.y_m);
        let [min_m, min_rad] = self.options.min_sigma;
        let [max_m, max_rad] = self.options.max_sigma;
        self.variance_translation_m2 = ((1.0 - rate) * self.variance_translation_m2
            + rate * per_axis_m2)
            .clamp(min_m * min_m, max_m * max_m);
        self.variance_rotation_rad2 = ((1.0 - rate) * self.variance_rotation_rad2
            + rate * deviation.theta_rad * deviation.theta_rad)
            .clamp(min_rad * min_rad, max_rad * max_rad);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_far_from_the_prediction_costs_more() {
        let prior = MotionPrior::new(MotionPriorOptions::default());
        let predicted = Pose2::new(1.0, 2.0, 0.5);
        let near = predicted * Pose2::new(0.1, 0.0, 0.02);
        let far = predicted * Pose2::new(2.0, 0.0, 0.0);
        let turned = predicted * Pose2::new(0.0, 0.0, 1.5);
        assert!(prior.penalty(predicted, near) < 0.01);
        assert!(prior.penalty(predicted, far) > 0.15);
        assert!(prior.penalty(predicted, turned) > 0.15);
        assert!(prior.penalty(predicted, far) > prior.penalty(predicted, near));
        assert_eq!(prior.penalty(predicted, predicted), 0.0);
    }

    #[test]
    fn the_prior_learns_how_far_motions_stray_within_its_bounds() {
        let options = MotionPriorOptions::default();
        let mut stop_and_go = MotionPrior::new(options);
        let mut steady = MotionPrior::new(options);
        for _ in 0..100 {
            stop_and_go.learn(Pose2::IDENTITY, Pose2::new(2.0, 0.0, 0.0));
            steady.learn(Pose2::IDENTITY, Pose2::new(0.01, 0.0, 0.001));
        }
        let [far_m, _] = stop_and_go.sigma();
        let [near_m, near_rad] = steady.sigma();
        assert!((far_m - 2.0f64.sqrt()).abs() < 0.01, "{far_m}");
        assert!((near_m - options.min_sigma[0]).abs() < 1e-9);
        assert!((near_rad - options.min_sigma[1]).abs() < 1e-9);
    }
}
