//! Pose-graph constraints that know what their alignment could not see.
//!
//! In a corridor, point-to-line ICP pins the scan across the corridor and in rotation, but
//! along the corridor only the few beams on a far wall or a door frame hold it, and those may
//! be missing or misleading: local tracking can slide there by a metre or more. A constraint
//! of a few centimetres in every direction then tells the pose graph that the slide is
//! certain, and a loop closed later bends the whole trajectory instead of undoing it.
//!
//! The alignment's information about the robot's translation, once its rotation is solved
//! for (the Schur complement of ICP's information, [`IcpMatch::information`]), shows the
//! corridor: its weaker direction holds far less than its stronger one. When the ratio is
//! below [`SlamOptions::degenerate_information_ratio`], the constraint's covariance grows
//! along that direction by [`SlamOptions::degenerate_sigma_m`]² (degeneracy detection after
//! Zhang, Kaess and Singh 2016, "On Degeneracy of Optimization-based State Estimation
//! Problems"); elsewhere it stays at [`SlamOptions::odometry_sigma`] for scan-to-scan
//! constraints and [`SlamOptions::loop_closure_sigma`] for loop closures. A loop closure
//! found along a corridor is as blind along it as local tracking. A scan-to-scan constraint
//! between scans a laser at its full rate took centimetres apart is loosened only by what
//! its predictions and tracking's moves leave unknown
//! ([`TrackedScan::unmeasured_sigma_m`](super::TrackedScan::unmeasured_sigma_m)): the robot
//! had no time to stop or turn between them.
//!
//! [`IcpMatch::information`]: super::icp::IcpMatch::information

use nalgebra::{Matrix2, Matrix3, Vector2};

use super::options::SlamOptions;
use crate::pose_graph::Edge;

/// The information of the constraint between a scan and the one before, for a scan placed by
/// an alignment with `information_in_robot` (about a motion of the robot in its own frame,
/// `(x_m, y_m, theta_rad)`), or by none. Along the alignment's weak direction the motion is
/// what tracking predicted and moved, uncertain by `unmeasured_sigma_m`
/// ([`TrackedScan::unmeasured_sigma_m`](super::TrackedScan::unmeasured_sigma_m)), at most
/// [`SlamOptions::degenerate_sigma_m`]: at a laser's full rate, scans centimetres apart do
/// not slide by metres.
pub fn consecutive_information(
    options: &SlamOptions,
    information_in_robot: Option<&Matrix3<f64>>,
    unmeasured_sigma_m: f64,
) -> Matrix3<f64> {
    constraint_information(
        options.odometry_sigma,
        options.degenerate_sigma_m.min(unmeasured_sigma_m),
        options,
        information_in_robot,
    )
}

/// The information of a loop-closure constraint found by an alignment with
/// `information_in_robot`, as [`consecutive_information`] with
/// [`SlamOptions::loop_closure_sigma`].
pub fn closure_information(
    options: &SlamOptions,
    information_in_robot: Option<&Matrix3<f64>>,
) -> Matrix3<f64> {
    constraint_information(
        options.loop_closure_sigma,
        options.degenerate_sigma_m,
        options,
        information_in_robot,
    )
}

/// Standard deviations `[sigma_m, sigma_rad]`, loosened along the alignment's weak direction.
fn constraint_information(
    [sigma_m, sigma_rad]: [f64; 2],
    weak_sigma_m: f64,
    options: &SlamOptions,
    information_in_robot: Option<&Matrix3<f64>>,
) -> Matrix3<f64> {
    let floor = Edge::information_from_std_devs(sigma_m, sigma_m, sigma_rad);
    let weak = information_in_robot.and_then(|information| {
        weak_translation(information, options.degenerate_information_ratio)
    });
    let Some(direction) = weak else {
        return floor;
    };
    let mut covariance = Matrix3::from_diagonal(&nalgebra::Vector3::new(
        sigma_m * sigma_m,
        sigma_m * sigma_m,
        sigma_rad * sigma_rad,
    ));
    let along = direction * direction.transpose() * weak_sigma_m.powi(2);
    let mut translation = covariance.fixed_view_mut::<2, 2>(0, 0);
    translation += along;
    covariance.try_inverse().unwrap_or(floor)
}

/// The unit direction of translation in which `information` (over `(x, y, theta)`) holds less
/// than `ratio` times what it holds in the perpendicular one, the rotation solved for; `None`
/// when there is none or the information says nothing.
pub fn weak_translation(information: &Matrix3<f64>, ratio: f64) -> Option<Vector2<f64>> {
    let rotation = information[(2, 2)];
    // Also rules out NaN.
    if rotation.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let coupling = information.fixed_view::<2, 1>(0, 2);
    let translation: Matrix2<f64> =
        information.fixed_view::<2, 2>(0, 0) - coupling * coupling.transpose() / rotation;
    let eigen = translation.symmetric_eigen();
    let (weak, strong) = if eigen.eigenvalues[0] <= eigen.eigenvalues[1] {
        (0, 1)
    } else {
        (1, 0)
    };
    let strongest = eigen.eigenvalues[strong];
    (strongest > 0.0 && eigen.eigenvalues[weak] < ratio * strongest)
        .then(|| eigen.eigenvectors.column(weak).into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ICP's information from unit-weight point-to-line pairs: `(normal, point)` in the robot
    /// frame at zero heading.
    fn information(pairs: &[([f64; 2], [f64; 2])]) -> Matrix3<f64> {
        pairs
            .iter()
            .map(|&([nx, ny], [px, py])| {
                let jacobian = nalgebra::Vector3::new(nx, ny, -nx * py + ny * px);
                jacobian * jacobian.transpose()
            })
            .sum()
    }

    /// A corridor along x: walls at y = ±1 seen from 1 to 10 m, and `end_wall` points on a
    /// wall across it.
    fn corridor(end_wall: usize) -> Matrix3<f64> {
        let mut pairs = Vec::new();
        for i in 1..=10 {
            let x = f64::from(i);
            pairs.push(([0.0, 1.0], [x, -1.0]));
            pairs.push(([0.0, -1.0], [x, 1.0]));
        }
        for i in 0..end_wall {
            pairs.push(([-1.0, 0.0], [12.0, -0.5 + 0.1 * i as f64]));
        }
        information(&pairs)
    }

    #[test]
    fn a_corridor_is_weak_along_its_axis() {
        let direction = weak_translation(&corridor(0), 0.03).expect("degenerate");
        assert!(direction.x.abs() > 0.999, "{direction}");
        // A far wall across it, seen by enough beams, fixes it.
        assert!(weak_translation(&corridor(10), 0.03).is_none());
    }

    #[test]
    fn a_room_is_not_weak() {
        let pairs = [
            ([1.0, 0.0], [-3.0, 0.5]),
            ([1.0, 0.0], [-3.0, -0.5]),
            ([-1.0, 0.0], [4.0, 1.0]),
            ([0.0, -1.0], [1.0, 2.0]),
            ([0.0, 1.0], [-1.0, -2.0]),
            ([0.0, 1.0], [2.0, -2.0]),
        ];
        assert!(weak_translation(&information(&pairs), 0.03).is_none());
        assert!(weak_translation(&Matrix3::zeros(), 0.03).is_none());
    }

    #[test]
    fn the_constraint_loosens_only_along_the_weak_direction() {
        let options = SlamOptions::default();
        let [sigma_m, _] = options.odometry_sigma;
        let far_apart = 10.0;
        let floor = consecutive_information(&options, None, far_apart);
        assert_eq!(
            floor,
            consecutive_information(&options, Some(&corridor(10)), far_apart)
        );
        let loose = consecutive_information(&options, Some(&corridor(0)), far_apart);
        let covariance = loose.try_inverse().expect("invertible");
        let along = options.degenerate_sigma_m.powi(2) + sigma_m * sigma_m;
        assert!(
            (covariance[(0, 0)] - along).abs() < 1e-9 * along,
            "{covariance}"
        );
        assert!(
            (covariance[(1, 1)] - sigma_m * sigma_m).abs() < 1e-12,
            "{covariance}"
        );
        assert!(
            (covariance[(2, 2)] - floor.try_inverse().expect("invertible")[(2, 2)]).abs() < 1e-12
        );
    }

    #[test]
    fn a_motion_the_prediction_holds_loosens_no_further_than_its_uncertainty() {
        let options = SlamOptions::default();
        let [sigma_m, _] = options.odometry_sigma;
        let unmeasured_m = 0.05;
        let held = consecutive_information(&options, Some(&corridor(0)), unmeasured_m);
        let covariance = held.try_inverse().expect("invertible");
        let along = unmeasured_m * unmeasured_m + sigma_m * sigma_m;
        assert!(
            (covariance[(0, 0)] - along).abs() < 1e-9 * along,
            "{covariance}"
        );
    }
}
