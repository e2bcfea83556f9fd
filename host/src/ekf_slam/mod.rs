//! Method 1: EKF SLAM over the robot and point landmarks, with size-limited local maps joined
//! into one global map.
//!
//! * [`EkfState`]: mean and full covariance, Joseph-form updates; the covariance kept whole
//!   or as one triangle ([`CovarianceStore`], [`PackedCovariance`]).
//! * Motion models ([`MotionModel`]): [`AckermannModel`] (car odometry, with online
//!   calibration of speed scale and steering offset), [`DifferentialDriveModel`] and
//!   [`ConstantVelocityModel`] (no odometry).
//! * [`RangeBearingModel`]: range-bearing observations of point landmarks.
//! * [`jcbb`]: data association by joint compatibility.
//! * [`HistoryMemory`]: recognising a revisited place from landmark constellations
//!   ([`Constellation`]), with evidence over consecutive local maps.
//! * [`LocalMap`] and [`GlobalMap`]: local maps and map joining (Tardós et al. 2002).
//! * [`LocalMapAnchors`]: each finished local map's base, fitted again to the final map.
//! * [`SubmapSlam`]: the pipeline.
//! * [`MapSmoother`]: the trajectory estimated again against the finished map, forwards and
//!   backwards.
//! * [`GpsAnchor`]: GPS fixes align the map to the GPS frame, then update the filter.
//! * [`LandmarkSlam`]: the method as one type, time-ordered inputs, observations and fixes in,
//!   poses, trajectory (smoothed at the end) and landmarks out.
//! * [`EkfPipeline`]: the method on the board link's events (trees from each scan, fixes).

pub mod ackermann;
pub mod constant_velocity;
pub mod constellation;
pub mod covariance_store;
pub mod differential_drive;
mod ekf_pipeline;
pub mod ekf_state;
pub mod frames;
pub mod global_map;
pub mod gps_anchor;
pub mod history_memory;
pub mod jcbb;
pub mod joined_state;
pub mod landmark_info;
mod landmark_slam;
pub mod local_map;
pub mod local_map_anchors;
pub mod map_smoother;
pub mod motion_model;
pub mod options;
pub mod packed_covariance;
pub mod pose_history;
pub mod range_bearing;
pub mod submap_slam;

pub use ackermann::{AckermannGeometry, AckermannInput, AckermannModel};
pub use constant_velocity::ConstantVelocityModel;
pub use constellation::{Constellation, ConstellationOptions, PlaceMatch};
pub use covariance_store::CovarianceStore;
pub use differential_drive::{DifferentialDriveInput, DifferentialDriveModel};
pub use ekf_pipeline::{EkfPipeline, EkfPipelineOptions, EkfPipelineStats, StampedPose};
pub use ekf_state::{EkfError, EkfState};
pub use global_map::{GlobalMap, JoinReport};
pub use gps_anchor::{GpsAnchor, GpsAnchorOptions, GpsOutcome};
pub use history_memory::{HistoryMemory, HistoryMemoryOptions, LoopClosure};
pub use jcbb::{JcbbOptions, jcbb};
pub use landmark_info::LandmarkInfo;
pub use landmark_slam::{LandmarkSlam, LandmarkSlamOptions, TimedPose};
pub use local_map::{LocalMap, ObservationReport};
pub use local_map_anchors::LocalMapAnchors;
pub use map_smoother::{MapSmoother, MapSmootherOptions, MapSmootherStats};
pub use motion_model::{MotionModel, MotionPrediction};
pub use options::{AssociationOptions, SubmapSlamOptions};
pub use packed_covariance::PackedCovariance;
pub use pose_history::{PoseHistory, PoseHistoryOptions};
pub use range_bearing::{LandmarkObservation, PredictedObservation, RangeBearingModel};
pub use submap_slam::{MappedLandmark, SubmapSlam, SubmapSlamStats};
