//! Method 1 on a single camera (MonoSLAM-style): an EKF over the camera and its 3D point
//! features, with inverse-depth features, active search and 1-point RANSAC.
//!
//! * [`camera_pipeline`]: the method with GPS as the robot runs it, [`CameraPipeline`].
//! * [`pinhole`]: the camera model, with radial–tangential distortion.
//! * [`sequence`]: recorded sequences in the KITTI and TUM layouts, with ground truth.
//! * [`patch`]: feature patches and their correlation search; [`appearance`]: a feature's
//!   first sighting, warped to the view of the camera now.
//! * [`forward_motion_prior`]: a camera looking forward from a ground vehicle,
//!   [`ForwardMotionPrior`].
//! * [`history_memory`]: finished local maps' features, recognised and used again.
//! * [`known_target`]: a target of known corners that gives a run its scale.
//! * [`level_prior`]: a camera held level on a ground robot, [`LevelPrior`].
//! * [`mono_ekf`]: the filter (state, motion and measurement models, inverse depth).
//! * [`mono_slam`]: the method frame by frame, [`MonoSlam`].
//! * [`motion_segmentation`]: points that move on their own, kept out of the map.
//! * [`trajectory_error`]: the estimate against the truth, up to a similarity.

pub mod appearance;
pub mod camera_pipeline;
pub mod forward_motion_prior;
pub mod history_memory;
pub mod known_target;
pub mod level_prior;
pub mod mono_ekf;
pub mod mono_slam;
pub mod motion_segmentation;
pub mod patch;
pub mod pinhole;
pub mod sequence;
pub mod trajectory_error;

pub use camera_pipeline::{CameraPipeline, CameraPipelineOptions, CameraPipelineStats, CameraPose};
pub use forward_motion_prior::ForwardMotionPrior;
pub use known_target::{KnownTarget, TargetCorner, TargetError, parse_known_target};
pub use level_prior::{LevelPrior, level_frame};
pub use mono_ekf::{MonoEkf, MonoEkfOptions};
pub use mono_slam::{FrameReport, MeasuredFeature, MonoSlam, MonoSlamOptions, MonoSlamStats};
pub use pinhole::PinholeCamera;
pub use sequence::{CameraSequence, SequenceError, SequenceLayout};
pub use trajectory_error::{TrajectoryError, trajectory_error};
