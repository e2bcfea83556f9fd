//! Monte-Carlo data for landmark EKF SLAM in a seeded [`crate::world::Scenario`]: true poses,
//! noisy odometry and noisy range-bearing observations of the landmarks (tree trunks in the
//! park), with the NEES helpers that check a filter's consistency on them.
//!
//! * [`NoiseModel`] ([`noise_model`]): the standard deviations and the laser timing.
//! * [`simulate()`] ([`mod@simulate`]): one run, a [`SimulatedRun`] of [`SimStep`]s
//!   ([`simulated_run`]).
//! * [`arc_step`], [`arc_odometry`] ([`arc_model`]): the exact arc motion model the odometry
//!   is meant for, and its inverse.
//! * [`pose_nees`], [`chi_square_bounds`] ([`host::evaluation`]): the consistency test.
//! * [`IdealEkf`] ([`ideal_ekf`]): the test's reference, EKF SLAM with the true data
//!   association and every Jacobian at the true state.
//!
//! # Contract
//!
//! Steps are `laser_period_s` apart from `t = 0` to the end of the scenario. With `N(0, σ²)`
//! an independent Gaussian draw:
//!
//! * **True pose.** Step 0 is the scenario's pose at `t = 0`. Every later true pose is
//!   [`arc_step`] of the previous one under the true odometry `(v̄, ω̄)` =
//!   [`arc_odometry`]`(previous true pose, scenario pose at t, dt)`: the heading equals the
//!   scenario's at every step (to rounding), and the position follows the scenario's along the
//!   direction of motion. A constant-speed, constant-turn arc cannot reproduce the scenario's
//!   changing speed and turn rate within a period exactly, so the true positions drift across
//!   the direction of motion, by about 5 mm at most over ten minutes in the park (tested
//!   below 1 cm); in exchange the
//!   true odometry integrates exactly to the true poses, and the only odometry error is the
//!   injected noise.
//! * **Odometry** of step `k ≥ 1` (the interval from step `k − 1`):
//!   `speed_mps = v̄ + N(0, σ_v²)` with `σ_v =` [`NoiseModel::speed_sigma_at_mps`]`(v̄)`, and
//!   `yaw_rate_radps = ω̄ + N(0, σ_ω²)` with `σ_ω =`
//!   [`NoiseModel::yaw_rate_sigma_at_radps`]`(ω̄)`. A filter predicts with [`arc_step`] and the
//!   control covariance `diag(σ_v², σ_ω²)`.
//! * **Observations**: every landmark whose centre lies within `max_range_m` of the true
//!   position and within half of `field_of_view_rad` of the true heading, and whose line of
//!   sight (a ray cast to its centre) meets nothing before its own surface. `range_m` is the
//!   distance to the centre plus `N(0, range_sigma_m²)`; `bearing_rad` is the centre's bearing
//!   in the sensor (= robot) frame plus `N(0, bearing_sigma_rad²)`, wrapped into `(-π, π]`.
//!   The measurement covariance is `diag(range_sigma_m², bearing_sigma_rad²)`. The diameter is
//!   exact.
//!
//! Randomness: the odometry noise comes from ChaCha8 stream 0 of the run seed, the observation
//! noise from stream 1, drawn in step order (speed then yaw rate; per observation in id order,
//! range then bearing). The same scenario, model and seed give the same run; other seeds give
//! independent noise on the same true poses.

pub mod arc_model;
pub mod ideal_ekf;
pub mod noise_model;
pub mod simulate;
pub mod simulated_run;

pub use arc_model::{arc_odometry, arc_step};
pub use host::evaluation::{chi_square_bounds, pose_nees};
pub use ideal_ekf::{IdealEkf, IdealEkfError};
pub use noise_model::{NoiseModel, NoiseModelError};
pub use simulate::simulate;
pub use simulated_run::{OdometryInput, SimObservation, SimStep, SimulatedRun};
