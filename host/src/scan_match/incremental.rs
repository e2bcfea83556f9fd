//! Incremental matching: the new robot pose from the previous one and a scan match.
//!
//! Frames: `map` is the frame the poses live in, `robot` has x forward, y left and angles
//! counter-clockwise. The reference scan was taken at `previous_pose_in_map` (its
//! `map_from_robot`), the new scan at the unknown new pose. The matcher finds
//! `M = reference_from_new`, the new robot frame seen from the reference robot frame, and the new
//! pose is `P_new = P_old * M`.

use super::pose::Pose2;
use super::scan::Scan;
use super::search::{MatchResult, ScanMatchError, ScanMatcher};

/// The outcome of [`match_incremental`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IncrementalMatch {
    /// The new robot pose, `map_from_robot` at the new scan: `previous_pose_in_map * M`.
    pub pose_in_map: Pose2,
    /// The match itself; `result.reference_from_new` is `M`.
    pub result: MatchResult,
}

/// Aligns `new_scan` with `reference_scan` (taken at `previous_pose_in_map`) using `matcher`,
/// searching its table around `initial_reference_from_new` (the motion since the reference
/// scan, e.g. from odometry; [`Pose2::IDENTITY`] when unknown), and returns the new pose.
///
/// # Errors
///
/// Whatever `matcher` returns, e.g. [`ScanMatchError::NonFiniteGuess`].
pub fn match_incremental(
    matcher: &impl ScanMatcher,
    previous_pose_in_map: Pose2,
    reference_scan: &Scan,
    new_scan: &Scan,
    initial_reference_from_new: Pose2,
) -> Result<IncrementalMatch, ScanMatchError> {
    let result = matcher.match_scans(reference_scan, new_scan, initial_reference_from_new)?;
    Ok(IncrementalMatch {
        pose_in_map: previous_pose_in_map * result.reference_from_new,
        result,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan_match::search::{RasterOptions, SearchTable};
    use crate::scan_match::synthetic::{cast_scan, polygon_walls};
    use crate::scan_match::{FastMatcher, ReferenceMatcher};

    #[test]
    fn test_tracks_a_move_in_a_room() {
        let walls = polygon_walls(&[
            [-3.05, -2.05],
            [4.05, -2.05],
            [4.05, 3.05],
            [1.0, 3.05],
            [-3.05, 1.0],
        ]);
        let previous_pose_in_map = Pose2::new(0.2, -0.1, 0.3);
        // Moved 0.2 m forward, 0.1 m left and turned 1 degree left.
        let true_reference_from_new = Pose2::new(0.2, 0.1, 1f64.to_radians());
        let new_pose_in_map = previous_pose_in_map * true_reference_from_new;
        let beams = |pose| {
            cast_scan(
                &walls,
                pose,
                -std::f64::consts::FRAC_PI_2,
                0.5f64.to_radians(),
                361,
                8.0,
            )
        };
        let reference_scan = beams(previous_pose_in_map);
        let new_scan = beams(new_pose_in_map);

        let raster = RasterOptions {
            resolution_m: 0.1,
            width_px: 128,
            height_px: 128,
            max_gap_m: 0.5,
        };
        let table = SearchTable {
            x_half_steps: 4,
            y_half_steps: 4,
            translation_step_px: 1,
            rotation_half_steps: 3,
            rotation_step_rad: 0.5f64.to_radians(),
        };
        let fast = FastMatcher::new(raster, table).unwrap();
        let reference = ReferenceMatcher::new(raster, table).unwrap();
        let fast_match = match_incremental(
            &fast,
            previous_pose_in_map,
            &reference_scan,
            &new_scan,
            Pose2::IDENTITY,
        )
        .unwrap();
        let reference_match = match_incremental(
            &reference,
            previous_pose_in_map,
            &reference_scan,
            &new_scan,
            Pose2::IDENTITY,
        )
        .unwrap();
        assert_eq!(
            fast_match,
            IncrementalMatch {
                result: MatchResult {
                    candidates_evaluated: fast_match.result.candidates_evaluated,
                    ..reference_match.result
                },
                ..reference_match
            }
        );

        let estimate = fast_match.pose_in_map;
        assert!(
            (estimate.x_m - new_pose_in_map.x_m).abs() < 0.15,
            "{estimate:?} vs {new_pose_in_map:?}"
        );
        assert!(
            (estimate.y_m - new_pose_in_map.y_m).abs() < 0.15,
            "{estimate:?} vs {new_pose_in_map:?}"
        );
        assert!(
            (estimate.theta_rad - new_pose_in_map.theta_rad).abs() < 0.02,
            "{estimate:?} vs {new_pose_in_map:?}"
        );
    }
}
