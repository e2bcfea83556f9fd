//! GPS fixes for the EKF: first to put the map into the GPS's metric frame, then as position
//! updates.
//!
//! Until the map is geo-referenced, each fix is paired with the filter's position of the
//! antenna; once the pairs span [`GpsAnchorOptions::alignment_span_m`], the weighted rigid
//! alignment `enu_from_map` re-expresses the whole map in the GPS frame, and from then on the
//! map frame *is* that frame and each fix is fused as a position update, gated against jumps.
//! A run of rejected fixes means the filter, not the receiver, is off (it drifted through an
//! outage): after [`GpsAnchorOptions::reacquire_after`] the gate opens until a fix is taken.

use nalgebra::Matrix2;

use super::frames::compose_pose;
use super::motion_model::MotionModel;
use super::submap_slam::SubmapSlam;
use crate::geometry::Pose2;
use crate::georef::{AlignmentPair, RigidAlignment2d, RigidAlignmentOptions};

/// How fixes are used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpsAnchorOptions {
    /// The map is aligned once the paired fixes span this far, metres.
    pub alignment_span_m: f64,
    /// Squared Mahalanobis distance above which a fix is a jump and is not fused.
    pub gate_distance2: f64,
    /// After this many rejected fixes in a row, the next one is fused whatever its distance.
    pub reacquire_after: usize,
}

impl Default for GpsAnchorOptions {
    /// Align over 30 m, gate at 25 (5 σ), re-acquire after 10 rejections.
    fn default() -> Self {
        GpsAnchorOptions {
            alignment_span_m: 30.0,
            gate_distance2: 25.0,
            reacquire_after: 10,
        }
    }
}

/// What one fix did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GpsOutcome {
    /// Paired with the filter's position, waiting for enough span to align.
    Paired,
    /// Completed the alignment: the map was re-expressed by this `enu_from_map`. Poses kept
    /// outside the filter must be moved by it too.
    Aligned(Pose2),
    /// Fused as a position update.
    Fused,
    /// Rejected by the gate.
    Rejected,
}

/// GPS alignment and fusion state. See the [module documentation](self).
#[derive(Debug, Clone, Default)]
pub struct GpsAnchor {
    options: GpsAnchorOptions,
    pairs: Vec<AlignmentPair>,
    aligned: bool,
    rejected_in_a_row: usize,
    /// Fixes fused as updates.
    pub fused: usize,
    /// Fixes rejected by the gate.
    pub rejected: usize,
}

impl GpsAnchor {
    /// A new anchor; the map is not yet aligned.
    pub fn new(options: GpsAnchorOptions) -> GpsAnchor {
        GpsAnchor {
            options,
            ..GpsAnchor::default()
        }
    }

    /// Whether the map frame is the GPS frame.
    pub fn is_aligned(&self) -> bool {
        self.aligned
    }

    /// Uses one fix at `fix_in_enu` (metres in the GPS's local frame) with covariance
    /// `noise_m2`, taken by an antenna at `antenna_in_robot`.
    pub fn on_fix<M: MotionModel>(
        &mut self,
        slam: &mut SubmapSlam<M>,
        fix_in_enu: [f64; 2],
        noise_m2: &Matrix2<f64>,
        antenna_in_robot: [f64; 2],
    ) -> GpsOutcome {
        if self.aligned {
            let gate = if self.rejected_in_a_row >= self.options.reacquire_after {
                f64::INFINITY
            } else {
                self.options.gate_distance2
            };
            return if slam.observe_position(fix_in_enu, antenna_in_robot, noise_m2, gate) {
                self.fused += 1;
                self.rejected_in_a_row = 0;
                GpsOutcome::Fused
            } else {
                self.rejected += 1;
                self.rejected_in_a_row += 1;
                GpsOutcome::Rejected
            };
        }
        let antenna = compose_pose(
            slam.pose_in_map().0,
            Pose2 {
                x_m: antenna_in_robot[0],
                y_m: antenna_in_robot[1],
                theta_rad: 0.0,
            },
        )
        .0;
        self.pairs.push(AlignmentPair {
            point_in_map: [antenna.x_m, antenna.y_m],
            point_in_enu: fix_in_enu,
            covariance_in_enu_m2: *noise_m2,
        });
        match self.try_align() {
            Some(enu_from_map) => {
                slam.transform_map(enu_from_map);
                self.aligned = true;
                self.pairs.clear();
                GpsOutcome::Aligned(enu_from_map)
            }
            None => GpsOutcome::Paired,
        }
    }

    /// `enu_from_map` once the pairs span far enough.
    fn try_align(&self) -> Option<Pose2> {
        let first = self.pairs.first()?.point_in_map;
        let span_m = self
            .pairs
            .iter()
            .map(|p| (p.point_in_map[0] - first[0]).hypot(p.point_in_map[1] - first[1]))
            .fold(0.0, f64::max);
        if span_m < self.options.alignment_span_m {
            return None;
        }
        let alignment =
            RigidAlignment2d::estimate(&self.pairs, &RigidAlignmentOptions::default()).ok()?;
        Some(alignment.enu_from_map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ekf_slam::{
        DifferentialDriveInput, DifferentialDriveModel, RangeBearingModel, SubmapSlamOptions,
    };

    /// A robot driving straight along its x axis while the GPS sees it drive north from
    /// (100, 200): the map is aligned once 30 m are covered, then fixes are fused.
    #[test]
    fn aligns_then_fuses_then_rejects_a_jump() {
        let mut slam = SubmapSlam::new(
            DifferentialDriveModel::default(),
            RangeBearingModel::default(),
            SubmapSlamOptions::default(),
            Pose2::IDENTITY,
        );
        let mut anchor = GpsAnchor::new(GpsAnchorOptions::default());
        let noise = Matrix2::identity() * 0.25;
        let input = DifferentialDriveInput {
            speed_mps: 1.0,
            yaw_rate_radps: 0.0,
        };
        let mut outcomes = Vec::new();
        for step in 0..=40 {
            if step > 0 {
                slam.predict(&input, 1.0);
            }
            let fix = [100.0, 200.0 + f64::from(step)];
            outcomes.push(anchor.on_fix(&mut slam, fix, &noise, [0.0; 2]));
        }
        let aligned_at = outcomes
            .iter()
            .position(|o| matches!(o, GpsOutcome::Aligned(_)))
            .expect("the map is aligned");
        assert_eq!(aligned_at, 30);
        let GpsOutcome::Aligned(t) = outcomes[aligned_at] else {
            unreachable!()
        };
        assert!((t.x_m - 100.0).abs() < 1e-6 && (t.y_m - 200.0).abs() < 1e-6);
        assert!((t.theta_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
        assert!(
            outcomes[aligned_at + 1..]
                .iter()
                .all(|o| *o == GpsOutcome::Fused)
        );
        let pose = slam.pose_in_map().0;
        assert!((pose.x_m - 100.0).abs() < 0.1 && (pose.y_m - 240.0).abs() < 0.1);
        // A 50 m jump is not fused.
        let jump = anchor.on_fix(&mut slam, [150.0, 240.0], &noise, [0.0; 2]);
        assert_eq!(jump, GpsOutcome::Rejected);
        assert_eq!((anchor.fused, anchor.rejected), (10, 1));
    }
}
