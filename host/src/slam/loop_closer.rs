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
use crate::scan_match::{
    Candidate, Excluded, FastMatcher, MatchResult, PoseRegion, PreparedReference, Scan,
    ScanMatchError,
};

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

    /// The candidates around `centre` that the alignment of `scan` pulls in from: within the
    /// ICP's first pairing distance, and the turn that moves an end point at the scan's
    /// median range that far.
    fn basin(&self, scan: &Scan, centre: Candidate) -> Excluded {
        let table = self.matcher.table();
        let step_m = f64::from(table.translation_step_px) * self.matcher.raster().resolution_m;
        let basin_m = self.options.icp.stages_m.first().copied().unwrap_or(0.5);
        let mut ranges_m: Vec<f64> = scan
            .points_in_robot()
            .iter()
            .flatten()
            .map(|p| p[0].hypot(p[1]))
            .collect();
        ranges_m.sort_by(f64::total_cmp);
        let median_m = ranges_m
            .get(ranges_m.len() / 2)
            .copied()
            .unwrap_or(1.0)
            .max(1.0);
        let basin_rad = (basin_m / median_m).max(table.rotation_step_rad);
        let half_xy = (basin_m / step_m).ceil() as u32;
        let half_rotation = (basin_rad / table.rotation_step_rad).ceil() as u32;
        Excluded {
            around: centre,
            half_steps: [half_xy, half_xy, half_rotation],
        }
    }

    /// The ambiguity ([`Self::ambiguity_around`]) of the raster search's answer `found` for
    /// `scan` around `guess`: the best candidate outside the basin of `found`
    /// ([`Self::basin`]) against `found`, by the overlap of their drawings.
    fn ambiguity(
        &self,
        reference: &PreparedReference,
        scan: &Scan,
        guess: Pose2,
        found: &MatchResult,
    ) -> f64 {
        let matcher = &self.matcher;
        let overlap = |result: &MatchResult| {
            let drawn = matcher.drawn_px(scan, guess, result.candidate);
            let uncovered = result.score_px.saturating_sub(reference.reference_px());
            f64::from(drawn.saturating_sub(uncovered))
        };
        let best = overlap(found);
        let excluded = self.basin(scan, found.candidate);
        match matcher.match_prepared_outside(reference, scan, guess, excluded) {
            Ok(Some(other)) if best > 0.0 => overlap(&other) / best,
            _ => 0.0,
        }
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
        self.search_distinct_around_guess(
            submap,
            reference_scan,
            scan,
            guess_in_submap,
            None,
            |_| false,
        )
        .map(|(closure, _)| closure)
    }

    /// [`Self::search_around_guess`] over the poses of the window that `region` (in the
    /// submap's frame; `None`: all) holds, and for a closure `worth` the test, its ambiguity
    /// over the whole window: the share of its fit (the overlap of the drawings) that the
    /// best candidate outside its basin reaches, 0 where nothing else fits, 1 where another
    /// pose fits as well, above 1 where one fits better (`None` for a closure not `worth` it).
    /// The second search reuses the first one's raster of the submap.
    pub fn search_distinct_around_guess(
        &self,
        submap: &SlamSubmap,
        reference_scan: &Scan,
        scan: &Scan,
        guess_in_submap: Pose2,
        region: Option<&dyn PoseRegion>,
        worth: impl FnOnce(&LoopClosure) -> bool,
    ) -> Option<(LoopClosure, Option<f64>)> {
        let (reference, submap_from_centre) = self.prepare_around(reference_scan, guess_in_submap);
        let near_beams = self.near_beams(scan);
        let guess_in_centre = submap_from_centre.inverse() * guess_in_submap;
        let found = match region {
            None => self
                .matcher
                .match_prepared(&reference, &near_beams, guess_in_centre)
                .ok()?,
            Some(region) => {
                let in_centre = Shifted {
                    region,
                    by_m: [submap_from_centre.x_m, submap_from_centre.y_m],
                };
                self.matcher
                    .match_prepared_within(&reference, &near_beams, guess_in_centre, &in_centre)
                    .ok()??
            }
        };
        let candidate =
            self.align_from(submap, scan, submap_from_centre * found.reference_from_new)?;
        let closure = self.accept(submap, &candidate)?;
        let ambiguity = worth(&closure)
            .then(|| self.ambiguity(&reference, &near_beams, guess_in_centre, &found));
        Some((closure, ambiguity))
    }

    /// How ambiguous `pose_in_submap` is for `scan` over this searcher's whole window around
    /// it: the raster search over the window, centred on the pose, against the submap's
    /// scans in its frame (`reference_scan`, as in [`Self::search_around_guess`]). It is the
    /// share of the pose's fit (the overlap of the drawings) that the best candidate outside
    /// the pose's basin reaches: 0 where nothing else fits, 1 where another place fits as
    /// well, and infinity where a candidate outside the basin fits best. A ratio test between
    /// the two best hypotheses: a corridor or a row of like rooms fits another pose almost as
    /// well. With the window as wide as the pose is uncertain, a look-alike that is the best
    /// fit only in a narrower window around a wrong estimate is told apart.
    pub fn ambiguity_around(
        &self,
        reference_scan: &Scan,
        scan: &Scan,
        pose_in_submap: Pose2,
    ) -> f64 {
        let (reference, submap_from_centre) = self.prepare_around(reference_scan, pose_in_submap);
        let near_beams = self.near_beams(scan);
        let pose_in_centre = submap_from_centre.inverse() * pose_in_submap;
        let Ok(found) = self
            .matcher
            .match_prepared(&reference, &near_beams, pose_in_centre)
        else {
            return f64::INFINITY;
        };
        let table = self.matcher.table();
        let at_pose = Candidate {
            x_index: table.x_half_steps,
            y_index: table.y_half_steps,
            rotation_index: table.rotation_half_steps,
        };
        if !self.basin(&near_beams, at_pose).contains(found.candidate) {
            return f64::INFINITY;
        }
        self.ambiguity(&reference, &near_beams, pose_in_centre, &found)
    }

    /// The submap's scans in its frame (`reference_scan`) drawn on a raster centred on
    /// `pose_in_submap`'s position, and `submap_from_centre`, that raster's frame.
    fn prepare_around(
        &self,
        reference_scan: &Scan,
        pose_in_submap: Pose2,
    ) -> (PreparedReference, Pose2) {
        let submap_from_centre = Pose2::new(pose_in_submap.x_m, pose_in_submap.y_m, 0.0);
        let centre_from_submap = submap_from_centre.inverse();
        let reference_in_centre = Scan::from_points_in_robot(
            reference_scan
                .points_in_robot()
                .iter()
                .map(|p| p.map(|p| centre_from_submap.transform_point(p)))
                .collect(),
        );
        (
            self.matcher.prepare(&reference_in_centre),
            submap_from_centre,
        )
    }

    /// The beams of `scan` that cannot leave a raster centred on a guess anywhere in the
    /// window (see [`Self::search_around_guess`]).
    fn near_beams(&self, scan: &Scan) -> Scan {
        let options = &self.options;
        let raster_half_m = 0.5 * f64::from(options.raster_side_px) * options.search_resolution_m;
        let max_range_m = raster_half_m - options.search_window_m * std::f64::consts::SQRT_2;
        Scan::from_points_in_robot(
            scan.points_in_robot()
                .iter()
                .map(|p| p.filter(|p| p[0].hypot(p[1]) <= max_range_m))
                .collect(),
        )
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

/// A region of the submap's frame seen from a frame translated by `by_m` in it (a raster
/// centred on a guess).
struct Shifted<'a> {
    region: &'a dyn PoseRegion,
    by_m: [f64; 2],
}

impl PoseRegion for Shifted<'_> {
    fn may_hold(&self, heading_rad: f64, min_m: [f64; 2], max_m: [f64; 2]) -> bool {
        let shift = |p: [f64; 2]| [p[0] + self.by_m[0], p[1] + self.by_m[1]];
        self.region
            .may_hold(heading_rad, shift(min_m), shift(max_m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan_match::synthetic::{cast_front_scan, irregular_room_walls, polygon_walls};
    use crate::slam::{SlamOptions, UncertainClosureOptions};

    /// The scans taken at `poses` among `walls`, in the frame of the first pose (the
    /// identity), as a finished submap gives them.
    fn reference_scan(walls: &[crate::scan_match::synthetic::WallInMap], poses: &[Pose2]) -> Scan {
        let options = SlamOptions::default();
        let mut submap = SlamSubmap::new(Pose2::IDENTITY, 0, options.submap, options.point_map);
        for (node, &pose) in poses.iter().enumerate() {
            submap.insert(node, &cast_front_scan(walls, pose), pose);
        }
        submap.reference_scan().expect("end points kept")
    }

    fn wide_closer() -> LoopCloser {
        LoopCloser::new(UncertainClosureOptions::default().search).expect("valid options")
    }

    #[test]
    fn a_place_no_other_pose_fits_is_not_ambiguous() {
        let walls = irregular_room_walls();
        let poses: Vec<Pose2> = (0..10)
            .map(|i| Pose2::new(-1.0 + 0.2 * f64::from(i), 0.0, 0.1 * f64::from(i)))
            .collect();
        let reference = reference_scan(&walls, &poses);
        let truth = Pose2::new(0.5, 0.3, 0.4);
        let scan = cast_front_scan(&walls, truth);
        let ambiguity = wide_closer().ambiguity_around(&reference, &scan, truth);
        assert!(ambiguity < 0.6, "{ambiguity}");
        // Two metres off, another pose fits better: infinitely ambiguous.
        let off = Pose2::new(2.5, 0.3, 0.4);
        assert_eq!(
            wide_closer().ambiguity_around(&reference, &scan, off),
            f64::INFINITY
        );
    }

    #[test]
    fn a_corridor_that_fits_as_well_further_along_is_ambiguous() {
        // A corridor 2 m wide and 80 m long, seen from near its middle: its ends lie beyond
        // the 20 m range, so the scan fits as well anywhere along it.
        let walls = polygon_walls(&[[-40.0, -1.0], [40.0, -1.0], [40.0, 1.0], [-40.0, 1.0]]);
        let poses: Vec<Pose2> = (0..10)
            .map(|i| Pose2::new(-1.0 + 0.2 * f64::from(i), 0.0, 0.0))
            .collect();
        let reference = reference_scan(&walls, &poses);
        let truth = Pose2::new(0.5, 0.0, 0.0);
        let scan = cast_front_scan(&walls, truth);
        let ambiguity = wide_closer().ambiguity_around(&reference, &scan, truth);
        assert!(ambiguity > 0.9, "{ambiguity}");
    }
}
