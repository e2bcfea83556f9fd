//! Loop closure: finding the current scan in an earlier, finished submap.
//!
//! The exact raster matcher ([`FastMatcher`]) searches a wide window (metres, tens of degrees)
//! around the scan's estimated pose in the submap, drawing the scan over all of the submap's
//! scans; the best candidate is aligned by point-to-line ICP on the submap's points and
//! accepted when at least [`LoopClosureOptions::min_inlier_fraction`] of the scan's end points
//! then lie on the submap's surfaces, at most [`LoopClosureOptions::max_free_fraction`] on
//! cells it has seen free, and they fall on occupied cells of its grid with a mean probability
//! of at least [`LoopClosureOptions::min_probability`]. The wide window is what
//! recovers the drift of local tracking; the two thresholds are what keep a corridor that
//! merely looks alike from closing a loop it should not.

use nalgebra::Matrix3;

use super::icp::align;
use super::options::LoopClosureOptions;
use super::slam_submap::{SlamSubmap, SubmapFit};
use super::window_matcher::window_matcher;
use crate::scan_match::{FastMatcher, Pose2, PreparedReference, Scan, ScanMatchError};

/// A scan found in a submap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopClosure {
    /// `submap_from_robot`: the scan's pose in the submap frame.
    pub pose_in_submap: Pose2,
    /// How the scan fits the submap there.
    pub fit: SubmapFit,
    /// What the alignment knows of the pose, about a motion of the robot in its own frame
    /// ([`IcpMatch::information_in_robot`](super::icp::IcpMatch::information_in_robot)).
    pub information_in_robot: Matrix3<f64>,
}

/// The searcher. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct LoopCloser {
    options: LoopClosureOptions,
    matcher: FastMatcher,
}

impl LoopCloser {
    /// A searcher with `options`.
    ///
    /// # Errors
    /// When the options do not make a valid raster or table.
    pub fn new(options: LoopClosureOptions) -> Result<Self, ScanMatchError> {
        let matcher = window_matcher(
            options.search_window_m,
            options.search_window_rad,
            options.search_resolution_m,
            options.search_rotation_step_rad,
            options.raster_side_px,
        )?;
        Ok(LoopCloser { matcher, options })
    }

    /// The options in use.
    pub fn options(&self) -> &LoopClosureOptions {
        &self.options
    }

    /// The matcher reference of a submap whose scans in its frame are `reference_scan`
    /// ([`SlamSubmap::reference_scan`]), for [`Self::search`].
    pub fn prepare(&self, reference_scan: &Scan) -> PreparedReference {
        self.matcher.prepare(reference_scan)
    }

    /// Searches `scan` in `submap` around `guess_in_submap` (`submap_from_robot`), with the
    /// submap's matcher reference `reference` ([`Self::prepare`]). Returns the match when it
    /// is good enough.
    pub fn search(
        &self,
        submap: &SlamSubmap,
        reference: &PreparedReference,
        scan: &Scan,
        guess_in_submap: Pose2,
    ) -> Option<LoopClosure> {
        let found = self
            .matcher
            .match_prepared(reference, scan, guess_in_submap)
            .ok()?;
        let points: Vec<[f64; 2]> = scan.points_in_robot().iter().flatten().copied().collect();
        let icp = &self.options.icp;
        let aligned = align(submap.points(), &points, found.reference_from_new, icp)?;
        let fit = submap.fit(&points, aligned.map_from_robot, icp.inlier_m);
        self.options.accepts(&fit).then(|| LoopClosure {
            pose_in_submap: aligned.map_from_robot,
            fit,
            information_in_robot: aligned.information_in_robot(),
        })
    }
}
