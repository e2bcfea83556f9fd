//! A motion given from outside (a reference trajectory's), scored as local tracking scores
//! its candidates, beside what tracking chose.
//!
//! Where tracking puts a scan in the wrong place, this tells the two failures apart: the
//! search never reached the right pose (the reference's motion scores higher than what was
//! chosen), or the right pose scores lower than a wrong one (the fit and the motion prior
//! prefer the wrong pose, and no search would help). The checked pose is scored where the
//! reference puts it, without aligning it.

use super::slam_submap::SubmapFit;
use crate::geometry::Pose2;

/// What tracking made of one scan, and how a given motion scored there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackingCheck {
    /// The motion from the last scan's pose that tracking chose (the prediction for a lost
    /// scan), in the last scan's frame.
    pub chosen_motion: Pose2,
    /// The highest score of any candidate, taken or refused (its
    /// [`SubmapFit::tracking_score`] less the motion prior's penalty); `None` when no
    /// alignment gave a candidate.
    pub best_score: Option<f64>,
    /// The motion checked, in the last scan's frame.
    pub checked_motion: Pose2,
    /// How the scan fits the submap at the checked motion; `None` when there was no submap
    /// to score it on.
    pub checked_fit: Option<SubmapFit>,
    /// Its score, as a candidate's.
    pub checked_score: Option<f64>,
}

/// Where tracking placed a scan against the checked motion, and why
/// ([`TrackingCheck::verdict`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrackingVerdict {
    /// The chosen motion lies near the checked one.
    Agrees,
    /// Elsewhere, and the checked motion scores higher than every candidate and would be
    /// taken: the search did not reach it.
    SearchMissed,
    /// Elsewhere, and the checked motion would be taken but scores lower than the best
    /// candidate: the score prefers the wrong pose.
    ScoredLower,
    /// Elsewhere, and the checked motion scores as a pose tracking refuses (at most 0, or
    /// no submap to score it on): the scan fits too little there to be placed at all.
    Refused,
}

impl TrackingCheck {
    /// The verdict, where a chosen motion farther than `max_m` or `max_rad` from the checked
    /// one counts as elsewhere.
    pub fn verdict(&self, max_m: f64, max_rad: f64) -> TrackingVerdict {
        if !self.chose_elsewhere(max_m, max_rad) {
            TrackingVerdict::Agrees
        } else if self.checked_score.is_none_or(|score| score <= 0.0) {
            TrackingVerdict::Refused
        } else if self.checked_scores_higher() {
            TrackingVerdict::SearchMissed
        } else {
            TrackingVerdict::ScoredLower
        }
    }

    /// Whether the chosen motion lies farther than `max_m` or `max_rad` from the checked one.
    pub fn chose_elsewhere(&self, max_m: f64, max_rad: f64) -> bool {
        let difference = self.checked_motion.inverse() * self.chosen_motion;
        difference.x_m.hypot(difference.y_m) > max_m
            || crate::geometry::wrap_angle_rad(difference.theta_rad).abs() > max_rad
    }

    /// Whether the checked motion scored higher than every candidate: the search did not
    /// reach it.
    pub fn checked_scores_higher(&self) -> bool {
        match (self.checked_score, self.best_score) {
            (Some(checked), Some(best)) => checked > best,
            (Some(_), None) => true,
            (None, _) => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(chosen: Pose2, best: Option<f64>, checked: Option<f64>) -> TrackingCheck {
        TrackingCheck {
            chosen_motion: chosen,
            best_score: best,
            checked_motion: Pose2::new(2.0, 0.0, 0.1),
            checked_fit: None,
            checked_score: checked,
        }
    }

    #[test]
    fn a_choice_is_elsewhere_beyond_either_bound() {
        let near = check(Pose2::new(2.1, 0.1, 0.12), None, None);
        assert!(!near.chose_elsewhere(0.3, 0.05));
        let short = check(Pose2::new(0.0, 0.0, 0.1), None, None);
        assert!(short.chose_elsewhere(0.3, 0.05));
        let turned = check(Pose2::new(2.0, 0.0, 0.3), None, None);
        assert!(turned.chose_elsewhere(0.3, 0.05));
        // Angles compare across ±π.
        let mut wrapped = check(Pose2::new(2.0, 0.0, 0.0), None, None);
        wrapped.checked_motion = Pose2::new(2.0, 0.0, std::f64::consts::PI - 0.01);
        wrapped.chosen_motion = Pose2::new(2.0, 0.0, -std::f64::consts::PI + 0.01);
        assert!(!wrapped.chose_elsewhere(0.3, 0.05));
    }

    #[test]
    fn a_verdict_names_why_the_choice_was_elsewhere() {
        let (max_m, max_rad) = (0.3, 0.05);
        let near = Pose2::new(2.0, 0.0, 0.1);
        let short = Pose2::IDENTITY;
        assert_eq!(
            check(near, Some(0.1), Some(0.5)).verdict(max_m, max_rad),
            TrackingVerdict::Agrees
        );
        assert_eq!(
            check(short, Some(0.4), Some(0.5)).verdict(max_m, max_rad),
            TrackingVerdict::SearchMissed
        );
        assert_eq!(
            check(short, Some(0.5), Some(0.4)).verdict(max_m, max_rad),
            TrackingVerdict::ScoredLower
        );
        assert_eq!(
            check(short, Some(-0.2), Some(0.0)).verdict(max_m, max_rad),
            TrackingVerdict::Refused
        );
        assert_eq!(
            check(short, Some(0.5), None).verdict(max_m, max_rad),
            TrackingVerdict::Refused
        );
    }

    #[test]
    fn the_checked_motion_scores_higher_only_above_every_candidate() {
        let chosen = Pose2::IDENTITY;
        assert!(check(chosen, Some(0.40), Some(0.45)).checked_scores_higher());
        assert!(!check(chosen, Some(0.45), Some(0.40)).checked_scores_higher());
        assert!(check(chosen, None, Some(-0.1)).checked_scores_higher());
        assert!(!check(chosen, Some(0.1), None).checked_scores_higher());
    }
}
