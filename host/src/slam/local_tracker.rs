//! Local tracking: each scan placed in the `local` frame against the active submap.
//!
//! The motion since the last scan is predicted from the odometry when there is some, else
//! taken to be the last motion again (constant velocity). From the prediction, the scan's end
//! points are aligned by point-to-line ICP ([`super::icp`]) on the older active submap's
//! points. How well a pose fits is judged on the scanned surface rather than on the beams
//! ([`SubmapFit::surface_fraction`]: end points weighted by their range), so that the few
//! beams on a far wall, which fix the pose along a corridor, are not outvoted by the many on
//! the walls close by.
//!
//! If too little of the surface then lies on the submap's surfaces, the prediction was too far
//! off for a local alignment: the exact raster matcher searches a wide window against the last
//! scans, around the prediction and around the last pose, the alignment is run again from
//! what it found and from the last pose, and the candidate with the highest score wins (its
//! [`SubmapFit::tracking_score`]: surface on the submap's surfaces, less a part of the surface
//! that contradicts it, on cells it has seen free or seen through its surfaces; less the
//! motion prior's penalty, below). When even that leaves
//! less than [`LocalTrackingOptions::full_turn_below_surface_fraction`](super::LocalTrackingOptions)
//! of the surface fitting, the robot may have turned further than the window reaches (a turn
//! on the spot that reverses the last one, a turn while driving a metre), and the search runs
//! once more over every heading, around the prediction and around the last pose, against the
//! last scans and against the whole older submap.
//!
//! Every candidate is weighed against the [`MotionPrior`]: its score is its fit less what the
//! prior's uncertainty makes of its distance from the prediction, so a pose tens of degrees or
//! metres from the prediction must fit far better to be taken, and a wide search whose best
//! candidate still scores nothing is refused. When three of the prior's standard deviations
//! reach beyond the wide search's window (with the defaults, always), a search over
//! [`LocalTrackingOptions::far_search_window_m`] follows the wide one, whatever the fit,
//! unless no pose that far from the prediction could pay the prior's penalty. A scan no
//! candidate placed keeps its predicted pose and is flagged lost ([`TrackedScan::lost`]); its
//! constraint to the scan before carries the prior's uncertainty, so that a loop closure can
//! undo it. Tracking then starts afresh from it: the active submaps are finished before a
//! scan whose place in them is unknown can blur them, and a new submap begins with the lost
//! scan, so that the next scans are tracked against a map that agrees with itself, as a
//! SLAM that loses its way starts a new map and joins it to the old one when it recognises
//! a place (the loop closure does the joining).
//!
//! Every alignment is held near the prediction where the submap leaves the pose free
//! ([`PosePrior`], with the motion prior's standard deviations): along a corridor longer than
//! the laser reaches, ICP would otherwise slide by decimetres from one scan to the next, and
//! by metres between scans a metre apart, wherever the clutter pulls it. Where the end points
//! fix the pose, the prior is one weak measurement among hundreds. Scans a laser takes at its
//! full rate lie centimetres apart, and the robot has no time to stop or turn between them
//! ([`MotionPrior::is_short_interval`]); there the prior is as tight as it has learnt to be,
//! and the scan's constraint to the node before is as uncertain along the free direction as
//! the predictions and the moves since ([`TrackedScan::unmeasured_sigma_m`]) rather than by
//! metres.
//!
//! The pose found goes into both active submaps when the [`MotionFilter`] admits the scan (the
//! robot moved or turned enough since the last scan inserted); the older is finished when the
//! newer has received [`SlamOptions::scans_per_submap`] scans.
//!
//! The searches around each guess, and the alignments from what they find, run side by side
//! on the machine's cores (`rayon`) and are taken in the order one after the other would take
//! them, so a scan's pose does not depend on how many cores there are.

use nalgebra::Matrix3;
use rayon::prelude::*;

use super::icp::{PosePrior, align_near};
use super::motion_filter::MotionFilter;
use super::motion_prior::MotionPrior;
use super::options::SlamOptions;
use super::recent_scans::RecentScans;
use super::slam_submap::{SlamSubmap, SubmapFit};
use super::tracking_check::TrackingCheck;
use super::window_matcher::window_matcher;
use crate::geometry::Pose2;
use crate::scan_match::{FastMatcher, PreparedReference, Scan};

/// What tracking made of one scan.
#[derive(Clone, Debug)]
pub struct TrackedScan {
    /// The scan's node number (0, 1, 2, … in the order scans were inserted), or `None` when
    /// the motion filter did not insert it ([`super::motion_filter`]).
    pub node: Option<usize>,
    /// `local_from_robot` at the scan.
    pub pose_in_local: Pose2,
    /// How the scan fits the submap it was aligned on (default for the first scan).
    pub fit: SubmapFit,
    /// What the alignment that placed the scan knows of its pose: ICP's information
    /// ([`IcpMatch::information`](super::icp::IcpMatch)) about a small motion of the robot in
    /// its own frame, `(x_m, y_m, theta_rad)`. `None` when no alignment placed it.
    pub information_in_robot: Option<Matrix3<f64>>,
    /// Whether the wide search ran.
    pub searched: bool,
    /// Whether the wide search ran once more over every heading.
    pub searched_every_heading: bool,
    /// Whether the far search ran ([`LocalTrackingOptions::far_search_window_m`]).
    ///
    /// [`LocalTrackingOptions::far_search_window_m`]: super::LocalTrackingOptions::far_search_window_m
    pub searched_far: bool,
    /// No alignment placed the scan: its pose is the prediction.
    pub lost: bool,
    /// The motion prior's standard deviations at this scan: translation (m), rotation (rad).
    pub prior_sigma: [f64; 2],
    /// For a node: how far its motion from the node before may be wrong in a direction its
    /// alignments could not see (along a corridor), m. There the motion is the predictions'
    /// of the scans since that node and what tracking moved them from their predictions (a
    /// slide the scans did not hold): the root of the sum of the predictions' variances and
    /// the squared moves. A prediction over a short interval
    /// ([`MotionPrior::is_short_interval`], a laser at its full rate) is as uncertain as the
    /// prior; over a longer one, in which a robot may stop or turn, as
    /// [`SlamOptions::degenerate_sigma_m`](super::SlamOptions::degenerate_sigma_m). Zero for a
    /// scan that is not a node.
    pub unmeasured_sigma_m: f64,
    /// How far the other candidate poses that scored nearly as well lie from the chosen one:
    /// their covariance about it in the robot frame, `(x_m, y_m, theta_rad)`, each weighted
    /// by how likely its score makes it (zero when no other candidate came close). Two
    /// headings a corridor junction cannot tell apart give the pose that much uncertainty.
    pub ambiguity_in_robot: Matrix3<f64>,
    /// The chosen pose's share of the likelihood of all candidates (1 when it stood alone,
    /// 0 for a lost scan).
    pub confidence: f64,
    /// The submaps this scan finished, to keep for loop closure: the older active one when
    /// the newer is full, or both when the scan was lost and tracking started afresh.
    pub finished_submaps: Vec<SlamSubmap>,
    /// The motion [`LocalTracker::check_next_motion`] asked to be scored, beside what was
    /// chosen; `None` when none was asked, and for the first scan.
    pub check: Option<TrackingCheck>,
}

/// A scan aligned on the older active submap.
#[derive(Clone, Copy, Debug)]
struct Alignment {
    pose_in_local: Pose2,
    fit: SubmapFit,
    /// The fit's [`SubmapFit::tracking_score`] less the motion prior's penalty.
    score: f64,
    /// See [`TrackedScan::information_in_robot`].
    information_in_robot: Matrix3<f64>,
}

/// The local-tracking state. See the [module documentation](self).
#[derive(Debug)]
pub struct LocalTracker {
    options: SlamOptions,
    /// Older first; at most two.
    active: Vec<SlamSubmap>,
    recent: RecentScans,
    wide_search: FastMatcher,
    /// The wide search's window over every heading.
    full_turn_search: FastMatcher,
    /// The search for scans farther apart than the wide window reaches.
    far_search: FastMatcher,
    prior: MotionPrior,
    filter: MotionFilter,
    last_pose_in_local: Option<Pose2>,
    last_motion: Pose2,
    last_odometry: Option<Pose2>,
    last_time_s: Option<f64>,
    /// Since the last node, summed: the squared errors of the predictions along a direction
    /// no alignment sees, and the squared moves from them ([`TrackedScan::unmeasured_sigma_m`]),
    /// m².
    unmeasured_m2: f64,
    next_node: usize,
    /// The motion the next scan is to be checked at ([`Self::check_next_motion`]).
    motion_to_check: Option<Pose2>,
}

impl LocalTracker {
    /// A tracker with no scan yet.
    ///
    /// # Errors
    /// When the wide-search options do not make a valid raster or table.
    pub fn new(options: SlamOptions) -> Result<Self, crate::scan_match::ScanMatchError> {
        let local = &options.local;
        let wide_search = window_matcher(
            local.search_window_m,
            local.search_window_rad,
            local.search_resolution_m,
            local.search_rotation_step_rad,
            256,
        )?;
        let full_turn_search = window_matcher(
            local.search_window_m,
            std::f64::consts::PI,
            local.search_resolution_m,
            local.search_rotation_step_rad,
            256,
        )?;
        let far_search = window_matcher(
            local.far_search_window_m,
            local.search_window_rad,
            local.far_search_resolution_m,
            local.far_search_rotation_step_rad,
            256,
        )?;
        Ok(LocalTracker {
            wide_search,
            full_turn_search,
            far_search,
            prior: MotionPrior::new(local.motion_prior),
            filter: MotionFilter::new(options.motion_filter),
            recent: RecentScans::new(local.recent_scans),
            active: Vec::new(),
            last_pose_in_local: None,
            last_motion: Pose2::IDENTITY,
            last_odometry: None,
            last_time_s: None,
            unmeasured_m2: 0.0,
            next_node: 0,
            motion_to_check: None,
            options,
        })
    }

    /// Has the next [`Self::track`] score `motion_from_last_scan` (the motion from the last
    /// scan's pose, in its frame: a reference trajectory's) as it scores its candidates, and
    /// report it in [`TrackedScan::check`] ([`super::tracking_check`]).
    pub fn check_next_motion(&mut self, motion_from_last_scan: Pose2) {
        self.motion_to_check = Some(motion_from_last_scan);
    }

    /// Places `scan` (beam end points in the robot frame), taken at `time_s`, in the local
    /// frame; `odometry` is the robot's pose in the odometry frame at the scan, when known.
    pub fn track(&mut self, time_s: f64, scan: &Scan, odometry: Option<Pose2>) -> TrackedScan {
        let odometry_motion = match (self.last_odometry, odometry) {
            (Some(previous), Some(current)) => Some(previous.inverse() * current),
            _ => None,
        };
        self.last_odometry = odometry;
        let motion_to_check = self.motion_to_check.take();
        if let Some(last_time_s) = self.last_time_s.replace(time_s) {
            self.prior.set_interval(time_s - last_time_s);
        }
        let Some(last_pose) = self.last_pose_in_local else {
            let pose = Pose2::IDENTITY;
            let (node, _) = self.accept(time_s, scan, pose, true);
            return TrackedScan {
                node,
                pose_in_local: pose,
                fit: SubmapFit::default(),
                information_in_robot: None,
                searched: false,
                searched_every_heading: false,
                searched_far: false,
                lost: false,
                prior_sigma: self.prior.sigma(),
                unmeasured_sigma_m: 0.0,
                ambiguity_in_robot: Matrix3::zeros(),
                confidence: 1.0,
                finished_submaps: Vec::new(),
                check: None,
            };
        };
        let points: Vec<[f64; 2]> = scan.points_in_robot().iter().flatten().copied().collect();
        let motion = odometry_motion.unwrap_or(self.last_motion);
        let predicted = last_pose * motion;
        let prior_sigma = self.prior.sigma();
        let mut best = self.align(&points, predicted, predicted);
        let mut candidates: Vec<Alignment> = best.into_iter().collect();
        let mut searched = false;
        let mut searched_every_heading = false;
        let mut searched_far = false;
        let local = &self.options.local;
        if best.is_none_or(|a| a.fit.surface_fraction < local.min_surface_fraction) {
            searched = true;
            let reference = self.recent.reference_in(last_pose);
            let mut guesses = vec![last_pose];
            guesses.extend(search_around(
                &self.wide_search,
                &reference,
                scan,
                last_pose,
                motion,
            ));
            self.keep_better(&mut best, &mut candidates, &points, &guesses, predicted);
            // The search over every heading runs on a poor fit, judged before the far search
            // adds its candidates: a far candidate that fits a little better must not keep the
            // right one, a turn beyond the window, from being found.
            let full_turn_floor = local.full_turn_below_surface_fraction;
            let poor_after_wide = best.is_none_or(|a| a.fit.surface_fraction < full_turn_floor);
            // The far search runs whenever three standard deviations of the prior reach beyond
            // the wide window, whatever the fit: along a corridor a pose a whole step short of
            // the truth still fits most of the surface, and only its contradictions (end points
            // on free cells, beams through walls) tell it from the right one. It is skipped
            // only when no pose beyond the window could win: such a pose lies at least the
            // window's half width from the prediction, so even a perfect fit scores no more
            // than 1 less the prior's penalty for that distance.
            let beyond_window = predicted * Pose2::new(local.search_window_m, 0.0, 0.0);
            let best_beyond_window = 1.0 - self.prior.penalty(predicted, beyond_window);
            if 3.0 * prior_sigma[0] > local.search_window_m
                && best.is_none_or(|a| a.score < best_beyond_window)
            {
                searched_far = true;
                let guesses = search_around(&self.far_search, &reference, scan, last_pose, motion);
                self.keep_better(&mut best, &mut candidates, &points, &guesses, predicted);
            }
            if poor_after_wide {
                searched_every_heading = true;
                let guesses = self.full_turn_guesses(&reference, scan, last_pose, motion);
                self.keep_better(&mut best, &mut candidates, &points, &guesses, predicted);
            }
        }
        // Scored before the scan goes into the submap.
        let checked = motion_to_check.map(|motion| {
            let scored = self.active.first().and_then(|submap| {
                let pose_in_submap = submap.pose_in_local().inverse() * (last_pose * motion);
                self.score_pose(&points, pose_in_submap, predicted)
            });
            (motion, scored)
        });
        let best_score = best.map(|a| a.score);
        // A candidate the prior makes less likely than its fit makes it right is refused.
        let best = best.filter(|a| a.score > 0.0);
        let lost = best.is_none();
        let (ambiguity_in_robot, confidence) = match best {
            Some(best) => ambiguity(&best, &candidates, local.motion_prior.fit_measurements),
            None => (Matrix3::zeros(), 0.0),
        };
        let (pose, fit, information_in_robot) = match best {
            Some(aligned) => {
                self.prior.learn(predicted, aligned.pose_in_local);
                (
                    aligned.pose_in_local,
                    aligned.fit,
                    Some(aligned.information_in_robot),
                )
            }
            None => (predicted, SubmapFit::default(), None),
        };
        // A scan local tracking had to search for is inserted whatever its motion: its pose
        // is the less certain, and a loop closure may need it as a node.
        let (node, finished_submaps) = if lost {
            self.restart(time_s, scan, pose)
        } else {
            self.accept(time_s, scan, pose, searched)
        };
        self.last_motion = last_pose.inverse() * pose;
        let moved = predicted.inverse() * pose;
        let predicted_error_m = if self.prior.is_short_interval() {
            prior_sigma[0]
        } else {
            self.options.degenerate_sigma_m
        };
        self.unmeasured_m2 += predicted_error_m.powi(2) + moved.x_m.powi(2) + moved.y_m.powi(2);
        let unmeasured_sigma_m = if node.is_some() {
            std::mem::take(&mut self.unmeasured_m2).sqrt()
        } else {
            0.0
        };
        TrackedScan {
            node,
            pose_in_local: pose,
            fit,
            information_in_robot,
            searched,
            searched_every_heading,
            searched_far,
            lost,
            prior_sigma,
            unmeasured_sigma_m,
            ambiguity_in_robot,
            confidence,
            finished_submaps,
            check: checked.map(|(checked_motion, scored)| TrackingCheck {
                chosen_motion: last_pose.inverse() * pose,
                best_score,
                checked_motion,
                checked_fit: scored.map(|(fit, _)| fit),
                checked_score: scored.map(|(_, score)| score),
            }),
        }
    }

    /// The submaps being built, older first.
    pub fn active_submaps(&self) -> &[SlamSubmap] {
        &self.active
    }

    /// Aligns `points` (robot frame) on the older active submap from `guess_in_local`, and
    /// scores the result against the prior around `predicted`.
    fn align(
        &self,
        points: &[[f64; 2]],
        guess_in_local: Pose2,
        predicted: Pose2,
    ) -> Option<Alignment> {
        let submap = self.active.first()?;
        let submap_in_local = submap.pose_in_local();
        let guess = submap_in_local.inverse() * guess_in_local;
        let icp = &self.options.local.icp;
        // Held near the prediction, as far as the prior knows it, where the submap leaves the
        // pose free (along a corridor).
        let prior = PosePrior {
            mean: submap_in_local.inverse() * predicted,
            sigma: self.prior.sigma(),
        };
        let found = align_near(submap.points(), points, guess, icp, Some(&prior))?;
        let (fit, score) = self.score_pose(points, found.map_from_robot, predicted)?;
        let pose_in_local = submap_in_local * found.map_from_robot;
        Some(Alignment {
            pose_in_local,
            fit,
            score,
            information_in_robot: found.information_in_robot(),
        })
    }

    /// Aligns `points` from each of `guesses_in_local` (side by side), adds the results to
    /// `candidates` in the guesses' order, and keeps in `best` each that scores higher (its
    /// [`SubmapFit::tracking_score`] less the prior's penalty for its distance from
    /// `predicted`), as aligning them one after the other would.
    fn keep_better(
        &self,
        best: &mut Option<Alignment>,
        candidates: &mut Vec<Alignment>,
        points: &[[f64; 2]],
        guesses_in_local: &[Pose2],
        predicted: Pose2,
    ) {
        let aligned: Vec<Option<Alignment>> = guesses_in_local
            .par_iter()
            .map(|&guess| self.align(points, guess, predicted))
            .collect();
        for candidate in aligned.into_iter().flatten() {
            candidates.push(candidate);
            if best.is_none_or(|b| candidate.score > b.score) {
                *best = Some(candidate);
            }
        }
    }

    /// How `points` (robot frame) fit the older active submap at `pose_in_submap`, and the
    /// score of a candidate there: its [`SubmapFit::tracking_score`] less the motion prior's
    /// penalty for its distance from `predicted` (local frame). `None` without an active
    /// submap.
    fn score_pose(
        &self,
        points: &[[f64; 2]],
        pose_in_submap: Pose2,
        predicted: Pose2,
    ) -> Option<(SubmapFit, f64)> {
        let submap = self.active.first()?;
        let fit = submap.tracking_fit(points, pose_in_submap, self.options.local.icp.inlier_m);
        let pose_in_local = submap.pose_in_local() * pose_in_submap;
        let score = fit.tracking_score(self.options.local.free_weight)
            - self.prior.penalty(predicted, pose_in_local);
        Some((fit, score))
    }

    /// Poses in the local frame found by the search over every heading, around the predicted
    /// `motion` and around standing still at `last_pose`: against the last scans
    /// (`recent_reference`, in the frame of `last_pose`), and against every scan of the older
    /// active submap, which has seen more of the place.
    fn full_turn_guesses(
        &self,
        recent_reference: &Scan,
        scan: &Scan,
        last_pose: Pose2,
        motion: Pose2,
    ) -> Vec<Pose2> {
        let recent = self.full_turn_search.prepare(recent_reference);
        let submap = self
            .active
            .first()
            .and_then(|submap| Some((submap.pose_in_local(), submap.reference_scan()?)));
        let submap_reference = submap
            .as_ref()
            .map(|(_, reference_scan)| self.full_turn_search.prepare(reference_scan));
        // Each search's frame in the local frame, and the search.
        let mut searches = vec![
            (last_pose, (&recent, motion)),
            (last_pose, (&recent, Pose2::IDENTITY)),
        ];
        if let (Some((submap_in_local, _)), Some(submap_reference)) = (submap, &submap_reference) {
            for guess in [motion, Pose2::IDENTITY] {
                let guess_in_submap = submap_in_local.inverse() * last_pose * guess;
                searches.push((submap_in_local, (submap_reference, guess_in_submap)));
            }
        }
        let (frames, searches): (Vec<Pose2>, Vec<_>) = searches.into_iter().unzip();
        search_each(&self.full_turn_search, scan, &searches)
            .into_iter()
            .zip(frames)
            .filter_map(|(found, frame_in_local)| Some(frame_in_local * found?))
            .collect()
    }

    /// Starts afresh from a lost `scan` at its predicted `pose`: the active submaps are
    /// finished, so that a scan whose place in them is unknown does not blur them, and a new
    /// one begins with this scan; the last scans, the wide search's reference, are forgotten.
    /// The next scans are tracked against this one, and the loop closure relates the new
    /// submap to the old ones once it finds where it lies. Returns the scan's node number and
    /// the submaps finished.
    fn restart(
        &mut self,
        time_s: f64,
        scan: &Scan,
        pose: Pose2,
    ) -> (Option<usize>, Vec<SlamSubmap>) {
        // A submap holding only the lost scan it was started from is no map: dropped.
        let mut finished: Vec<SlamSubmap> = std::mem::take(&mut self.active)
            .into_iter()
            .filter(|submap| submap.num_scans() > 1)
            .collect();
        for submap in &mut finished {
            submap.finish();
        }
        self.recent.clear();
        // With no active submap, the scan starts one.
        let (node, _) = self.accept(time_s, scan, pose, true);
        (node, finished)
    }

    /// Takes the scan taken at `time_s` as at `pose`: inserts it when `always` or when the
    /// motion filter admits it, and starts and finishes submaps as due. Returns its node
    /// number when it was inserted, and the submap it finished.
    fn accept(
        &mut self,
        time_s: f64,
        scan: &Scan,
        pose: Pose2,
        always: bool,
    ) -> (Option<usize>, Vec<SlamSubmap>) {
        self.last_pose_in_local = Some(pose);
        if !self.filter.admits(time_s, pose, always) {
            return (None, Vec::new());
        }
        let node = self.next_node;
        self.next_node += 1;
        if self.active.is_empty() {
            self.active.push(SlamSubmap::new(
                pose,
                node,
                self.options.submap,
                self.options.point_map,
            ));
        }
        for submap in &mut self.active {
            submap.insert(node, scan, pose);
        }
        let newest_full = self
            .active
            .last()
            .is_some_and(|s| s.num_scans() >= self.options.scans_per_submap);
        let mut finished = Vec::new();
        if newest_full {
            let mut next = SlamSubmap::new(pose, node, self.options.submap, self.options.point_map);
            next.insert(node, scan, pose);
            self.active.push(next);
            if self.active.len() > 2 {
                let mut old = self.active.remove(0);
                old.finish();
                finished.push(old);
            }
        }
        self.recent.push(pose, scan.clone());
        (Some(node), finished)
    }

    /// Finishes and returns the active submaps (at the end of a run).
    pub fn finish(&mut self) -> Vec<SlamSubmap> {
        let mut submaps = std::mem::take(&mut self.active);
        for submap in &mut submaps {
            submap.finish();
        }
        submaps
    }
}

/// The poses in the local frame `matcher` finds for `scan` against `reference` (the last
/// scans, in the frame of `last_pose`), searched around the predicted `motion` and around
/// standing still: a robot that stops turning or driving leaves the prediction a whole step
/// off.
fn search_around(
    matcher: &FastMatcher,
    reference: &Scan,
    scan: &Scan,
    last_pose: Pose2,
    motion: Pose2,
) -> Vec<Pose2> {
    let prepared = matcher.prepare(reference);
    let searches = [(&prepared, motion), (&prepared, Pose2::IDENTITY)];
    search_each(matcher, scan, &searches)
        .into_iter()
        .flatten()
        .map(|found| last_pose * found)
        .collect()
}

/// The pose `matcher` finds for `scan` in each search (a prepared reference and the guess,
/// both in the reference's frame), side by side; `None` where a search finds none.
fn search_each(
    matcher: &FastMatcher,
    scan: &Scan,
    searches: &[(&PreparedReference, Pose2)],
) -> Vec<Option<Pose2>> {
    searches
        .par_iter()
        .map(|&(reference, guess)| {
            let found = matcher.match_prepared(reference, scan, guess).ok()?;
            Some(found.reference_from_new)
        })
        .collect()
}

/// The covariance about `best` (in its robot frame) of the `candidates` whose score comes
/// near its own, and `best`'s share of their likelihood.
///
/// A score is a log-likelihood over `fit_measurements` ([`MotionPriorOptions::fit_measurements`](
/// super::MotionPriorOptions::fit_measurements)), so a candidate weighs
/// `exp(fit_measurements · (score − best score))` against the best; candidates that converged
/// to one pose count once.
fn ambiguity(
    best: &Alignment,
    candidates: &[Alignment],
    fit_measurements: f64,
) -> (Matrix3<f64>, f64) {
    // Within a centimetre and a tenth of a degree: one pose.
    let same = |d: Pose2| d.x_m.hypot(d.y_m) < 0.01 && d.theta_rad.abs() < 0.1f64.to_radians();
    let mut distinct: Vec<&Alignment> = Vec::new();
    for candidate in candidates {
        if !distinct
            .iter()
            .any(|kept| same(kept.pose_in_local.inverse() * candidate.pose_in_local))
        {
            distinct.push(candidate);
        }
    }
    let (mut covariance, mut total_weight) = (Matrix3::zeros(), 0.0);
    let mut best_weight = 0.0;
    for candidate in distinct {
        let weight = (fit_measurements * (candidate.score - best.score)).exp();
        let d = best.pose_in_local.inverse() * candidate.pose_in_local;
        let offset = nalgebra::Vector3::new(d.x_m, d.y_m, d.theta_rad);
        covariance += weight * offset * offset.transpose();
        total_weight += weight;
        if same(d) {
            best_weight += weight;
        }
    }
    if total_weight > 0.0 {
        (covariance / total_weight, best_weight / total_weight)
    } else {
        (Matrix3::zeros(), 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan_match::synthetic::{cast_front_scan, irregular_room_walls};

    fn room_scan(pose: Pose2) -> Scan {
        cast_front_scan(&irregular_room_walls(), pose)
    }

    fn tracked_heading_deg(options: SlamOptions, headings_deg: &[f64]) -> f64 {
        let mut tracker = LocalTracker::new(options).unwrap();
        let mut last = Pose2::IDENTITY;
        for heading in headings_deg {
            let scan = room_scan(Pose2::new(0.3, -0.2, heading.to_radians()));
            last = tracker.track(0.0, &scan, None).pose_in_local;
        }
        last.theta_rad.to_degrees()
    }

    #[test]
    fn a_scan_of_another_place_is_flagged_lost_and_keeps_the_prediction() {
        let mut tracker = LocalTracker::new(SlamOptions::default()).unwrap();
        let step = Pose2::new(0.1, 0.0, 0.0);
        let mut truth = Pose2::new(0.3, -0.2, 0.0);
        let mut last = None;
        for _ in 0..5 {
            let tracked = tracker.track(0.0, &room_scan(truth), None);
            assert!(!tracked.lost);
            assert!(tracked.confidence > 0.0);
            last = Some(tracked.pose_in_local);
            truth = truth * step;
        }
        let last = last.expect("tracked");
        // A hall 60 m across that the room's submap has seen nothing of: no candidate fits.
        let hall = crate::scan_match::synthetic::polygon_walls(&[
            [-30.0, -30.0],
            [30.0, -30.0],
            [30.0, 30.0],
            [-30.0, 30.0],
        ]);
        let elsewhere = cast_front_scan(&hall, Pose2::new(0.0, 0.0, 0.4));
        let tracked = tracker.track(0.0, &elsewhere, None);
        assert!(tracked.lost, "{:?}", tracked.fit);
        assert_eq!(tracked.confidence, 0.0);
        // The prediction: the last step repeated.
        let predicted = last * step;
        let error = predicted.inverse() * tracked.pose_in_local;
        assert!(error.x_m.hypot(error.y_m) < 0.02, "{error:?}");
        assert!(tracked.information_in_robot.is_none());
    }

    #[test]
    fn scans_close_in_time_leave_a_node_centimetres_loose_and_scans_far_apart_metres() {
        // The same 3 m drive in 2.7 cm steps, stamped at a laser's 37.5 Hz and a second apart.
        let options = SlamOptions::default();
        let step = Pose2::new(0.027, 0.0, 0.0);
        let drive = |interval_s: f64| {
            let mut tracker = LocalTracker::new(options.clone()).unwrap();
            let mut truth = Pose2::new(-2.0, -0.2, 0.0);
            let mut nodes = Vec::new();
            for k in 0..111 {
                let tracked = tracker.track(f64::from(k) * interval_s, &room_scan(truth), None);
                assert!(!tracked.lost);
                if tracked.node.is_some() {
                    let moved_m = f64::from(k) * step.x_m;
                    let error_m =
                        (tracked.pose_in_local.x_m - moved_m).hypot(tracked.pose_in_local.y_m);
                    nodes.push((tracked.unmeasured_sigma_m, error_m));
                }
                truth = truth * step;
            }
            nodes
        };
        let close = drive(1.0 / 37.5);
        // One node every 0.2 m or so; once the prior has learnt the steady motion, a node's
        // constraint is as loose as its scans' predictions (3.3 cm each at the floor).
        assert!(close.len() > 10, "{}", close.len());
        let (last_sigma_m, last_error_m) = close[close.len() - 1];
        assert!(last_sigma_m < 0.15, "{last_sigma_m}");
        assert!(last_error_m < 0.05, "{last_error_m}");
        // A second apart, a robot may stop or turn between scans: as loose as before.
        for (sigma_m, _) in drive(1.0).into_iter().skip(1) {
            assert!(sigma_m >= options.degenerate_sigma_m, "{sigma_m}");
        }
    }

    #[test]
    fn tracking_starts_afresh_after_a_lost_scan() {
        // Every scan inserted, 0.1 m apart.
        let mut options = SlamOptions::default();
        options.motion_filter.enabled = false;
        let mut tracker = LocalTracker::new(options).unwrap();
        let step = Pose2::new(0.1, 0.0, 0.0);
        let mut truth = Pose2::new(0.3, -0.2, 0.0);
        for _ in 0..5 {
            assert!(!tracker.track(0.0, &room_scan(truth), None).lost);
            truth = truth * step;
        }
        // Into a hall the room's submap has seen nothing of.
        let hall = crate::scan_match::synthetic::polygon_walls(&[
            [-30.0, -30.0],
            [22.0, -30.0],
            [30.0, 10.0],
            [-30.0, 30.0],
        ]);
        let in_hall = |x_m: f64| {
            cast_front_scan(&hall, Pose2::new(0.0, 0.0, 0.4) * Pose2::new(x_m, 0.0, 0.0))
        };
        let lost = tracker.track(0.0, &in_hall(0.0), None);
        assert!(lost.lost);
        // The room's submap is finished as it was, without the lost scan.
        assert_eq!(lost.finished_submaps.len(), 1);
        assert_eq!(lost.finished_submaps[0].num_scans(), 5);
        assert_eq!(tracker.active_submaps().len(), 1);
        assert_eq!(tracker.active_submaps()[0].num_scans(), 1);
        // The next scans of the hall are tracked against the lost one: 0.1 m a step, as the
        // robot moves (the prediction after the lost scan repeats the room's last step).
        let mut last = lost.pose_in_local;
        for x_m in [0.1, 0.2, 0.3] {
            let tracked = tracker.track(0.0, &in_hall(x_m), None);
            assert!(!tracked.lost, "{:?}", tracked.fit);
            let moved = last.inverse() * tracked.pose_in_local;
            assert!((moved.x_m - 0.1).abs() < 0.02, "{moved:?}");
            assert!(
                moved.y_m.abs() < 0.02 && moved.theta_rad.abs() < 0.01,
                "{moved:?}"
            );
            last = tracked.pose_in_local;
        }
    }

    #[test]
    fn a_step_of_metres_after_standing_still_is_found_along_a_corridor() {
        // A corridor 2 m wide with a door recess on either side, closed 12 m ahead. The robot
        // drives, stands still, then drives 2 m between two scans: twice the wide search's
        // reach from both the prediction (standing still) and the last pose. The far search
        // runs although the pose the wide search finds fits most of the surface, and finds
        // the step. (With the one recess only, the raster's pixel count prefers standing
        // still by a handful of pixels; the alignment is held near the prediction, so the
        // step must come from the search.)
        let walls = crate::scan_match::synthetic::polygon_walls(&[
            [-1.0, -1.0],
            [4.0, -1.0],
            [4.0, -1.6],
            [5.0, -1.6],
            [5.0, -1.0],
            [12.0, -1.0],
            [12.0, 1.0],
            [7.0, 1.0],
            [7.0, 1.6],
            [6.0, 1.6],
            [6.0, 1.0],
            [-1.0, 1.0],
        ]);
        let mut tracker = LocalTracker::new(SlamOptions::default()).unwrap();
        let mut tracked = None;
        for x_m in [0.0, 0.3, 0.6, 0.6, 0.6, 0.6, 2.6] {
            let scan = cast_front_scan(&walls, Pose2::new(x_m, 0.0, 0.0));
            tracked = Some(tracker.track(0.0, &scan, None));
        }
        let tracked = tracked.expect("tracked");
        assert!(tracked.searched_far, "{tracked:?}");
        let pose = tracked.pose_in_local;
        assert!(
            (pose.x_m - 2.6).abs() < 0.1 && pose.y_m.abs() < 0.1,
            "{pose:?}"
        );
    }

    #[test]
    fn a_turn_back_beyond_the_search_window_is_found() {
        // A turn of -30° and then one of +62° on the spot: the second lies outside the
        // ±45° window around both the repeated motion and standing still.
        let headings_deg = [0.0, -30.0, 32.0];
        let found = tracked_heading_deg(SlamOptions::default(), &headings_deg);
        assert!((found - 32.0).abs() < 0.5, "{found}°");

        let mut without = SlamOptions::default();
        without.local.full_turn_below_surface_fraction = 0.0;
        let lost = tracked_heading_deg(without, &headings_deg);
        assert!((lost - 32.0).abs() > 5.0, "{lost}°");
    }
}
