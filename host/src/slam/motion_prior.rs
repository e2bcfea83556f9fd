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
//!
//! How far a motion can stray from its prediction also depends on the time it had: a laser
//! at 37.5 Hz sees the robot 2.7 cm further on at 1 m/s, and its motion cannot change by half
//! a metre in 27 ms. The floor of the learned deviation is therefore the smaller of
//! [`MotionPriorOptions::min_sigma`] and what [`MotionPriorOptions::max_stray_per_s`] allows
//! over the time between the two scans ([`MotionPrior::set_interval`]).

use crate::geometry::Pose2;

/// How the motion prior starts and learns. See the [module documentation](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionPriorOptions {
    /// Standard deviation of the prediction before any motion was tracked: translation (m),
    /// rotation (rad).
    pub initial_sigma: [f64; 2],
    /// The learned standard deviation never drops below this between scans far apart in time:
    /// translation (m), rotation (rad).
    pub min_sigma: [f64; 2],
    /// What a motion can stray from its prediction per second between the scans: the floor
    /// is the smaller of [`Self::min_sigma`] and this times the longer of the last two
    /// intervals, translation (m/s), rotation (rad/s).
    pub max_stray_per_s: [f64; 2],
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
            // The floor above from 0.4 s between scans on (every benchmark log but a few of
            // Intel's scans); 3.3 cm and 2° at 37.5 Hz.
            max_stray_per_s: [1.25, 75f64.to_radians()],
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
    /// Time between the last two scans and between the two before, s (`None` before there
    /// were such scans, or where the time did not advance: the floor is then `min_sigma`).
    intervals_s: [Option<f64>; 2],
}

impl MotionPrior {
    /// A prior at its initial standard deviations.
    pub fn new(options: MotionPriorOptions) -> Self {
        let [sigma_m, sigma_rad] = options.initial_sigma;
        MotionPrior {
            options,
            variance_translation_m2: sigma_m * sigma_m,
            variance_rotation_rad2: sigma_rad * sigma_rad,
            intervals_s: [None; 2],
        }
    }

    /// Sets the time between the scan being tracked and the one before, s: the floor of the
    /// prior's deviation scales with it below [`MotionPriorOptions::min_sigma`]. The
    /// prediction repeats the motion over the interval before, so the floor follows the
    /// longer of the two: a scan stamped right after one that came seconds later is predicted
    /// from a motion of seconds.
    pub fn set_interval(&mut self, interval_s: f64) {
        let interval_s = (interval_s.is_finite() && interval_s > 0.0).then_some(interval_s);
        self.intervals_s = [interval_s, self.intervals_s[0]];
    }

    /// Whether the scans are so close in time that the floor of the prior's translation is
    /// set by the interval ([`MotionPriorOptions::max_stray_per_s`]) rather than by
    /// [`MotionPriorOptions::min_sigma`]: the robot had no time to stop or turn between them,
    /// and the prediction holds to within the learned deviation.
    pub fn is_short_interval(&self) -> bool {
        self.floor()[0] < self.options.min_sigma[0]
    }

    /// The lowest standard deviations over the current interval: translation (m), rotation
    /// (rad).
    fn floor(&self) -> [f64; 2] {
        let [min_m, min_rad] = self.options.min_sigma;
        let [Some(this_s), Some(before_s)] = self.intervals_s else {
            return [min_m, min_rad];
        };
        let interval_s = this_s.max(before_s);
        let [per_s_m, per_s_rad] = self.options.max_stray_per_s;
        [
            min_m.min(per_s_m * interval_s),
            min_rad.min(per_s_rad * interval_s),
        ]
    }

    /// The variances of the prediction over the current interval: m², rad².
    fn variances(&self) -> [f64; 2] {
        let [floor_m, floor_rad] = self.floor();
        let [max_m, max_rad] = self.options.max_sigma;
        [
            self.variance_translation_m2
                .clamp(floor_m * floor_m, (max_m * max_m).max(floor_m * floor_m)),
            self.variance_rotation_rad2.clamp(
                floor_rad * floor_rad,
                (max_rad * max_rad).max(floor_rad * floor_rad),
            ),
        ]
    }

    /// The standard deviations of the prediction now: translation (m), rotation (rad).
    pub fn sigma(&self) -> [f64; 2] {
        self.variances().map(f64::sqrt)
    }

    /// The squared Mahalanobis distance of `pose` from `predicted` (both `local_from_robot`),
    /// the deviation taken in the predicted robot frame.
    pub fn squared_distance(&self, predicted: Pose2, pose: Pose2) -> f64 {
        let deviation = predicted.inverse() * pose;
        let [variance_m2, variance_rad2] = self.variances();
        (deviation.x_m * deviation.x_m + deviation.y_m * deviation.y_m) / variance_m2
            + deviation.theta_rad * deviation.theta_rad / variance_rad2
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
        // Learnt from the variances over this interval, so that a stretch of slow scans
        // after a fast one starts from its own floor.
        let [variance_m2, variance_rad2] = self.variances();
        let [max_m, max_rad] = self.options.max_sigma;
        self.variance_translation_m2 =
            ((1.0 - rate) * variance_m2 + rate * per_axis_m2).min(max_m * max_m);
        self.variance_rotation_rad2 = ((1.0 - rate) * variance_rad2
            + rate * deviation.theta_rad * deviation.theta_rad)
            .min(max_rad * max_rad);
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

    #[test]
    fn scans_close_in_time_lower_the_floor_in_proportion() {
        let options = MotionPriorOptions::default();
        let mut prior = MotionPrior::new(options);
        prior.set_interval(1.0);
        prior.set_interval(1.0 / 37.5);
        // One short interval after a long one is predicted from the long one's motion.
        assert!(!prior.is_short_interval());
        prior.set_interval(1.0 / 37.5);
        assert!(prior.is_short_interval());
        for _ in 0..200 {
            prior.learn(Pose2::IDENTITY, Pose2::new(0.001, 0.0, 0.0001));
        }
        let [sigma_m, sigma_rad] = prior.sigma();
        let [per_s_m, per_s_rad] = options.max_stray_per_s;
        assert!((sigma_m - per_s_m / 37.5).abs() < 1e-12, "{sigma_m}");
        assert!((sigma_rad - per_s_rad / 37.5).abs() < 1e-12, "{sigma_rad}");
        // A step of 10 cm is then far less likely than between scans a second apart.
        let step = Pose2::new(0.1, 0.0, 0.0);
        let close = prior.penalty(Pose2::IDENTITY, step);
        prior.set_interval(1.0);
        assert!(!prior.is_short_interval());
        let [far_m, far_rad] = prior.sigma();
        assert!((far_m - options.min_sigma[0]).abs() < 1e-12, "{far_m}");
        assert!((far_rad - options.min_sigma[1]).abs() < 1e-12, "{far_rad}");
        assert!(close > 2.0 * prior.penalty(Pose2::IDENTITY, step));
    }
}
