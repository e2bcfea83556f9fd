//! A trajectory's error against GPS fixes, and the receiver's own jumps.
//!
//! Where no ground truth exists but a GPS track does (Victoria Park), the trajectory's position
//! at each fix's time is compared with the fix: directly when the trajectory is in the fixes'
//! frame (GPS was fused), or after the best rigid alignment when it is not (a SLAM run without
//! GPS lives in its own frame). A receiver jumps at times; such a fix lies further from both of
//! its neighbours than the vehicle could drive, and is found from the fixes alone, whatever the
//! trajectory, so that the error can be given with and without those fixes.

use nalgebra::Matrix2;
use serde::Serialize;

use crate::geometry::Pose2;
use crate::georef::{AlignmentPair, RigidAlignment2d, RigidAlignmentOptions};

/// A position in a metric frame at a time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedPosition {
    /// Time, seconds.
    pub t_s: f64,
    /// `[x_m, y_m]`.
    pub position_m: [f64; 2],
}

/// The distances between a trajectory and the fixes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GpsError {
    /// Fixes compared (those within the trajectory's time span).
    pub compared: usize,
    /// Root mean square distance, metres; NaN when none was compared.
    pub rms_m: f64,
    /// Median distance, metres; NaN when none was compared.
    pub median_m: f64,
}

/// The distance of `trajectory` (positions in time order) to each of `fixes` within its time
/// span, the trajectory interpolated at each fix's time; after the best rigid alignment of the
/// trajectory onto the fixes when `align`.
pub fn error_to_gps(
    trajectory: &[TimedPosition],
    fixes: &[TimedPosition],
    align: bool,
) -> GpsError {
    let pairs: Vec<AlignmentPair> = fixes
        .iter()
        .filter_map(|fix| {
            position_at(trajectory, fix.t_s).map(|p| AlignmentPair {
                point_in_map: p,
                point_in_enu: fix.position_m,
                covariance_in_enu_m2: Matrix2::identity(),
            })
        })
        .collect();
    let enu_from_map = if align {
        RigidAlignment2d::estimate(&pairs, &RigidAlignmentOptions::default())
            .map(|a| a.enu_from_map)
            .unwrap_or_default()
    } else {
        Pose2::IDENTITY
    };
    let mut distances: Vec<f64> = pairs
        .iter()
        .map(|pair| {
            let [x, y] = enu_from_map.transform_point(pair.point_in_map);
            (x - pair.point_in_enu[0]).hypot(y - pair.point_in_enu[1])
        })
        .collect();
    if distances.is_empty() {
        return GpsError {
            compared: 0,
            rms_m: f64::NAN,
            median_m: f64::NAN,
        };
    }
    let rms_m = (distances.iter().map(|d| d * d).sum::<f64>() / distances.len() as f64).sqrt();
    distances.sort_by(f64::total_cmp);
    GpsError {
        compared: distances.len(),
        rms_m,
        median_m: distances[distances.len() / 2],
    }
}

/// Whether each of `fixes` (in time order) is a receiver jump: further from both its previous
/// and its next fix than `max_speed_mps` could carry the vehicle (a first or last fix is
/// judged by its one neighbour).
pub fn receiver_jumps(fixes: &[TimedPosition], max_speed_mps: f64) -> Vec<bool> {
    let too_fast = |a: &TimedPosition, b: &TimedPosition| {
        let dt_s = (b.t_s - a.t_s).abs();
        let [ax, ay] = a.position_m;
        let [bx, by] = b.position_m;
        (bx - ax).hypot(by - ay) > max_speed_mps * dt_s
    };
    (0..fixes.len())
        .map(|i| {
            let before = i.checked_sub(1).map(|p| too_fast(&fixes[p], &fixes[i]));
            let after = fixes.get(i + 1).map(|next| too_fast(&fixes[i], next));
            match (before, after) {
                (Some(a), Some(b)) => a && b,
                (Some(one), None) | (None, Some(one)) => one,
                (None, None) => false,
            }
        })
        .collect()
}

/// The trajectory's position at `t_s`, interpolated between the positions around it.
fn position_at(trajectory: &[TimedPosition], t_s: f64) -> Option<[f64; 2]> {
    let after = trajectory.partition_point(|p| p.t_s < t_s);
    if after == 0 || after == trajectory.len() {
        return None;
    }
    let (a, b) = (trajectory[after - 1], trajectory[after]);
    let f = if b.t_s > a.t_s {
        (t_s - a.t_s) / (b.t_s - a.t_s)
    } else {
        0.0
    };
    Some([
        a.position_m[0] + f * (b.position_m[0] - a.position_m[0]),
        a.position_m[1] + f * (b.position_m[1] - a.position_m[1]),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t_s: f64, x_m: f64, y_m: f64) -> TimedPosition {
        TimedPosition {
            t_s,
            position_m: [x_m, y_m],
        }
    }

    #[test]
    fn a_shifted_and_turned_trajectory_has_no_error_once_aligned() {
        let fixes: Vec<TimedPosition> = (0..20)
            .map(|k| {
                let t = f64::from(k);
                at(t, 2.0 * t, (0.3 * t).sin() * 5.0)
            })
            .collect();
        let map_from_enu = Pose2::new(10.0, -4.0, 0.7);
        let trajectory: Vec<TimedPosition> = fixes
            .iter()
            .map(|f| TimedPosition {
                t_s: f.t_s,
                position_m: map_from_enu.transform_point(f.position_m),
            })
            .collect();
        let aligned = error_to_gps(&trajectory, &fixes, true);
        assert_eq!(aligned.compared, 19, "the first fix has no pose before it");
        assert!(aligned.rms_m < 1e-9, "{aligned:?}");
        let direct = error_to_gps(&trajectory, &fixes, false);
        assert!(direct.rms_m > 5.0, "{direct:?}");
        assert!(direct.median_m <= direct.rms_m * 2.0);
    }

    #[test]
    fn no_overlap_in_time_compares_nothing() {
        let error = error_to_gps(
            &[at(0.0, 0.0, 0.0), at(1.0, 1.0, 0.0)],
            &[at(5.0, 0.0, 0.0)],
            false,
        );
        assert_eq!(error.compared, 0);
        assert!(error.rms_m.is_nan());
    }

    #[test]
    fn a_jump_is_far_from_both_neighbours() {
        let fixes = [
            at(0.0, 0.0, 0.0),
            at(1.0, 1.0, 0.0),
            at(2.0, 40.0, 0.0),
            at(3.0, 3.0, 0.0),
            at(4.0, 4.0, 0.0),
        ];
        assert_eq!(
            receiver_jumps(&fixes, 15.0),
            [false, false, true, false, false]
        );
        // A lone first fix far from the second is judged by that one neighbour.
        assert_eq!(
            receiver_jumps(&[at(0.0, 90.0, 0.0), at(1.0, 0.0, 0.0)], 15.0),
            [true, true]
        );
    }
}
