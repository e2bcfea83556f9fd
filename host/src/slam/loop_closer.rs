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
use crate::geometry::Pose2;
use crate::grid::Occupancy;
use crate::scan_match::{FastMatcher, PreparedReference, Scan, ScanMatchError};

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

/// A scan aligned in a submap, whose end points lie on the submap's surfaces often enough to
/// be accepted, before the rest of the test ([`LoopCloser::accept`]).
#[derive(Clone, Debug)]
pub struct AlignedCandidate {
    /// The scan's end points, robot frame.
    points_in_robot: Vec<[f64; 2]>,
    /// `submap_from_robot` after alignment.
    pose_in_submap: Pose2,
    /// What the alignment knows of the pose ([`LoopClosure::information_in_robot`]).
    information_in_robot: Matrix3<f64>,
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
        let candidate = self.align(submap, reference, scan, guess_in_submap)?;
        self.accept(submap, &candidate)
    }

    /// The first part of [`Self::search`], which needs only the submap's end points: the
    /// raster search and the alignment. `None` when the search finds nothing, or when too few
    /// end points lie on the submap's surfaces for [`Self::accept`] to take it.
    pub fn align(
        &self,
        submap: &SlamSubmap,
        reference: &PreparedReference,
        scan: &Scan,
        guess_in_submap: Pose2,
    ) -> Option<AlignedCandidate> {
        let found = self
            .matcher
            .match_prepared(reference, scan, guess_in_submap)
            .ok()?;
        self.align_from(submap, scan, found.reference_from_new)
    }

    /// [`Self::search`] over a window too wide for a raster centred on the submap's frame
    /// (the uncertain closer's, [`UncertainClosureOptions`](super::UncertainClosureOptions)):
    /// the submap's scans in its frame (`reference_scan`, as [`SlamSubmap::reference_scan`]
    /// gives them) are drawn on a raster centred on the guess, prepared for this search
    /// alone. The raster matcher does not count what falls off its raster, so a scan pushed
    /// to the edge of a wide window would shed its beams there for free; the beams that could
    /// leave the raster anywhere in the window are left out of the raster search (the
    /// alignment and the acceptance test use every beam).
    pub fn search_around_guess(
        &self,
        submap: &SlamSubmap,
        reference_scan: &Scan,
        scan: &Scan,
        guess_in_submap: Pose2,
    ) -> Option<LoopClosure> {
        let submap_from_centre = Pose2::new(guess_in_submap.x_m, guess_in_submap.y_m, 0.0);
        let centre_from_submap = submap_from_centre.inverse();
        let reference_in_centre = Scan::from_points_in_robot(
            reference_scan
                .points_in_robot()
                .iter()
                .map(|p| p.map(|p| centre_from_submap.transform_point(p)))
                .collect(),
        );
        let reference = self.matcher.prepare(&reference_in_centre);
        let options = &self.options;
        let raster_half_m = 0.5 * f64::from(options.raster_side_px) * options.search_resolution_m;
        let max_range_m = raster_half_m - options.search_window_m * std::f64::consts::SQRT_2;
        let near_beams = Scan::from_points_in_robot(
            scan.points_in_robot()
                .iter()
                .map(|p| p.filter(|p| p[0].hypot(p[1]) <= max_range_m))
                .collect(),
        );
        let found = self
            .matcher
            .match_prepared(
                &reference,
                &near_beams,
                centre_from_submap * guess_in_submap,
            )
            .ok()?;
        let candidate =
            self.align_from(submap, scan, submap_from_centre * found.reference_from_new)?;
        self.accept(submap, &candidate)
    }

    /// [`Self::search`] without the raster search: `scan` aligned on the submap's points from
    /// `start_in_submap` alone, and tested. For a pose already known to within the alignment's
    /// reach (a closure's prediction carried through local tracking).
    pub fn search_from(
        &self,
        submap: &SlamSubmap,
        scan: &Scan,
        start_in_submap: Pose2,
    ) -> Option<LoopClosure> {
        let candidate = self.align_from(submap, scan, start_in_submap)?;
        self.accept(submap, &candidate)
    }

    /// Aligns `scan` on the submap's points from `start_in_submap` (`submap_from_robot`);
    /// `None` when the alignment fails or leaves too few end points on the submap's surfaces
    /// for [`Self::accept`] to take it.
    fn align_from(
        &self,
        submap: &SlamSubmap,
        scan: &Scan,
        start_in_submap: Pose2,
    ) -> Option<AlignedCandidate> {
        let points: Vec<[f64; 2]> = scan.points_in_robot().iter().flatten().copied().collect();
        let icp = &self.options.icp;
        let aligned = align(submap.points(), &points, start_in_submap, icp)?;
        let inlier_fraction = submap.inlier_fraction(&points, aligned.map_from_robot, icp.inlier_m);
        (inlier_fraction >= self.options.min_inlier_fraction).then(|| AlignedCandidate {
            points_in_robot: points,
            pose_in_submap: aligned.map_from_robot,
            information_in_robot: aligned.information_in_robot(),
        })
    }

    /// The rest of [`Self::search`]: the whole acceptance test of `candidate`, found by
    /// [`Self::align`] in `submap`, whose grid it reads.
    pub fn accept(&self, submap: &SlamSubmap, candidate: &AlignedCandidate) -> Option<LoopClosure> {
        self.accept_on(submap, submap.grid(), candidate)
    }

    /// [`Self::accept`] with the submap's occupancy read from `occupancy`
    /// ([`SlamSubmap::fit_on`]).
    pub fn accept_on(
        &self,
        submap: &SlamSubmap,
        occupancy: &impl Occupancy,
        candidate: &AlignedCandidate,
    ) -> Option<LoopClosure> {
        let fit = submap.fit_on(
            occupancy,
            &candidate.points_in_robot,
            candidate.pose_in_submap,
            self.options.icp.inlier_m,
        );
        self.options.accepts(&fit).then_some(LoopClosure {
            pose_in_submap: candidate.pose_in_submap,
            fit,
            information_in_robot: candidate.information_in_robot,
        })
    }
}
