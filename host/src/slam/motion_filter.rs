//! Which scans become part of the map.
//!
//! Every scan is tracked, so every scan has a pose; but a laser at 37.5 Hz on a robot at 1 m/s
//! takes a scan every 2.7 cm, and a robot standing still takes the same scan over and over.
//! Inserting all of them would make the submaps, the pose graph, loop closure and the final
//! refinement grow with the time spent rather than with the ground covered. A scan is
//! therefore inserted (into the submaps, as a node of the pose graph) only once the robot has
//! moved or turned enough since the last inserted one, or after a while in any case, as
//! Cartographer's motion filter does (0.2 m, 1°, 5 s). The other scans are placed relative to
//! the last node and follow it when loop closures move it. A scan local tracking had to
//! search for is always inserted.
//!
//! On logs of about one scan per metre it inserts every scan; at the laser's real rate it
//! inserts about one scan in eight (`docs/method2.md` gives what that does).

use crate::geometry::Pose2;

/// When a tracked scan is inserted. See the [module documentation](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionFilterOptions {
    /// Whether to filter at all; `false` inserts every scan.
    pub enabled: bool,
    /// A scan farther than this from the last inserted one is inserted, metres.
    pub max_distance_m: f64,
    /// A scan turned further than this from the last inserted one is inserted, radians.
    pub max_angle_rad: f64,
    /// A scan taken longer than this after the last inserted one is inserted, seconds.
    pub max_time_s: f64,
}

impl Default for MotionFilterOptions {
    fn default() -> Self {
        MotionFilterOptions {
            enabled: true,
            max_distance_m: 0.2,
            max_angle_rad: 1f64.to_radians(),
            max_time_s: 5.0,
        }
    }
}

/// The last inserted scan, and the test against it. See the [module documentation](self).
#[derive(Clone, Copy, Debug)]
pub struct MotionFilter {
    options: MotionFilterOptions,
    /// Time and `local_from_robot` of the last inserted scan.
    last_inserted: Option<(f64, Pose2)>,
}

impl MotionFilter {
    /// A filter that inserts the first scan it is shown.
    pub fn new(options: MotionFilterOptions) -> Self {
        MotionFilter {
            options,
            last_inserted: None,
        }
    }

    /// Whether the scan taken at `time_s` and tracked at `pose_in_local` is to be inserted
    /// (always when `always`); when it is, it becomes the scan later ones are compared with.
    pub fn admits(&mut self, time_s: f64, pose_in_local: Pose2, always: bool) -> bool {
        let admitted = match self.last_inserted {
            None => true,
            Some(_) if always => true,
            Some(_) if !self.options.enabled => true,
            Some((last_time_s, last_pose)) => {
                let motion = last_pose.inverse() * pose_in_local;
                motion.x_m.hypot(motion.y_m) > self.options.max_distance_m
                    || motion.theta_rad.abs() > self.options.max_angle_rad
                    // A clock that jumps back (a replay's restart) inserts too.
                    || !(time_s - last_time_s <= self.options.max_time_s
                        && time_s >= last_time_s)
            }
        };
        if admitted {
            self.last_inserted = Some((time_s, pose_in_local));
        }
        admitted
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scan_is_inserted_after_enough_motion_turn_or_time() {
        let mut filter = MotionFilter::new(MotionFilterOptions::default());
        assert!(filter.admits(0.0, Pose2::IDENTITY, false));
        // Standing still, creeping and turning a little: not inserted.
        assert!(!filter.admits(0.1, Pose2::IDENTITY, false));
        assert!(!filter.admits(0.2, Pose2::new(0.15, 0.1, 0.01), false));
        // 0.25 m from the last inserted scan.
        assert!(filter.admits(0.3, Pose2::new(0.25, 0.0, 0.0), false));
        assert!(!filter.admits(0.4, Pose2::new(0.3, 0.0, 0.0), false));
        // 1.5° of turn on the spot.
        assert!(filter.admits(0.5, Pose2::new(0.25, 0.0, 1.5f64.to_radians()), false));
        // Standing still for longer than 5 s.
        let still = Pose2::new(0.25, 0.0, 1.5f64.to_radians());
        assert!(!filter.admits(5.4, still, false));
        assert!(filter.admits(5.6, still, false));
        // A clock that went back.
        assert!(filter.admits(1.0, still, false));
        // A scan that must be a node.
        assert!(filter.admits(1.1, still, true));
    }

    #[test]
    fn switched_off_it_inserts_every_scan() {
        let mut filter = MotionFilter::new(MotionFilterOptions {
            enabled: false,
            ..MotionFilterOptions::default()
        });
        for k in 0..5 {
            assert!(filter.admits(f64::from(k) * 0.01, Pose2::IDENTITY, false));
        }
    }
}
