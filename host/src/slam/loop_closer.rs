//! Loop closure: finding the current scan in an earlier, finished submap.
//!
//! The exact raster matcher ([`FastMatcher`]) searches a wide window (metres, tens of degrees)
//! around the scan's estimated pose in the submap, drawing the scan over all of the submap's
//! scans; the best candidate is refined on the submap's interpolated grid and accepted when
//! the scan's end points then fall on occupied cells with a mean probability of at least
//! [`LoopClosureOptions::min_probability`]. The wide window is what recovers the drift of
//! local tracking; the probability threshold is what keeps a corridor that merely looks alike
//! from closing a loop it should not.

use super::options::LoopClosureOptions;
use super::slam_submap::SlamSubmap;
use super::window_matcher::window_matcher;
use crate::grid::{ScanRefiner, ScanRefinerOptions};
use crate::scan_match::{FastMatcher, Pose2, Scan, ScanMatchError, ScanMatcher};

/// A scan found in a submap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopClosure {
    /// `submap_from_robot`: the scan's pose in the submap frame.
    pub pose_in_submap: Pose2,
    /// Mean grid probability at the scan's end points.
    pub probability: f64,
}

/// The searcher. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct LoopCloser {
    options: LoopClosureOptions,
    matcher: FastMatcher,
    refiner: ScanRefiner,
}

impl LoopCloser {
    /// A searcher with `options`, refining with `refiner`.
    ///
    /// # Errors
    /// When the options do not make a valid raster or table.
    pub fn new(
        options: LoopClosureOptions,
        refiner: ScanRefinerOptions,
    ) -> Result<Self, ScanMatchError> {
        let matcher = window_matcher(
            options.search_window_m,
            options.search_window_rad,
            options.search_resolution_m,
            options.search_rotation_step_rad,
            options.raster_side_px,
        )?;
        Ok(LoopCloser {
            matcher,
            refiner: ScanRefiner::new(refiner),
            options,
        })
    }

    /// The options in use.
    pub fn options(&self) -> &LoopClosureOptions {
        &self.options
    }

    /// Searches `scan` in `submap` around `guess_in_submap` (`submap_from_robot`), with the
    /// submap's matcher reference `reference` (its scans in its frame). Returns the match
    /// when it is good enough.
    pub fn search(
        &self,
        submap: &SlamSubmap,
        reference: &Scan,
        scan: &Scan,
        guess_in_submap: Pose2,
    ) -> Option<LoopClosure> {
        let grid = submap.interpolated_if_ready()?;
        let found = self
            .matcher
            .match_scans(reference, scan, guess_in_submap)
            .ok()?;
        let refined = self.refiner.refine(scan, grid, found.reference_from_new)?;
        (refined.mean_probability >= self.options.min_probability).then_some(LoopClosure {
            pose_in_submap: refined.grid_from_robot,
            probability: refined.mean_probability,
        })
    }
}
