//! The host's pose estimate during a run: laser odometry by scan matching against keyframes.
//!
//! Each scan is matched with the fast raster matcher ([`host::scan_match::FastMatcher`])
//! against the last keyframe, starting from a constant-velocity guess; a scan becomes the
//! next keyframe once the robot has moved [`KEYFRAME_DISTANCE_M`] or turned
//! [`KEYFRAME_TURN_RAD`] from the last one. Poses are in the `map` frame, whose origin is the
//! robot's pose at its first scan. Without loop closure this drifts; the full SLAM methods
//! replace it.

use host::geometry::Pose2;
use host::link::LaserScan;
use host::scan_match::{FastMatcher, PreparedReference, RasterOptions, Scan, SearchTable};
use protocol::{GpsFixMsg, MeasuringMode, ScanMsg};

/// A new keyframe after this much travel, m.
pub const KEYFRAME_DISTANCE_M: f64 = 0.3;
/// A new keyframe after this much turning, rad.
pub const KEYFRAME_TURN_RAD: f64 = 0.15;

/// The largest plausible motion between two scans, m (2.5 m/s at 37.5 scans per second).
const MAX_STEP_M: f64 = 0.07;
/// The largest plausible turn between two scans, rad.
const MAX_TURN_RAD: f64 = 0.05;

/// Laser odometry. See the [module documentation](self).
#[derive(Debug)]
pub struct Estimator {
    matcher: Option<FastMatcher>,
    /// The last keyframe's pose in `map`, and its scan drawn for the matcher once for every
    /// scan matched against it.
    keyframe: Option<(Option<PreparedReference>, Pose2)>,
    /// The last scan's pose in the keyframe's frame.
    last_in_keyframe: Pose2,
    /// The motion between the last two scans.
    motion: Pose2,
    pose_in_map: Pose2,
}

impl Estimator {
    /// Laser odometry with pixels of `resolution_m`: 5 cm indoors, coarser outdoors where
    /// the features are farther away.
    pub fn new(resolution_m: f64) -> Estimator {
        let raster = RasterOptions {
            resolution_m,
            max_gap_m: (10.0 * resolution_m).max(0.5),
            ..RasterOptions::default()
        };
        let table = SearchTable::quantised(6, 6, resolution_m, 12, 0.25_f64.to_radians(), &raster);
        Estimator {
            matcher: FastMatcher::new(raster, table).ok(),
            keyframe: None,
            last_in_keyframe: Pose2::IDENTITY,
            motion: Pose2::IDENTITY,
            pose_in_map: Pose2::IDENTITY,
        }
    }

    /// A scan at host time `_t_s`: returns the robot's pose `[x_m, y_m, theta_rad]` in `map`.
    pub fn on_scan(&mut self, _t_s: f64, msg: &ScanMsg) -> [f64; 3] {
        let scan = to_scan(msg);
        let Some((keyframe, keyframe_pose)) = &self.keyframe else {
            self.keyframe = Some((self.prepare(&scan), Pose2::IDENTITY));
            return pose_array(self.pose_in_map);
        };
        let guess = self.last_in_keyframe * self.motion;
        let matched = self
            .matcher
            .as_ref()
            .zip(keyframe.as_ref())
            .and_then(|(m, keyframe)| m.match_prepared(keyframe, &scan, guess).ok())
            .map_or(guess, |r| r.reference_from_new);
        let motion = self.last_in_keyframe.inverse() * matched;
        // A robot moves a few centimetres between scans; a larger step is a bad match, and
        // extrapolating it would run away.
        self.motion =
            if motion.x_m.hypot(motion.y_m) > MAX_STEP_M || motion.theta_rad.abs() > MAX_TURN_RAD {
                Pose2::IDENTITY
            } else {
                motion
            };
        self.last_in_keyframe = matched;
        self.pose_in_map = *keyframe_pose * matched;
        if matched.x_m.hypot(matched.y_m) > KEYFRAME_DISTANCE_M
            || matched.theta_rad.abs() > KEYFRAME_TURN_RAD
        {
            self.keyframe = Some((self.prepare(&scan), self.pose_in_map));
            self.last_in_keyframe = Pose2::IDENTITY;
        }
        pose_array(self.pose_in_map)
    }

    /// `scan` drawn as the matcher's reference, when there is a matcher.
    fn prepare(&self, scan: &Scan) -> Option<PreparedReference> {
        self.matcher.as_ref().map(|m| m.prepare(scan))
    }

    /// A GPS fix. Laser odometry does not use it.
    pub fn on_fix(&mut self, _fix: &GpsFixMsg) {}
}

fn pose_array(pose: Pose2) -> [f64; 3] {
    [pose.x_m, pose.y_m, pose.theta_rad]
}

/// The scan's beam end points.
fn to_scan(msg: &ScanMsg) -> Scan {
    LaserScan::from_msg(msg, MeasuringMode::DEFAULT).to_scan(80.0)
}
