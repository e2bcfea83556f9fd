//! An edge of the pose graph: a measured relative pose between two nodes, its information
//! matrix and an optional robust kernel.
//!
//! The edge from node `i` to node `j` measures `to_in_from` (`Z`, the pose of `j` in the frame of
//! `i`). Its error at the node poses `X_i`, `X_j` is the pose `Z⁻¹ · X_i⁻¹ · X_j` read as the vector
//! `(x, y, theta)`, with theta wrapped into `(-pi, pi]`; it is zero when the poses agree with the
//! measurement. The edge's cost is `ρ(eᵀ Ω e)`, where `Ω` is the information matrix (the inverse
//! covariance of the measurement, rows and columns in x, y, theta order) and `ρ` is the identity
//! or a [`RobustKernel`]. This is the SE(2) error of Grisetti et al., "A Tutorial on Graph-Based
//! SLAM" (2010), section IV, with the Jacobians of its additive `(x, y, theta)` parametrisation.

use nalgebra::{Matrix3, Vector3};

use super::error::PoseGraphError;
use super::node::NodeId;
use super::robust_kernel::RobustKernel;
use crate::geometry::Pose2;

/// The index of an edge in its [`PoseGraph`](super::PoseGraph), in the order edges were added.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct EdgeId(pub usize);

/// A relative-pose constraint between two nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// The node the measurement is taken from.
    pub from: NodeId,
    /// The node whose pose is measured.
    pub to: NodeId,
    /// The measured pose of node `to` in the frame of node `from` (`from_from_to`).
    pub to_in_from: Pose2,
    /// The inverse covariance of the measurement, in x, y, theta order (1/m², 1/rad²); symmetric
    /// positive definite.
    pub information: Matrix3<f64>,
    /// A robust kernel for edges that may be wrong, such as loop closures; `None` keeps the
    /// plain squared error.
    pub kernel: Option<RobustKernel>,
}

impl Edge {
    /// An edge from `from` to `to` measuring `to_in_from` with `information`, without a kernel.
    pub fn new(from: NodeId, to: NodeId, to_in_from: Pose2, information: Matrix3<f64>) -> Self {
        Edge {
            from,
            to,
            to_in_from,
            information,
            kernel: None,
        }
    }

    /// The same edge with its squared error passed through `kernel`.
    pub fn with_kernel(self, kernel: RobustKernel) -> Self {
        Edge {
            kernel: Some(kernel),
            ..self
        }
    }

    /// The diagonal information matrix of independent errors with standard deviations
    /// `sigma_x_m`, `sigma_y_m` (metres) and `sigma_theta_rad` (radians).
    pub fn information_from_std_devs(
        sigma_x_m: f64,
        sigma_y_m: f64,
        sigma_theta_rad: f64,
    ) -> Matrix3<f64> {
        Matrix3::from_diagonal(&Vector3::new(
            1.0 / (sigma_x_m * sigma_x_m),
            1.0 / (sigma_y_m * sigma_y_m),
            1.0 / (sigma_theta_rad * sigma_theta_rad),
        ))
    }

    /// Checks the edge on its own: distinct ends, a finite measurement, a finite symmetric
    /// positive definite information matrix and a valid kernel. Whether the nodes exist is
    /// checked by the graph.
    ///
    /// # Errors
    ///
    /// [`PoseGraphError::SelfLoop`], [`PoseGraphError::NonFinite`],
    /// [`PoseGraphError::InvalidInformation`] or [`PoseGraphError::InvalidKernel`], naming the
    /// first problem found.
    pub fn validate(&self) -> Result<(), PoseGraphError> {
        if self.from == self.to {
            return Err(PoseGraphError::SelfLoop(self.from));
        }
        if !pose_is_finite(self.to_in_from) {
            return Err(PoseGraphError::NonFinite("an edge measurement"));
        }
        if self.information.iter().any(|value| !value.is_finite()) {
            return Err(PoseGraphError::NonFinite("an edge information matrix"));
        }
        let scale = self.information.amax();
        let asymmetry = (self.information - self.information.transpose()).amax();
        if asymmetry > 1e-9 * scale || self.information.cholesky().is_none() {
            return Err(PoseGraphError::InvalidInformation);
        }
        if let Some(kernel) = self.kernel {
            kernel.validate()?;
        }
        Ok(())
    }

    /// The error vector `(x, y, theta)` of `Z⁻¹ · X_from⁻¹ · X_to` for the node poses
    /// `from_in_map` and `to_in_map`; zero when they agree with the measurement.
    pub fn error(&self, from_in_map: Pose2, to_in_map: Pose2) -> Vector3<f64> {
        let residual = self.to_in_from.inverse() * (from_in_map.inverse() * to_in_map);
        Vector3::new(residual.x_m, residual.y_m, residual.theta_rad)
    }

    /// The squared Mahalanobis error `eᵀ Ω e` (the edge's χ²) at the given node poses.
    pub fn chi2(&self, from_in_map: Pose2, to_in_map: Pose2) -> f64 {
        let error = self.error(from_in_map, to_in_map);
        error.dot(&(self.information * error))
    }

    /// The error and its Jacobians with respect to `(x_m, y_m, theta_rad)` of the `from` and the
    /// `to` pose, at the given node poses.
    pub(crate) fn linearize(&self, from_in_map: Pose2, to_in_map: Pose2) -> Linearization {
        let error = self.error(from_in_map, to_in_map);
        let (sin_from, cos_from) = from_in_map.theta_rad.sin_cos();
        let (sin_z, cos_z) = self.to_in_from.theta_rad.sin_cos();
        let dx = to_in_map.x_m - from_in_map.x_m;
        let dy = to_in_map.y_m - from_in_map.y_m;
        // Rᵀ(theta_from + theta_z) = Rᵀ(theta_z) · Rᵀ(theta_from): rotates map vectors into the
        // frame of the measured pose.
        let (sin_sum, cos_sum) = (from_in_map.theta_rad + self.to_in_from.theta_rad).sin_cos();
        // d/dtheta_from of Rᵀ(theta_from) · (t_to − t_from), then rotated by Rᵀ(theta_z).
        let q_x = -sin_from * dx + cos_from * dy;
        let q_y = -cos_from * dx - sin_from * dy;
        let de_x_dtheta = cos_z * q_x + sin_z * q_y;
        let de_y_dtheta = -sin_z * q_x + cos_z * q_y;
        #[rustfmt::skip]
        let jacobian_from = Matrix3::new(
            -cos_sum, -sin_sum, de_x_dtheta,
            sin_sum, -cos_sum, de_y_dtheta,
            0.0, 0.0, -1.0,
        );
        #[rustfmt::skip]
        let jacobian_to = Matrix3::new(
            cos_sum, sin_sum, 0.0,
            -sin_sum, cos_sum, 0.0,
            0.0, 0.0, 1.0,
        );
        Linearization {
            error,
            jacobian_from,
            jacobian_to,
        }
    }
}

/// An edge's error and its Jacobians at one pair of node poses.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Linearization {
    /// The error vector `(x, y, theta)`.
    pub(crate) error: Vector3<f64>,
    /// d error / d (x, y, theta) of the `from` node.
    pub(crate) jacobian_from: Matrix3<f64>,
    /// d error / d (x, y, theta) of the `to` node.
    pub(crate) jacobian_to: Matrix3<f64>,
}

/// Whether every component of `pose` is finite.
pub(crate) fn pose_is_finite(pose: Pose2) -> bool {
    pose.x_m.is_finite() && pose.y_m.is_finite() && pose.theta_rad.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edge() -> Edge {
        Edge::new(
            NodeId(0),
            NodeId(1),
            Pose2::new(1.0, 0.2, 0.3),
            Edge::information_from_std_devs(0.1, 0.2, 0.05),
        )
    }

    #[test]
    fn test_error_is_zero_when_poses_agree() {
        let edge = edge();
        let from_in_map = Pose2::new(2.0, -1.0, 2.5);
        let to_in_map = from_in_map * edge.to_in_from;
        assert!(edge.error(from_in_map, to_in_map).amax() < 1e-12);
        assert!(edge.chi2(from_in_map, to_in_map) < 1e-20);
    }

    #[test]
    fn test_error_angle_is_wrapped() {
        let edge = Edge::new(
            NodeId(0),
            NodeId(1),
            Pose2::new(0.0, 0.0, 3.0),
            Matrix3::identity(),
        );
        let error = edge.error(Pose2::IDENTITY, Pose2::new(0.0, 0.0, -3.0));
        assert!(
            (error.z - (std::f64::consts::TAU - 6.0)).abs() < 1e-12,
            "{error}"
        );
    }

    #[test]
    fn test_jacobians_match_finite_differences() {
        let edge = edge();
        let from_in_map = Pose2::new(2.0, -1.0, 2.9);
        let to_in_map = Pose2::new(2.5, 0.4, -3.0);
        let linearization = edge.linearize(from_in_map, to_in_map);
        let step = 1e-7;
        let nudge = |pose: Pose2, axis: usize, amount: f64| {
            let mut values = [pose.x_m, pose.y_m, pose.theta_rad];
            values[axis] += amount;
            Pose2::new(values[0], values[1], values[2])
        };
        for axis in 0..3 {
            let numeric_from = (edge.error(nudge(from_in_map, axis, step), to_in_map)
                - edge.error(nudge(from_in_map, axis, -step), to_in_map))
                / (2.0 * step);
            let numeric_to = (edge.error(from_in_map, nudge(to_in_map, axis, step))
                - edge.error(from_in_map, nudge(to_in_map, axis, -step)))
                / (2.0 * step);
            let analytic_from = linearization.jacobian_from.column(axis);
            let analytic_to = linearization.jacobian_to.column(axis);
            assert!(
                (numeric_from - analytic_from).amax() < 1e-6,
                "from, axis {axis}"
            );
            assert!((numeric_to - analytic_to).amax() < 1e-6, "to, axis {axis}");
        }
    }

    #[test]
    fn test_validate() {
        assert_eq!(edge().validate(), Ok(()));
        let self_loop = Edge {
            to: NodeId(0),
            ..edge()
        };
        assert_eq!(
            self_loop.validate(),
            Err(PoseGraphError::SelfLoop(NodeId(0)))
        );
        let mut asymmetric = edge();
        asymmetric.information[(0, 1)] = 1.0;
        assert_eq!(
            asymmetric.validate(),
            Err(PoseGraphError::InvalidInformation)
        );
        let mut singular = edge();
        singular.information[(2, 2)] = 0.0;
        assert_eq!(singular.validate(), Err(PoseGraphError::InvalidInformation));
        let nan_measurement = Edge {
            to_in_from: Pose2::new(f64::NAN, 0.0, 0.0),
            ..edge()
        };
        assert!(matches!(
            nan_measurement.validate(),
            Err(PoseGraphError::NonFinite(_))
        ));
        let bad_kernel = edge().with_kernel(RobustKernel::Huber { delta: -1.0 });
        assert_eq!(bad_kernel.validate(), Err(PoseGraphError::InvalidKernel));
    }
}
