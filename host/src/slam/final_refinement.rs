//! The final refinement: every scan aligned on the finished submaps near it, as its place
//! settles or at the end of the run.
//!
//! During the run, loop closure searches only every few scans, and a scan is tied to the
//! submaps it went into only through the chain of consecutive-scan constraints. Once the run
//! is over and the graph optimised (every node free again, [`super::settled_submaps`]),
//! every scan not aligned during the run (below) is aligned by point-to-line ICP on the
//! finished submaps it did not go into whose frames lie within
//! [`RefinementOptions::max_distance_m`] (the nearest few, see below), starting from their
//! relative pose in the graph. An alignment that moves the scan by at most
//! [`RefinementOptions::max_correction_m`] and
//! [`RefinementOptions::max_correction_rad`] and passes the loop closure's acceptance test
//! becomes a constraint like a loop closure's, and the graph is optimised once more. Every
//! place seen again is then tied to the submaps that saw it, not only to the ones loop
//! closure happened to search from it.
//!
//! No wide search runs here: the graph already holds the loops that loop closure found, and a
//! scan the graph places more than [`RefinementOptions::max_correction_m`] off (when it is
//! aligned) is left to it.
//!
//! A place mapped on every lap of a long run lies in a submap per lap: each scan is tried on
//! at most [`RefinementOptions::max_submaps_per_scan`] of them, the nearest, so that the
//! end of a run costs in proportion to its scans rather than to its scans times its laps.
//!
//! A scan whose place settled during the run ([`RefinedAhead`]) is aligned then, a few nodes
//! for every node added, rather than at the end: the end aligns the scans of the places that
//! never settled (the free part of the graph) and the few fixed ones not yet reached, not
//! every scan of the run. Such a scan is aligned from the graph's poses of that time, on the
//! submaps finished by then, and the constraints it gave then (or none) are what it keeps:
//! the end does not check them against its own poses, nor try it again on the submaps of
//! later passes, whose own scans tie them to it.

use std::collections::{HashMap, VecDeque};

use super::closure_confirmation::FoundClosure;
use super::icp::align;
use super::options::{RefinementOptions, SlamOptions};
use super::slam_submap::SlamSubmap;
use crate::geometry::Pose2;
use crate::scan_match::Scan;

/// The constraints found for the scans of `nodes` (`scans` holds every node's, in node
/// order, the beams the SLAM trusted) in `submaps`, each node and submap frame where
/// `pose_in_map` puts it (the optimised graph). A node aligned `ahead`, during the run, keeps
/// the constraints found then and is not aligned again. See the
/// [module documentation](self).
pub(crate) fn refinement_closures(
    pose_in_map: impl Fn(usize) -> Option<Pose2>,
    nodes: &[usize],
    submaps: &[&SlamSubmap],
    scans: &[Scan],
    options: &SlamOptions,
    ahead: &RefinedAhead,
) -> Vec<FoundClosure> {
    let mut closures = Vec::new();
    for &node in nodes {
        match ahead.closures.get(&node) {
            Some(found) => closures.extend_from_slice(found),
            None => {
                if let Some(scan) = scans.get(node) {
                    closures.extend(node_closures(&pose_in_map, node, scan, submaps, options));
                }
            }
        }
    }
    closures
}

/// The final refinement of the nodes fixed during the run, made as they are fixed rather than
/// at the end. A node is fixed once every submap it went into has settled
/// ([`super::settled_submaps`]): later passes agree with its place, and the graph holds it
/// where it will stay until the end releases it. It is then aligned on the finished submaps
/// near it, as the end of the run would align it, and keeps those constraints; a later pass's
/// submap is tied to it by that pass's own nodes. The end of the run is left with the nodes
/// that never settled (the pass under way and the places seen once), and the fixed ones not
/// yet reached.
#[derive(Debug, Default)]
pub(crate) struct RefinedAhead {
    /// For every node aligned ahead: the constraints found (none, when no alignment passed).
    closures: HashMap<usize, Vec<FoundClosure>>,
    /// Fixed nodes not yet aligned, in the order they were fixed.
    pending: VecDeque<usize>,
}

impl RefinedAhead {
    /// `node` was fixed: it is to be aligned.
    pub(crate) fn fixed(&mut self, node: usize) {
        self.pending.push_back(node);
    }

    /// Whether a fixed node waits to be aligned.
    pub(crate) fn has_pending(&self) -> bool {
        !self.pending.is_empty()
    }

    /// Nodes aligned ahead so far.
    pub(crate) fn nodes_aligned(&self) -> usize {
        self.closures.len()
    }

    /// Aligns at most `max_nodes` of the pending nodes on the finished `submaps` near them,
    /// each node and submap frame where `pose_in_map` puts it (the graph as it stands).
    pub(crate) fn align_pending(
        &mut self,
        max_nodes: usize,
        pose_in_map: impl Fn(usize) -> Option<Pose2>,
        submaps: &[&SlamSubmap],
        scans: &[Scan],
        options: &SlamOptions,
    ) {
        for _ in 0..max_nodes {
            let Some(node) = self.pending.pop_front() else {
                return;
            };
            if let Some(scan) = scans.get(node) {
                let found = node_closures(&pose_in_map, node, scan, submaps, options);
                self.closures.insert(node, found);
            }
        }
    }
}

/// The constraints of `node` (its `scan`) in the nearest `submaps` it did not go into,
/// within the refinement's distance and at most its number of them, each aligned from the
/// node's pose in it.
fn node_closures(
    pose_in_map: impl Fn(usize) -> Option<Pose2>,
    node: usize,
    scan: &Scan,
    submaps: &[&SlamSubmap],
    options: &SlamOptions,
) -> Vec<FoundClosure> {
    let refinement = &options.refinement;
    let Some(node_in_map) = pose_in_map(node) else {
        return Vec::new();
    };
    let mut near: Vec<(f64, &SlamSubmap, Pose2)> = submaps
        .iter()
        .filter(|submap| !(submap.first_node()..=submap.last_node()).contains(&node))
        .filter_map(|&submap| {
            let submap_in_map = pose_in_map(submap.first_node())?;
            let guess = submap_in_map.inverse() * node_in_map;
            let distance_m = guess.x_m.hypot(guess.y_m);
            (distance_m <= refinement.max_distance_m).then_some((distance_m, submap, guess))
        })
        .collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    near.truncate(refinement.max_submaps_per_scan);
    let points: Vec<[f64; 2]> = scan.points_in_robot().iter().flatten().copied().collect();
    near.into_iter()
        .filter_map(|(_, submap, guess)| align_on(submap, node, &points, guess, options))
        .collect()
}

/// The constraint of `node` (end points `points`) in `submap` aligned from `guess`, when the
/// alignment stays within the allowed correction and passes the loop closure's test.
fn align_on(
    submap: &SlamSubmap,
    node: usize,
    points: &[[f64; 2]],
    guess: Pose2,
    options: &SlamOptions,
) -> Option<FoundClosure> {
    let loop_closure = &options.loop_closure;
    if !may_fit(submap, points, guess, options) {
        return None;
    }
    let aligned = align(submap.points(), points, guess, &loop_closure.icp)?;
    if !within_correction(guess, aligned.map_from_robot, &options.refinement) {
        return None;
    }
    let fit = submap.fit(points, aligned.map_from_robot, loop_closure.icp.inlier_m);
    loop_closure.accepts(&fit).then(|| FoundClosure {
        submap_first_node: submap.first_node(),
        node,
        pose_in_submap: aligned.map_from_robot,
        information_in_robot: Some(aligned.information_in_robot()),
    })
}

/// Whether enough of `points_in_robot` lie near the submap's points at `guess` for an
/// alignment within the allowed correction to pass the acceptance test's share of end points
/// on the submap's surfaces. Only then is the alignment worth running.
///
/// A correction of at most `t` and `θ` moves a point at range `r` by at most `t + r θ`, so an
/// end point that fits after it lies within `inlier_m + t + r θ` of a map point before it.
/// The test is therefore necessary for acceptance, and skipping what fails it changes no
/// result.
fn may_fit(
    submap: &SlamSubmap,
    points_in_robot: &[[f64; 2]],
    guess: Pose2,
    options: &SlamOptions,
) -> bool {
    let refinement = &options.refinement;
    let loop_closure = &options.loop_closure;
    // A micrometre of slack for rounding.
    let reach_m = loop_closure.icp.inlier_m + refinement.max_correction_m + 1e-6;
    let near = points_in_robot
        .iter()
        .filter(|p| {
            let range_m = p[0].hypot(p[1]);
            let point = guess.transform_point(**p);
            let reach_m = reach_m + range_m * refinement.max_correction_rad;
            submap.points().any_within(point, reach_m)
        })
        .count();
    near as f64 / points_in_robot.len() as f64 >= loop_closure.min_inlier_fraction
}

/// Whether `aligned` lies within the allowed correction of `guess`.
fn within_correction(guess: Pose2, aligned: Pose2, options: &RefinementOptions) -> bool {
    let correction = guess.inverse() * aligned;
    correction.x_m.hypot(correction.y_m) <= options.max_correction_m
        && correction.theta_rad.abs() <= options.max_correction_rad
}

#[cfg(test)]
mod tests {
    use super::*;

    fn every_node(scans: &[Scan]) -> Vec<usize> {
        (0..scans.len()).collect()
    }
    use crate::scan_match::synthetic::{cast_front_scan, irregular_room_walls};

    fn room_scan(pose: Pose2) -> Scan {
        cast_front_scan(&irregular_room_walls(), pose)
    }

    /// A finished submap of nodes `0..8`, scanned around the room's middle, and a later node 8
    /// whose graph pose is `held_pose` while it was truly scanned at `true_pose`: the submap,
    /// every node's pose in the graph and every node's scan.
    fn room_with_a_later_scan(
        options: &SlamOptions,
        true_pose: Pose2,
        held_pose: Pose2,
    ) -> (SlamSubmap, Vec<Pose2>, Vec<Scan>) {
        let mut submap = SlamSubmap::new(Pose2::IDENTITY, 0, options.submap, options.point_map);
        let mut poses_in_map: Vec<Pose2> = (0..8)
            .map(|k| {
                let k = f64::from(k);
                Pose2::new(0.12 * k, -0.06 * k, 0.04 * k)
            })
            .collect();
        let mut scans = Vec::new();
        for (node, &pose) in poses_in_map.iter().enumerate() {
            let scan = room_scan(pose);
            submap.insert(node, &scan, pose);
            scans.push(scan);
        }
        submap.finish();
        scans.push(room_scan(true_pose));
        poses_in_map.push(held_pose);
        (submap, poses_in_map, scans)
    }

    /// The end of the run's constraints for [`room_with_a_later_scan`].
    fn closures_for(
        options: &SlamOptions,
        true_pose: Pose2,
        held_pose: Pose2,
    ) -> Vec<FoundClosure> {
        let (submap, poses_in_map, scans) = room_with_a_later_scan(options, true_pose, held_pose);
        refinement_closures(
            |n| poses_in_map.get(n).copied(),
            &every_node(&scans),
            &[&submap],
            &scans,
            options,
            &RefinedAhead::default(),
        )
    }

    #[test]
    fn a_node_aligned_ahead_keeps_its_constraints_and_is_not_aligned_again() {
        let options = SlamOptions::default();
        let true_pose = Pose2::new(0.8, -0.4, 0.2);
        let held_pose = Pose2::new(0.95, -0.3, 0.22);
        let (submap, mut poses_in_map, scans) =
            room_with_a_later_scan(&options, true_pose, held_pose);
        let mut ahead = RefinedAhead::default();
        ahead.fixed(8);
        let align_ahead = |ahead: &mut RefinedAhead, max_nodes: usize| {
            let pose_in_map = |n: usize| poses_in_map.get(n).copied();
            ahead.align_pending(max_nodes, pose_in_map, &[&submap], &scans, &options);
        };
        // No node a call: nothing aligned yet.
        align_ahead(&mut ahead, 0);
        assert_eq!(ahead.nodes_aligned(), 0);
        // Aligned while the graph holds node 8 near where it was scanned.
        align_ahead(&mut ahead, 5);
        assert_eq!(ahead.nodes_aligned(), 1);
        // The end of the run then holds it beyond the allowed correction: aligned there, it
        // would be left to the graph.
        poses_in_map[8] = true_pose * Pose2::new(0.0, 0.0, 6f64.to_radians());
        let at_end = |ahead: &RefinedAhead| {
            refinement_closures(
                |n| poses_in_map.get(n).copied(),
                &every_node(&scans),
                &[&submap],
                &scans,
                &options,
                ahead,
            )
        };
        assert!(at_end(&RefinedAhead::default()).is_empty());
        let kept = at_end(&ahead);
        assert_eq!(kept.len(), 1, "{kept:?}");
        assert_eq!((kept[0].submap_first_node, kept[0].node), (0, 8));
        let error = true_pose.inverse() * kept[0].pose_in_submap;
        assert!(error.x_m.hypot(error.y_m) < 0.01, "{error:?}");
    }

    #[test]
    fn a_scan_held_a_little_off_is_tied_to_the_submap_where_it_fits() {
        let true_pose = Pose2::new(0.8, -0.4, 0.2);
        let held_pose = Pose2::new(0.95, -0.3, 0.22);
        let closures = closures_for(&SlamOptions::default(), true_pose, held_pose);
        // Nodes 0 to 7 went into the submap; only node 8 is aligned on it.
        assert_eq!(closures.len(), 1, "{closures:?}");
        let closure = closures[0];
        assert_eq!((closure.submap_first_node, closure.node), (0, 8));
        let error = true_pose.inverse() * closure.pose_in_submap;
        assert!(error.x_m.hypot(error.y_m) < 0.01, "{error:?}");
        assert!(error.theta_rad.abs() < 0.2f64.to_radians(), "{error:?}");
    }

    #[test]
    fn a_scan_held_beyond_the_allowed_correction_is_left_to_the_graph() {
        let true_pose = Pose2::new(0.8, -0.4, 0.2);
        let held_pose = Pose2::new(0.8, -0.4, 0.2 + 6f64.to_radians());
        let mut options = SlamOptions::default();
        let closures = closures_for(&options, true_pose, held_pose);
        assert!(closures.is_empty(), "{closures:?}");
        // The alignment itself finds the pose: only the limit turns it down.
        options.refinement.max_correction_rad = 10f64.to_radians();
        assert_eq!(closures_for(&options, true_pose, held_pose).len(), 1);
    }

    #[test]
    fn a_place_mapped_on_many_laps_ties_each_scan_to_the_nearest_few_submaps() {
        // Two laps more than the budget through the room, each mapped into a submap of its
        // own (frames a little apart), then a last scan in the middle of the room.
        let options = SlamOptions::default();
        let budget = options.refinement.max_submaps_per_scan;
        let laps = budget + 2;
        let mut submaps = Vec::new();
        let mut poses_in_map = Vec::new();
        let mut scans = Vec::new();
        for lap in 0..laps {
            let frame = Pose2::new(0.1 * lap as f64, 0.0, 0.0);
            let mut submap = SlamSubmap::new(frame, 2 * lap, options.submap, options.point_map);
            for step in 0..2 {
                let pose = frame * Pose2::new(0.2 * f64::from(step), 0.0, 0.0);
                let scan = room_scan(pose);
                submap.insert(2 * lap + step as usize, &scan, pose);
                poses_in_map.push(pose);
                scans.push(scan);
            }
            submap.finish();
            submaps.push(submap);
        }
        let last = Pose2::new(1.0, -0.2, 0.1);
        poses_in_map.push(last);
        scans.push(room_scan(last));
        let submaps: Vec<&SlamSubmap> = submaps.iter().collect();
        let closures = refinement_closures(
            |n| poses_in_map.get(n).copied(),
            &every_node(&scans),
            &submaps,
            &scans,
            &options,
            &RefinedAhead::default(),
        );
        let mut of_last: Vec<usize> = closures
            .iter()
            .filter(|c| c.node == 2 * laps)
            .map(|c| c.submap_first_node / 2)
            .collect();
        of_last.sort_unstable();
        // The laps whose frames lie nearest the scan (the last ones), and no more.
        let nearest: Vec<usize> = (laps - budget..laps).collect();
        assert_eq!(of_last, nearest);
    }
}
