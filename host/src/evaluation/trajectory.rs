//! A trajectory: robot poses in the map frame, each with its timestamp, looked up by time.
//!
//! Logs and relation files print timestamps with different precision (the Intel relations,
//! for instance, differ from the log's scan timestamps in the last printed digits), so a lookup
//! takes the pose nearest in time within a tolerance rather than an exact match.

use crate::geometry::Pose2;

/// The robot's pose in the map at one timestamp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StampedPose {
    /// When the robot was there, seconds.
    pub timestamp_s: f64,
    /// The robot's pose, `map_from_robot`.
    pub pose_in_map: Pose2,
}

impl StampedPose {
    /// The pose `pose_in_map` at `timestamp_s`.
    pub fn new(timestamp_s: f64, pose_in_map: Pose2) -> Self {
        StampedPose {
            timestamp_s,
            pose_in_map,
        }
    }
}

/// Poses ordered by timestamp.
///
/// Poses with equal timestamps keep the order they were given in. A pose whose timestamp is NaN
/// sorts first or last (by its sign) and is never found by [`Trajectory::nearest`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    poses: Vec<StampedPose>,
}

impl Trajectory {
    /// A trajectory of `poses`, sorted by timestamp.
    pub fn new(mut poses: Vec<StampedPose>) -> Self {
        poses.sort_by(|a, b| a.timestamp_s.total_cmp(&b.timestamp_s));
        Trajectory { poses }
    }

    /// The poses, by timestamp.
    pub fn poses(&self) -> &[StampedPose] {
        &self.poses
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// True if there are no poses.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// Index (into [`Trajectory::poses`]) of the pose nearest in time to `timestamp_s`, if it
    /// is at most `tolerance_s` away. Of two poses equally near, the earlier one is taken.
    pub fn nearest(&self, timestamp_s: f64, tolerance_s: f64) -> Option<usize> {
        // First pose at or after `timestamp_s` in the `total_cmp` order the poses are sorted by.
        let after = self
            .poses
            .partition_point(|p| p.timestamp_s.total_cmp(&timestamp_s).is_lt());
        let distance = |index: usize| (self.poses[index].timestamp_s - timestamp_s).abs();
        // A NaN distance (NaN timestamp) loses against any number.
        let nearer = |a: usize, b: usize| distance(a) < distance(b) || distance(b).is_nan();
        let before = after.checked_sub(1);
        let at_or_after = (after < self.poses.len()).then_some(after);
        let best = match (before, at_or_after) {
            (Some(b), Some(a)) if nearer(a, b) => Some(a),
            (Some(b), _) => Some(b),
            (None, a) => a,
        };
        // `<=` is false for NaN, so a NaN timestamp never matches.
        best.filter(|&index| distance(index) <= tolerance_s)
    }

    /// The pose nearest in time to `timestamp_s` within `tolerance_s`; see
    /// [`Trajectory::nearest`].
    pub fn pose_near(&self, timestamp_s: f64, tolerance_s: f64) -> Option<&StampedPose> {
        self.nearest(timestamp_s, tolerance_s)
            .map(|index| &self.poses[index])
    }
}

impl FromIterator<StampedPose> for Trajectory {
    fn from_iter<I: IntoIterator<Item = StampedPose>>(poses: I) -> Self {
        Trajectory::new(poses.into_iter().collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(timestamp_s: f64, x_m: f64) -> StampedPose {
        StampedPose::new(timestamp_s, Pose2::new(x_m, 0.0, 0.0))
    }

    #[test]
    fn test_sorts_by_time_keeping_ties_in_order() {
        let trajectory = Trajectory::new(vec![at(2.0, 0.0), at(1.0, 1.0), at(2.0, 2.0)]);
        let xs: Vec<f64> = trajectory
            .poses()
            .iter()
            .map(|p| p.pose_in_map.x_m)
            .collect();
        assert_eq!(xs, [1.0, 0.0, 2.0]);
    }

    #[test]
    fn test_nearest_within_tolerance() {
        let trajectory: Trajectory = [at(10.0, 0.0), at(10.5, 1.0), at(11.0, 2.0)]
            .into_iter()
            .collect();
        assert_eq!(trajectory.nearest(10.5, 0.0), Some(1));
        assert_eq!(trajectory.nearest(10.5004, 1e-3), Some(1));
        assert_eq!(trajectory.nearest(10.4996, 1e-3), Some(1));
        assert_eq!(trajectory.nearest(10.502, 1e-3), None);
        assert_eq!(trajectory.nearest(10.7, 0.3), Some(1));
        assert_eq!(trajectory.nearest(10.8, 0.3), Some(2));
        // Halfway between two poses the earlier one wins.
        assert_eq!(trajectory.nearest(10.75, 0.3), Some(1));
        // Before the first and after the last pose.
        assert_eq!(trajectory.nearest(9.9995, 1e-3), Some(0));
        assert_eq!(trajectory.nearest(11.0005, 1e-3), Some(2));
        assert_eq!(trajectory.nearest(12.0, 1e-3), None);
        assert_eq!(trajectory.nearest(f64::NAN, 1e-3), None);
        let pose = trajectory.pose_near(11.0, 0.0).map(|p| p.pose_in_map.x_m);
        assert_eq!(pose, Some(2.0));
    }

    #[test]
    fn test_empty_and_nan_timestamps() {
        assert_eq!(Trajectory::default().nearest(1.0, 1.0), None);
        let trajectory = Trajectory::new(vec![at(f64::NAN, 0.0), at(1.0, 1.0)]);
        assert_eq!(trajectory.poses()[0].timestamp_s, 1.0);
        assert_eq!(trajectory.nearest(1.0, 0.0), Some(0));
        assert_eq!(trajectory.nearest(5.0, 10.0), Some(0));
        // A NaN of the other sign sorts first; it still loses against a real neighbour.
        let trajectory = Trajectory::new(vec![at(1.0, 1.0), at(-f64::NAN, 0.0)]);
        assert!(trajectory.poses()[0].timestamp_s.is_nan());
        assert_eq!(trajectory.nearest(1.0, 0.0), Some(1));
        assert_eq!(trajectory.nearest(0.5, 1.0), Some(1));
    }
}
