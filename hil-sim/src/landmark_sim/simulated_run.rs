//! The data one simulated landmark run produces: per laser scan, the true pose, the noisy
//! odometry since the previous scan, and the noisy landmark observations.
//!
//! What is noisy and how is stated in [`super`] and on each field; the standard deviations
//! come from the [`super::NoiseModel`] the run was made with.

/// Odometry over one interval: a constant forward speed and yaw rate, to be integrated with
/// the exact arc model ([`super::arc_step`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OdometryInput {
    /// Forward speed, metres per second.
    pub speed_mps: f64,
    /// Turn rate, radians per second, counter-clockwise positive.
    pub yaw_rate_radps: f64,
}

/// One landmark seen in one scan, measured from the laser (at the robot origin, facing
/// forward, so the sensor frame is the robot frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimObservation {
    /// The landmark's [`crate::world::Landmark::id`]: the true data association.
    pub landmark_id: u32,
    /// Distance from the laser to the landmark's centre plus `N(0, range_sigma_m²)` noise,
    /// metres (not clamped, so it may be negative when the noise exceeds the distance).
    pub range_m: f64,
    /// Bearing of the landmark's centre in the sensor frame (counter-clockwise from the
    /// forward axis) plus `N(0, bearing_sigma_rad²)` noise, wrapped into `(-π, π]`, radians.
    pub bearing_rad: f64,
    /// The landmark's true diameter, metres (noise-free, a hint for data association).
    pub diameter_m: f64,
}

/// The data at one laser time.
#[derive(Debug, Clone, PartialEq)]
pub struct SimStep {
    /// Time since the start of the scenario, seconds.
    pub t_s: f64,
    /// Length of the odometry interval ending at this step, seconds; 0 at step 0.
    pub dt_s: f64,
    /// The robot's true pose in the world frame, `[x_m, y_m, theta_rad]`, heading in
    /// `(-π, π]`.
    pub true_pose: [f64; 3],
    /// Noisy odometry for the interval from the previous step to this one; zero (and
    /// noise-free) at step 0.
    pub odometry: OdometryInput,
    /// The landmarks observed at this step, in ascending id order.
    pub observations: Vec<SimObservation>,
}

/// A simulated run: one [`SimStep`] per laser scan, the first at `t = 0`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimulatedRun {
    /// The steps in time order, `laser_period_s` apart.
    pub steps: Vec<SimStep>,
}

impl SimulatedRun {
    /// The true pose at step 0, where a filter starts; `None` for an empty run.
    pub fn initial_pose(&self) -> Option<[f64; 3]> {
        self.steps.first().map(|step| step.true_pose)
    }
}
