//! Why a pose graph rejected an input or could not be optimised.

use std::fmt;

use super::edge::EdgeId;
use super::node::NodeId;

/// Why a pose-graph operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PoseGraphError {
    /// An edge or a request names a node the graph does not have.
    MissingNode(NodeId),
    /// A request names an edge the graph does not have.
    MissingEdge(EdgeId),
    /// An edge joins a node to itself.
    SelfLoop(NodeId),
    /// A pose, a measurement, an information matrix, a kernel parameter or the cost is NaN or
    /// infinite; the text says which.
    NonFinite(&'static str),
    /// An information matrix is not symmetric positive definite.
    InvalidInformation,
    /// A robust kernel parameter is not strictly positive.
    InvalidKernel,
    /// An optimisation option is out of range; the text names it.
    InvalidOptions(&'static str),
    /// This free node has no chain of edges to any fixed node, so its pose is not determined.
    Unanchored(NodeId),
    /// The damped normal equations stayed non positive definite up to the largest damping.
    Factorization,
    /// The sparse solver could not set up its ordering, symbolic factorisation or workspace
    /// (out of memory or index range).
    SolverSetup,
}

impl fmt::Display for PoseGraphError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PoseGraphError::MissingNode(node) => write!(f, "the pose graph has no {node}"),
            PoseGraphError::MissingEdge(edge) => write!(f, "the pose graph has no edge {}", edge.0),
            PoseGraphError::SelfLoop(node) => write!(f, "an edge joins {node} to itself"),
            PoseGraphError::NonFinite(what) => write!(f, "{what} is not finite"),
            PoseGraphError::InvalidInformation => {
                write!(
                    f,
                    "an information matrix is not symmetric positive definite"
                )
            }
            PoseGraphError::InvalidKernel => {
                write!(f, "a robust kernel parameter is not strictly positive")
            }
            PoseGraphError::InvalidOptions(what) => {
                write!(f, "invalid pose-graph options: {what}")
            }
            PoseGraphError::Unanchored(node) => {
                write!(f, "{node} is free and not connected to any fixed node")
            }
            PoseGraphError::Factorization => {
                write!(f, "the normal equations could not be factorised")
            }
            PoseGraphError::SolverSetup => {
                write!(f, "the sparse solver could not allocate its factorisation")
            }
        }
    }
}

impl std::error::Error for PoseGraphError {}
