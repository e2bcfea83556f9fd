//! Geo-referencing downstream of a SLAM method: the robot's trajectory in the `map` frame and
//! the GPS fixes give `enu_from_map` with its covariance. The grid method (method 2) is
//! geo-referenced this way; method 1 fuses the fixes into its filter instead.
//!
//! Fixes are kept as `enu` measurements with their time. Each [`GeoReferencer::align`] pairs
//! every fix with the antenna's position on the trajectory *as the SLAM holds it now*
//! (interpolated at the fix's time), so a loop closure that moves earlier poses moves their
//! pairs too, and fits the weighted rigid alignment ([`RigidAlignment2d`]). Receiver jumps are
//! found by the alignment's own residuals: a pair whose residual lies outside the fix's
//! covariance by more than the χ² gate is set aside and the alignment fitted again without it,
//! until no pair changes side. The map counts as geo-referenced once the alignment's heading
//! is known to the given standard deviation: its covariance, not a driven distance, decides.
//!
//! Method 1 aligns its map with the same rigid fit and then fuses the fixes as updates
//! ([`crate::ekf_slam::GpsAnchor`]), so its map frame becomes the `enu` frame itself.

use nalgebra::Matrix3;

use super::{
    AlignmentPair, GeoRefError, GpsMeasurement, GpsMeasurementOptions, LocalFrame,
    RigidAlignment2d, RigidAlignmentOptions,
};
use crate::geometry::Pose2;
use crate::link::GpsFix;

/// Options of [`GeoReferencer`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeoReferencerOptions {
    /// The GPS antenna's position on the robot, `[x_m, y_m]`.
    pub antenna_in_robot: [f64; 2],
    /// How fixes become `enu` measurements with a covariance.
    pub gps: GpsMeasurementOptions,
    /// The fit.
    pub alignment: RigidAlignmentOptions,
    /// A pair whose squared Mahalanobis residual exceeds this is a receiver jump. Default
    /// 13.8, the 99.9 % point of χ² with two degrees of freedom.
    pub jump_gate_chi2: f64,
    /// The map is geo-referenced once the heading of `enu_from_map` has at most this standard
    /// deviation, radians. Default 2°.
    pub max_heading_sigma_rad: f64,
    /// A fix is paired only with poses at most this far apart around it (or this far from the
    /// trajectory's first or last pose), seconds: across a gap in the scans it is left out.
    /// Default 1 s.
    pub max_pose_gap_s: f64,
}

impl Default for GeoReferencerOptions {
    fn default() -> Self {
        GeoReferencerOptions {
            antenna_in_robot: [0.0; 2],
            gps: GpsMeasurementOptions::default(),
            alignment: RigidAlignmentOptions::default(),
            jump_gate_chi2: 13.8,
            max_heading_sigma_rad: 2f64.to_radians(),
            max_pose_gap_s: 1.0,
        }
    }
}

/// The current geo-referencing of the map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapAlignment {
    /// Maps `point_in_map` into the `enu` frame of [`GeoReferencer::frame`].
    pub enu_from_map: Pose2,
    /// Covariance of (`x_m`, `y_m`, `theta_rad`) of `enu_from_map`.
    pub covariance: Matrix3<f64>,
    /// Fixes the alignment rests on.
    pub pairs_used: usize,
    /// Fixes set aside as receiver jumps.
    pub jumps: usize,
    /// Root mean square of the used pairs' residuals, metres.
    pub rms_residual_m: f64,
}

/// A fix as an `enu` measurement at a host time.
#[derive(Debug, Clone, Copy)]
struct TimedFix {
    time_s: f64,
    measurement: GpsMeasurement,
}

/// `enu_from_map` from a trajectory and GPS fixes. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct GeoReferencer {
    options: GeoReferencerOptions,
    frame: Option<LocalFrame>,
    fixes: Vec<TimedFix>,
    alignment: Option<MapAlignment>,
}

impl GeoReferencer {
    /// A geo-referencer whose `enu` frame is at `datum_lat_lon_deg` when given, else at the
    /// first fix with a position.
    pub fn new(options: GeoReferencerOptions, datum_lat_lon_deg: Option<[f64; 2]>) -> Self {
        GeoReferencer {
            options,
            frame: datum_lat_lon_deg.and_then(|[lat, lon]| LocalFrame::new(lat, lon, 0.0).ok()),
            fixes: Vec::new(),
            alignment: None,
        }
    }

    /// Keeps a fix received at host time `time_s`; whether it carried a usable position.
    ///
    /// # Errors
    /// The fix's position or covariance cannot be expressed in the `enu` frame.
    pub fn add_fix(&mut self, time_s: f64, fix: &GpsFix) -> Result<bool, GeoRefError> {
        if !fix.has_position() {
            return Ok(false);
        }
        let measurement =
            GpsMeasurement::in_frame_or_first(fix, &mut self.frame, &self.options.gps)?;
        self.fixes.push(TimedFix {
            time_s,
            measurement,
        });
        Ok(true)
    }

    /// Fits `enu_from_map` to the fixes against `trajectory` (host time and pose in the map,
    /// in time order) as it stands now; the alignment once the heading is determined (the last
    /// one found while a new fit is not).
    pub fn align(&mut self, trajectory: &[(f64, Pose2)]) -> Option<MapAlignment> {
        let pairs: Vec<AlignmentPair> = self
            .fixes
            .iter()
            .filter_map(|fix| {
                let pose = pose_at(trajectory, fix.time_s, self.options.max_pose_gap_s)?;
                let antenna_in_map = pose.transform_point(self.options.antenna_in_robot);
                Some(AlignmentPair::new(antenna_in_map, &fix.measurement))
            })
            .collect();
        // A fit that does not settle, or whose heading is not determined for now, leaves the
        // last alignment in place: the map does not lose its place on the image.
        if let Some(alignment) = fit_without_jumps(&pairs, &self.options) {
            self.alignment = Some(alignment);
        }
        self.alignment
    }

    /// The last alignment [`GeoReferencer::align`] found, if the heading was determined.
    pub fn alignment(&self) -> Option<MapAlignment> {
        self.alignment
    }

    /// The `enu` frame, once there is a datum.
    pub fn frame(&self) -> Option<&LocalFrame> {
        self.frame.as_ref()
    }

    /// Fixes kept so far.
    pub fn fixes(&self) -> usize {
        self.fixes.len()
    }
}

/// Rounds of [`fit_without_jumps`] in which a pair set aside may come back into the fit.
const FREE_ROUNDS: usize = 8;

/// The rigid alignment of `pairs` with the pairs outside the gate left out, refitted until
/// the set of inliers settles; `None` while the heading is not determined.
fn fit_without_jumps(
    pairs: &[AlignmentPair],
    options: &GeoReferencerOptions,
) -> Option<MapAlignment> {
    let mut inlier = vec![true; pairs.len()];
    // Each round either settles or moves at least one pair. In the first rounds a pair set
    // aside may come back once the fit has moved; after them pairs only leave, so the set
    // settles within as many more rounds as there are pairs: a trajectory that bends away
    // from the fixes slowly, peeling off a few pairs a round, still gets its alignment.
    for round in 0..FREE_ROUNDS + pairs.len() + 1 {
        let used: Vec<AlignmentPair> = pairs
            .iter()
            .zip(&inlier)
            .filter_map(|(p, &keep)| keep.then_some(*p))
            .collect();
        let fit = RigidAlignment2d::estimate(&used, &options.alignment).ok()?;
        let next: Vec<bool> = pairs
            .iter()
            .zip(&inlier)
            .map(|(pair, &was_inlier)| {
                (was_inlier || round < FREE_ROUNDS)
                    && squared_mahalanobis(&fit, pair) <= options.jump_gate_chi2
            })
            .collect();
        // Never leave fewer than two pairs: the alignment would not be determined.
        let settled = next == inlier || next.iter().filter(|&&k| k).count() < 2;
        if settled {
            let heading_sigma_rad = fit.covariance[(2, 2)].max(0.0).sqrt();
            return (heading_sigma_rad <= options.max_heading_sigma_rad).then_some(MapAlignment {
                enu_from_map: fit.enu_from_map,
                covariance: fit.covariance,
                pairs_used: used.len(),
                jumps: pairs.len() - used.len(),
                rms_residual_m: fit.rms_residual_m,
            });
        }
        inlier = next;
    }
    None
}

/// `rᵀ Σ⁻¹ r` of the pair's residual under `fit`, with the fix's covariance.
fn squared_mahalanobis(fit: &RigidAlignment2d, pair: &AlignmentPair) -> f64 {
    let predicted = fit.enu_from_map.transform_point(pair.point_in_map);
    let r = nalgebra::Vector2::new(
        predicted[0] - pair.point_in_enu[0],
        predicted[1] - pair.point_in_enu[1],
    );
    match pair.covariance_in_enu_m2.try_inverse() {
        Some(information) => (r.transpose() * information * r)[(0, 0)],
        None => f64::INFINITY,
    }
}

/// The pose at `time_s` on `trajectory`, interpolated between the poses around it; `None`
/// outside the trajectory or across a gap longer than `max_gap_s`.
fn pose_at(trajectory: &[(f64, Pose2)], time_s: f64, max_gap_s: f64) -> Option<Pose2> {
    let after = trajectory.partition_point(|(t, _)| *t < time_s);
    let Some(&(t1, p1)) = trajectory.get(after) else {
        let &(t0, p0) = trajectory.last()?;
        return (time_s - t0 <= max_gap_s).then_some(p0);
    };
    if after == 0 {
        return (t1 - time_s <= max_gap_s).then_some(p1);
    }
    let (t0, p0) = trajectory[after - 1];
    if t1 - t0 > max_gap_s {
        return None;
    }
    let s = if t1 > t0 {
        (time_s - t0) / (t1 - t0)
    } else {
        0.0
    };
    // Along the relative motion, so the heading takes the short way round.
    let step = p0.inverse() * p1;
    Some(p0 * Pose2::new(s * step.x_m, s * step.y_m, s * step.theta_rad))
}

#[cfg(test)]
mod tests {
    use protocol::{FixQuality, FixSource, GpsFixMsg, Position};

    use super::*;

    const DATUM: [f64; 2] = [48.0, 11.0];

    /// A fix at `point_in_enu` of the datum's frame.
    fn fix_at(frame: &LocalFrame, point_in_enu: [f64; 2]) -> GpsFixMsg {
        let [lon_deg, lat_deg] = frame.to_lon_lat_deg(point_in_enu).expect("in range");
        GpsFixMsg {
            position: Some(Position {
                lat_ndeg: (lat_deg * 1e9).round() as i64,
                lon_ndeg: (lon_deg * 1e9).round() as i64,
            }),
            ..no_fix()
        }
    }

    /// A report without a position.
    fn no_fix() -> GpsFixMsg {
        GpsFixMsg {
            stamp_us: 0,
            source: FixSource::Gga,
            talker: *b"GP",
            date: None,
            time: None,
            quality: FixQuality::Gps,
            position: None,
            alt_msl_mm: None,
            geoid_sep_mm: None,
            num_sats: Some(9),
            hdop_centi: Some(100),
            speed_mm_s: None,
            course_cdeg: None,
            gst: None,
        }
    }

    /// A robot driving an L in the map frame, one pose a second.
    fn l_shaped_trajectory() -> Vec<(f64, Pose2)> {
        (0..60)
            .map(|k| {
                let t = k as f64;
                let pose = if k < 30 {
                    Pose2::new(t, 0.0, 0.0)
                } else {
                    Pose2::new(29.0, t - 29.0, std::f64::consts::FRAC_PI_2)
                };
                (t, pose)
            })
            .collect()
    }

    #[test]
    fn finds_the_transform_and_sets_a_receiver_jump_aside() {
        let frame = LocalFrame::new(DATUM[0], DATUM[1], 0.0).expect("datum");
        let enu_from_map = Pose2::new(100.0, -40.0, 0.6);
        let trajectory = l_shaped_trajectory();
        let mut georef = GeoReferencer::new(GeoReferencerOptions::default(), Some(DATUM));
        for (k, (t, pose)) in trajectory.iter().enumerate() {
            let mut point = (enu_from_map * *pose).transform_point([0.0, 0.0]);
            if k == 40 {
                point[0] += 60.0;
            }
            let fix = GpsFix::from_msg(&fix_at(&frame, point));
            assert!(georef.add_fix(*t, &fix).expect("fix"));
        }
        let alignment = georef.align(&trajectory).expect("aligned");
        assert_eq!(alignment.jumps, 1);
        assert_eq!(alignment.pairs_used, 59);
        let error = alignment.enu_from_map.inverse() * enu_from_map;
        assert!(error.x_m.hypot(error.y_m) < 0.05, "{error:?}");
        assert!(error.theta_rad.abs() < 1e-3, "{error:?}");
    }

    #[test]
    fn a_map_that_bends_away_from_the_fixes_keeps_its_alignment() {
        let frame = LocalFrame::new(DATUM[0], DATUM[1], 0.0).expect("datum");
        let trajectory = l_shaped_trajectory();
        let mut georef = GeoReferencer::new(GeoReferencerOptions::default(), Some(DATUM));
        for (t, pose) in &trajectory {
            let fix = GpsFix::from_msg(&fix_at(&frame, [pose.x_m, pose.y_m]));
            georef.add_fix(*t, &fix).expect("fix");
        }
        // The SLAM's map bends away from the ground slowly, its error growing with the cube
        // of the time driven (65 m at the end): each fit sets a few more pairs aside, and it
        // takes more rounds than a pair may come back in before the set settles.
        let bent: Vec<(f64, Pose2)> = trajectory
            .iter()
            .map(|&(t, p)| (t, Pose2::new(p.x_m, p.y_m + 3e-4 * t.powi(3), p.theta_rad)))
            .collect();
        let alignment = georef
            .align(&bent)
            .expect("aligned on the pairs that agree");
        assert!(
            alignment.pairs_used >= 30 && alignment.jumps >= 10,
            "{alignment:?}"
        );
    }

    #[test]
    fn a_short_straight_drive_leaves_the_heading_open() {
        let frame = LocalFrame::new(DATUM[0], DATUM[1], 0.0).expect("datum");
        let trajectory: Vec<(f64, Pose2)> = (0..3)
            .map(|k| (k as f64, Pose2::new(0.5 * k as f64, 0.0, 0.0)))
            .collect();
        let mut georef = GeoReferencer::new(GeoReferencerOptions::default(), Some(DATUM));
        for (t, pose) in &trajectory {
            let fix = GpsFix::from_msg(&fix_at(&frame, [pose.x_m, pose.y_m]));
            georef.add_fix(*t, &fix).expect("fix");
        }
        assert_eq!(georef.align(&trajectory), None);
    }

    #[test]
    fn a_fix_without_position_is_not_kept() {
        let mut georef = GeoReferencer::new(GeoReferencerOptions::default(), None);
        assert!(
            !georef
                .add_fix(0.0, &GpsFix::from_msg(&no_fix()))
                .expect("no error")
        );
        assert_eq!(georef.fixes(), 0);
        assert!(georef.frame().is_none());
    }

    #[test]
    fn poses_are_interpolated_at_the_fix_time() {
        let trajectory = vec![
            (0.0, Pose2::new(0.0, 0.0, 3.0)),
            (1.0, Pose2::new(2.0, 0.0, -3.0)),
        ];
        let pose = pose_at(&trajectory, 0.5, 1.0).expect("inside");
        assert!((pose.theta_rad.abs() - std::f64::consts::PI).abs() < 0.3);
        assert!(pose_at(&trajectory, 3.0, 1.0).is_none());
        assert_eq!(pose_at(&trajectory, 1.5, 1.0), Some(trajectory[1].1));
        assert!(pose_at(&[(0.0, Pose2::IDENTITY), (5.0, Pose2::IDENTITY)], 2.0, 1.0).is_none());
    }
}
