//! Loop closures confirmed by a second one before they enter the pose graph.
//!
//! One scan matched well in an earlier submap may still be a place that merely looks alike (a
//! corridor, a row of identical offices). A closure is therefore held back until another scan,
//! at most [`ConfirmationOptions::window_scans`] later, is found in the same submap (or in a
//! frame close by, [`ConfirmationOptions::max_frame_gap_nodes`]) at a pose that agrees with
//! it: the two matches must imply the same motion between the two scans as local tracking
//! measured, within [`ConfirmationOptions::max_translation_m`] and
//! [`ConfirmationOptions::max_rotation_rad`]. Two coincidences that agree on the geometry are
//! far less likely than one.

use nalgebra::Matrix3;

use crate::geometry::Pose2;

/// How closures are confirmed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConfirmationOptions {
    /// A closure waits this many scans at most for its confirmation.
    pub window_scans: usize,
    /// Largest disagreement in translation between the two matches and local tracking, metres.
    pub max_translation_m: f64,
    /// Largest disagreement in rotation, radians.
    pub max_rotation_rad: f64,
    /// Two closures in frames of different nodes confirm each other when those nodes are at
    /// most this many apart: the one frame is carried into the other through local
    /// tracking's poses. 0 asks for the same frame (the same submap).
    pub max_frame_gap_nodes: usize,
    /// A closure enters with the earlier ones that agree with it once at least this many do.
    pub min_agreeing: usize,
}

impl Default for ConfirmationOptions {
    fn default() -> Self {
        ConfirmationOptions {
            window_scans: 20,
            max_translation_m: 0.3,
            max_rotation_rad: 3f64.to_radians(),
            max_frame_gap_nodes: 0,
            min_agreeing: 1,
        }
    }
}

/// A scan found in a submap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoundClosure {
    /// The node whose pose is the submap's frame.
    pub submap_first_node: usize,
    /// The scan's node.
    pub node: usize,
    /// The scan's pose in the submap frame.
    pub pose_in_submap: Pose2,
    /// What the alignment knows of that pose, about a motion of the robot in its own frame;
    /// `None` when it is not known.
    pub information_in_robot: Option<Matrix3<f64>>,
}

/// Closures waiting for confirmation. See the [module documentation](self).
#[derive(Clone, Debug, Default)]
pub struct ClosureConfirmation {
    options: ConfirmationOptions,
    /// Recent closures, and whether each is in the graph already.
    recent: Vec<(FoundClosure, bool)>,
    /// Closures that left the window without a second one agreeing.
    rejected: usize,
}

impl ClosureConfirmation {
    /// Nothing pending.
    pub fn new(options: ConfirmationOptions) -> Self {
        ClosureConfirmation {
            options,
            recent: Vec::new(),
            rejected: 0,
        }
    }

    /// Closures rejected so far: offered, and out of the window without a second one that
    /// agreed with them. Those still waiting are counted by [`Self::rejected_at_end`].
    pub fn rejected(&self) -> usize {
        self.rejected
    }

    /// [`Self::rejected`], with the closures still waiting counted as rejected (at the end of
    /// a run nothing can confirm them any more).
    pub fn rejected_at_end(&self) -> usize {
        self.rejected + self.recent.iter().filter(|(_, added)| !added).count()
    }

    /// Where the scan of `node` should lie if the closures still waiting are right: for each
    /// submap (by its frame's node) a closure waits in, the latest such closure and its pose
    /// carried to `node` through local tracking's `poses_in_local`. A search there is the
    /// test of that closure: a scan found where it predicts agrees with it, and a look-alike
    /// rarely predicts the next scans as well. Only the waiting closures `followed` takes are
    /// carried.
    pub fn predictions(
        &self,
        node: usize,
        poses_in_local: &[Pose2],
        followed: impl Fn(&FoundClosure) -> bool,
    ) -> Vec<(FoundClosure, Pose2)> {
        let window = self.options.window_scans;
        let mut predictions: Vec<(FoundClosure, Pose2)> = Vec::new();
        for (waiting, _) in
            self.recent.iter().rev().filter(|(c, added)| {
                !*added && c.node < node && c.node + window >= node && followed(c)
            })
        {
            if predictions
                .iter()
                .any(|(c, _)| c.submap_first_node == waiting.submap_first_node)
            {
                continue;
            }
            let (Some(then), Some(now)) =
                (poses_in_local.get(waiting.node), poses_in_local.get(node))
            else {
                continue;
            };
            let tracked = then.inverse() * *now;
            predictions.push((*waiting, waiting.pose_in_submap * tracked));
        }
        predictions
    }

    /// Offers `found`; `poses_in_local` are local tracking's poses of every node so far.
    /// Returns the closures to add to the graph now: none while `found` is alone, else the
    /// earlier closures it agrees with that are not in the graph yet, and `found` itself.
    pub fn offer(&mut self, found: FoundClosure, poses_in_local: &[Pose2]) -> Vec<FoundClosure> {
        let window = self.options.window_scans;
        let rejected = &mut self.rejected;
        self.recent.retain(|(c, added)| {
            let kept = c.node + window >= found.node && c.node <= found.node;
            *rejected += usize::from(!kept && !added);
            kept
        });
        let mut agreeing = Vec::new();
        for (index, (earlier, _)) in self.recent.iter().enumerate() {
            let frame_gap = earlier.submap_first_node.abs_diff(found.submap_first_node);
            if frame_gap > self.options.max_frame_gap_nodes || earlier.node == found.node {
                continue;
            }
            let (Some(a), Some(b), Some(frame_a), Some(frame_b)) = (
                poses_in_local.get(earlier.node),
                poses_in_local.get(found.node),
                poses_in_local.get(earlier.submap_first_node),
                poses_in_local.get(found.submap_first_node),
            ) else {
                continue;
            };
            let tracked = a.inverse() * *b;
            // `found`'s pose in `earlier`'s frame (the same pose when the frames are one).
            let found_in_earlier_frame = if frame_gap == 0 {
                found.pose_in_submap
            } else {
                frame_a.inverse() * *frame_b * found.pose_in_submap
            };
            let matched = earlier.pose_in_submap.inverse() * found_in_earlier_frame;
            let difference = tracked.inverse() * matched;
            if difference.x_m.hypot(difference.y_m) > self.options.max_translation_m
                || difference.theta_rad.abs() > self.options.max_rotation_rad
            {
                continue;
            }
            agreeing.push(index);
        }
        let agrees = !agreeing.is_empty() && agreeing.len() >= self.options.min_agreeing;
        let mut confirmed = Vec::new();
        if agrees {
            for index in agreeing {
                let (earlier, added) = &mut self.recent[index];
                if !*added {
                    *added = true;
                    confirmed.push(*earlier);
                }
            }
            confirmed.push(found);
        }
        self.recent.push((found, agrees));
        confirmed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight_line(n: usize) -> Vec<Pose2> {
        (0..n).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect()
    }

    /// Node 40 found in the submap of node 0.
    fn closure_at_node_40() -> FoundClosure {
        FoundClosure {
            submap_first_node: 0,
            node: 40,
            pose_in_submap: Pose2::new(2.0, 1.0, 0.1),
            information_in_robot: None,
        }
    }

    #[test]
    fn a_single_closure_waits_and_an_agreeing_one_confirms_both() {
        let poses = straight_line(60);
        let mut confirmation = ClosureConfirmation::new(ConfirmationOptions::default());
        let first = closure_at_node_40();
        assert!(confirmation.offer(first, &poses).is_empty());
        // Five scans on, five metres on along the robot's heading in the submap.
        let (sin, cos) = 0.1f64.sin_cos();
        let second = FoundClosure {
            submap_first_node: 0,
            node: 45,
            pose_in_submap: Pose2::new(2.0 + 5.0 * cos, 1.0 + 5.0 * sin, 0.1),
            information_in_robot: None,
        };
        assert_eq!(confirmation.offer(second, &poses), vec![first, second]);
        assert_eq!(confirmation.rejected_at_end(), 0);
    }

    #[test]
    fn asked_for_two_agreeing_a_closure_waits_for_the_second() {
        let poses = straight_line(60);
        let mut confirmation = ClosureConfirmation::new(ConfirmationOptions {
            min_agreeing: 2,
            ..ConfirmationOptions::default()
        });
        let (sin, cos) = 0.1f64.sin_cos();
        let at = |node: usize| {
            let along_m = (node - 40) as f64;
            FoundClosure {
                submap_first_node: 0,
                node,
                pose_in_submap: Pose2::new(2.0 + along_m * cos, 1.0 + along_m * sin, 0.1),
                information_in_robot: None,
            }
        };
        assert!(confirmation.offer(at(40), &poses).is_empty());
        // One agrees: not yet.
        assert!(confirmation.offer(at(42), &poses).is_empty());
        // One that disagrees (a metre off) changes nothing.
        let off = FoundClosure {
            pose_in_submap: Pose2::new(2.0 + 3.0 * cos, 2.0 + 3.0 * sin, 0.1),
            ..at(43)
        };
        assert!(confirmation.offer(off, &poses).is_empty());
        // The third agrees with both earlier ones: all three enter.
        assert_eq!(
            confirmation.offer(at(45), &poses),
            vec![at(40), at(42), at(45)]
        );
        // The one that disagreed is rejected once out of the window.
        assert_eq!(confirmation.rejected_at_end(), 1);
    }

    #[test]
    fn a_waiting_closure_predicts_the_next_scans_until_confirmed_or_out_of_its_window() {
        let poses = straight_line(80);
        let mut confirmation = ClosureConfirmation::new(ConfirmationOptions::default());
        let first = closure_at_node_40();
        assert!(confirmation.offer(first, &poses).is_empty());
        let everything = |_: &FoundClosure| true;
        assert!(confirmation.predictions(40, &poses, everything).is_empty());
        // Three scans on, three metres on along the closure's heading in its submap.
        let predicted = confirmation.predictions(43, &poses, everything);
        let (sin, cos) = 0.1f64.sin_cos();
        let [(waiting, pose)] = predicted[..] else {
            panic!("one prediction, not {predicted:?}");
        };
        assert_eq!(waiting, first);
        assert!((pose.x_m - (2.0 + 3.0 * cos)).abs() < 1e-9);
        assert!((pose.y_m - (1.0 + 3.0 * sin)).abs() < 1e-9);
        assert!((pose.theta_rad - 0.1).abs() < 1e-12);
        // Only the closures followed are predicted, and none beyond the window.
        assert!(
            confirmation
                .predictions(43, &poses, |c| c.node != 40)
                .is_empty()
        );
        assert!(confirmation.predictions(61, &poses, everything).is_empty());
        // Once confirmed, it predicts nothing.
        let second = FoundClosure {
            node: 43,
            pose_in_submap: pose,
            ..first
        };
        assert_eq!(confirmation.offer(second, &poses).len(), 2);
        assert!(confirmation.predictions(44, &poses, everything).is_empty());
    }

    #[test]
    fn a_closure_no_second_one_agrees_with_is_counted_rejected() {
        let poses = straight_line(100);
        let mut confirmation = ClosureConfirmation::new(ConfirmationOptions::default());
        let lonely = closure_at_node_40();
        assert!(confirmation.offer(lonely, &poses).is_empty());
        // Waiting: rejected only if the run ends now.
        assert_eq!(confirmation.rejected(), 0);
        assert_eq!(confirmation.rejected_at_end(), 1);
        // Another closure beyond the window pushes the first out, unconfirmed.
        let later = FoundClosure {
            node: 40 + ConfirmationOptions::default().window_scans + 1,
            ..lonely
        };
        assert!(confirmation.offer(later, &poses).is_empty());
        assert_eq!(confirmation.rejected(), 1);
        assert_eq!(confirmation.rejected_at_end(), 2);
    }

    #[test]
    fn closures_in_nearby_frames_confirm_each_other_when_allowed() {
        let poses = straight_line(60);
        let first = FoundClosure {
            submap_first_node: 0,
            node: 40,
            pose_in_submap: Pose2::new(2.0, 1.0, 0.0),
            information_in_robot: None,
        };
        // The same place seen from node 3's frame, three metres on along x.
        let second = FoundClosure {
            submap_first_node: 3,
            node: 45,
            pose_in_submap: Pose2::new(2.0 + 5.0 - 3.0, 1.0, 0.0),
            information_in_robot: None,
        };
        let mut same_frame_only = ClosureConfirmation::new(ConfirmationOptions::default());
        assert!(same_frame_only.offer(first, &poses).is_empty());
        assert!(same_frame_only.offer(second, &poses).is_empty());
        let mut nearby = ClosureConfirmation::new(ConfirmationOptions {
            max_frame_gap_nodes: 5,
            ..ConfirmationOptions::default()
        });
        assert!(nearby.offer(first, &poses).is_empty());
        assert_eq!(nearby.offer(second, &poses), vec![first, second]);
    }

    #[test]
    fn a_disagreeing_or_late_closure_confirms_nothing() {
        let poses = straight_line(100);
        let mut confirmation = ClosureConfirmation::new(ConfirmationOptions::default());
        let first = FoundClosure {
            submap_first_node: 0,
            node: 40,
            pose_in_submap: Pose2::new(2.0, 1.0, 0.0),
            information_in_robot: None,
        };
        assert!(confirmation.offer(first, &poses).is_empty());
        let elsewhere = FoundClosure {
            node: 45,
            pose_in_submap: Pose2::new(2.0, 4.0, 0.0),
            ..first
        };
        assert!(confirmation.offer(elsewhere, &poses).is_empty());
        let late = FoundClosure {
            node: 90,
            pose_in_submap: Pose2::new(52.0, 1.0, 0.0),
            ..first
        };
        assert!(confirmation.offer(late, &poses).is_empty());
    }
}
