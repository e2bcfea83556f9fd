//! What a loop closure would tell the graph: the information it adds about the scan's pose
//! relative to the place it closes on.
//!
//! A closure measures a relative pose the graph already holds with some covariance `P` (from
//! [`relative_covariances`](crate::pose_graph::relative_covariances)); the closure itself has
//! covariance `R`. For Gaussians the mutual information between the measurement and the
//! relative pose is `½ ln det(I + R⁻¹ P)`, nats: the log of how much the closure shrinks the
//! volume of the pose's uncertainty. It is the measure information-based pose SLAM uses to
//! add only informative links (Ila, Porta and Andrade-Cetto 2010, "Information-based compact
//! pose SLAM"). Right after a closure, `P` is about `R` (the closure plus the few scans
//! tracked since) and another closure adds about `½ ln 2³ ≈ 1.04` nats; with every scan
//! tracked since, `P` and the gain grow. The relative covariance is an upper bound of the
//! true one (the Dijkstra projection ignores parallel paths), so the gain is too: a search
//! it skips is certainly uninformative by the graph's own model.

use nalgebra::Matrix3;

/// The information (nats) a closure with covariance `closure` adds about a relative pose the
/// graph holds with covariance `relative` (both x, y, theta in the same frame); infinite when
/// either covariance is singular or not finite, so such a closure is always worth a search.
pub fn closure_gain_nats(relative: &Matrix3<f64>, closure: &Matrix3<f64>) -> f64 {
    let (combined, own) = ((relative + closure).determinant(), closure.determinant());
    if own <= 0.0 || combined <= 0.0 || !own.is_finite() || !combined.is_finite() {
        return f64::INFINITY;
    }
    0.5 * (combined / own).ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_closure_as_certain_as_the_pose_halves_its_uncertainty_in_each_direction() {
        let closure = Matrix3::from_diagonal(&nalgebra::Vector3::new(9e-4, 9e-4, 7.6e-5));
        let gain = closure_gain_nats(&closure, &closure);
        assert!((gain - 1.5 * 2f64.ln()).abs() < 1e-12, "{gain}");
        // Ten times as uncertain: ½ ln 11³.
        let gain = closure_gain_nats(&(closure * 10.0), &closure);
        assert!((gain - 1.5 * 11f64.ln()).abs() < 1e-9, "{gain}");
        // A pose known exactly relative to the place learns nothing.
        assert_eq!(closure_gain_nats(&Matrix3::zeros(), &closure), 0.0);
    }

    #[test]
    fn the_gain_does_not_depend_on_the_frame_both_are_in() {
        let relative = Matrix3::new(4e-3, 1e-3, 2e-4, 1e-3, 1e-3, 1e-4, 2e-4, 1e-4, 5e-4);
        let closure = Matrix3::from_diagonal(&nalgebra::Vector3::new(9e-4, 4e-4, 7.6e-5));
        let (s, c) = 0.7f64.sin_cos();
        let rotation = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let turned = |m: &Matrix3<f64>| rotation * m * rotation.transpose();
        let gain = closure_gain_nats(&relative, &closure);
        let turned_gain = closure_gain_nats(&turned(&relative), &turned(&closure));
        assert!((gain - turned_gain).abs() < 1e-9, "{gain} {turned_gain}");
        assert!(closure_gain_nats(&relative, &Matrix3::zeros()).is_infinite());
    }
}
