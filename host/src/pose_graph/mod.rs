//! A 2D pose graph and its sparse nonlinear least-squares optimiser.
//!
//! Nodes are robot poses in the map frame; edges are measured relative poses between them
//! (odometry, scan matches, loop closures), each with an information matrix and optionally a
//! robust kernel. [`PoseGraph::optimize`] moves the free nodes to minimise the sum of the edges'
//! squared Mahalanobis errors by Levenberg–Marquardt on the sparse normal equations, which are
//! reordered by approximate minimum degree and solved by `faer`'s supernodal sparse Cholesky
//! factorisation, whose symbolic part is computed once per graph topology.
//!
//! * [`PoseGraph`], [`Node`], [`NodeId`]: the graph and its pose variables.
//! * [`Edge`], [`EdgeId`]: a relative-pose constraint and its SE(2) error.
//! * [`RobustKernel`]: Huber and Cauchy costs for constraints that may be wrong.
//! * [`relative_covariances`]: how uncertain one node's pose is relative to every other
//!   ([`RelativeCovariances`]); [`relative_covariance`], relative to one.
//! * [`OptimizeOptions`], [`OptimizeReport`]: how to iterate and what happened.
//! * [`PoseGraphError`]: why an input was refused or optimisation failed.
//! * [`synthetic`]: graphs with known true poses, for tests and benchmarks.

mod adjacency;
mod edge;
mod error;
mod graph;
mod node;
mod normal_equations;
mod optimizer;
mod relative_covariance;
mod robust_kernel;
pub mod synthetic;

pub use edge::{Edge, EdgeId};
pub use error::PoseGraphError;
pub use graph::PoseGraph;
pub use node::{Node, NodeId};
pub use optimizer::{OptimizeOptions, OptimizeReport};
pub use relative_covariance::{RelativeCovariances, relative_covariance, relative_covariances};
pub use robust_kernel::RobustKernel;
