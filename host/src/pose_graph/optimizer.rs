//! Levenberg–Marquardt over the pose graph: options, report and the iteration itself.
//!
//! Each iteration linearises every edge at the current poses (robust kernels enter as weights,
//! iteratively reweighted least squares), solves the damped normal equations
//! `(H + lambda · diag(H)) Δ = −b`, and evaluates the cost at the moved poses. A step that lowers
//! the cost is kept and `lambda` shrinks according to how well the linear model predicted the
//! gain; a step that does not is undone and `lambda` grows, which turns the next step towards
//! a short gradient step. The damping schedule is Nielsen's (Madsen, Nielsen and Tingleff,
//! "Methods for Non-Linear Least Squares Problems", 2004, section 3.2). Optimisation stops when
//! a step changes the cost by less than a fraction of it.

use serde::{Deserialize, Serialize};

use super::edge::Edge;
use super::error::PoseGraphError;
use super::node::Node;
use super::normal_equations::NormalEquations;
use super::robust_kernel::robust_cost;

/// Smallest damping used, so that a growing `lambda` can always escape from zero.
const MIN_LAMBDA: f64 = 1e-12;
/// Damping beyond which further rejected steps end the optimisation.
const MAX_LAMBDA: f64 = 1e12;

/// How [`PoseGraph::optimize`](super::PoseGraph::optimize) iterates and when it stops.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OptimizeOptions {
    /// The most linear solves to run, accepted or rejected; 0 only evaluates the cost.
    pub max_iterations: usize,
    /// Stop once a step changes the cost by less than this fraction of it; `>= 0`.
    pub relative_cost_tolerance: f64,
    /// The Marquardt damping `lambda` of the first step, relative to the diagonal of `H`;
    /// `> 0`. Small values start close to Gauss–Newton.
    pub initial_lambda: f64,
}

impl Default for OptimizeOptions {
    fn default() -> Self {
        OptimizeOptions {
            max_iterations: 100,
            relative_cost_tolerance: 1e-9,
            initial_lambda: 1e-4,
        }
    }
}

impl OptimizeOptions {
    /// Checks that every option is in range.
    ///
    /// # Errors
    ///
    /// [`PoseGraphError::InvalidOptions`] naming the first option out of range.
    pub fn validate(&self) -> Result<(), PoseGraphError> {
        if !(self.relative_cost_tolerance >= 0.0 && self.relative_cost_tolerance.is_finite()) {
            return Err(PoseGraphError::InvalidOptions(
                "relative_cost_tolerance must be finite and >= 0",
            ));
        }
        if !(self.initial_lambda > 0.0 && self.initial_lambda.is_finite()) {
            return Err(PoseGraphError::InvalidOptions(
                "initial_lambda must be finite and > 0",
            ));
        }
        Ok(())
    }
}

/// What an optimisation did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OptimizeReport {
    /// Linear solves run, accepted or rejected.
    pub iterations: usize,
    /// The total cost `Σ ρ(eᵀ Ω e)` before optimising, over the edges with a free end (an
    /// edge between two fixed nodes adds a constant); this is χ² when no edge has a kernel.
    pub initial_cost: f64,
    /// The same cost after optimising.
    pub final_cost: f64,
    /// Whether the stopping test on the relative cost change was met (or there was nothing to
    /// optimise) before `max_iterations` ran out or the damping reached its limit.
    pub converged: bool,
}

/// The total robust cost of `edges` at the poses of `nodes`.
pub(crate) fn total_cost(nodes: &[Node], edges: &[Edge]) -> f64 {
    edges
        .iter()
        .map(|edge| {
            let chi2 = edge.chi2(nodes[edge.from.0].pose_in_map, nodes[edge.to.0].pose_in_map);
            robust_cost(edge.kernel, chi2)
        })
        .sum()
}

/// Runs Levenberg–Marquardt on the poses of `nodes`, with `system` laid out for `nodes` and
/// `edges`; on return `nodes` hold the best poses found.
///
/// # Errors
///
/// [`PoseGraphError::NonFinite`] if the initial cost is not finite;
/// [`PoseGraphError::Factorization`] if the normal equations cannot be factorised even with the
/// largest damping.
pub(crate) fn levenberg_marquardt(
    nodes: &mut Vec<Node>,
    edges: &[Edge],
    system: &mut NormalEquations,
    options: &OptimizeOptions,
) -> Result<OptimizeReport, PoseGraphError> {
    let mut cost = system.linearize(nodes, edges);
    if !cost.is_finite() {
        return Err(PoseGraphError::NonFinite("the initial cost"));
    }
    let initial_cost = cost;
    let mut converged = cost == 0.0 || system.variable_count() == 0;
    let mut lambda = options.initial_lambda;
    let mut lambda_growth = 2.0;
    let mut iterations = 0;
    let mut candidate = nodes.clone();
    let mut stale_linearization = false;
    while !converged && iterations < options.max_iterations {
        if stale_linearization {
            system.linearize(nodes, edges);
            stale_linearization = false;
        }
        iterations += 1;
        let predicted_reduction = match system.solve_damped(lambda) {
            Ok(predicted_reduction) => predicted_reduction,
            Err(error) => {
                lambda *= lambda_growth;
                lambda_growth *= 2.0;
                if lambda > MAX_LAMBDA {
                    return Err(error);
                }
                continue;
            }
        };
        system.apply_step(nodes, &mut candidate);
        let new_cost = system.free_cost(&candidate, edges);
        let change_is_small = (cost - new_cost).abs() <= options.relative_cost_tolerance * cost;
        if new_cost < cost {
            // Gain ratio: actual over predicted reduction; near 1 the model is trustworthy.
            let gain_ratio = if predicted_reduction > 0.0 {
                (cost - new_cost) / predicted_reduction
            } else {
                1.0
            };
            lambda = (lambda * (1.0 / 3.0_f64).max(1.0 - (2.0 * gain_ratio - 1.0).powi(3)))
                .max(MIN_LAMBDA);
            lambda_growth = 2.0;
            std::mem::swap(nodes, &mut candidate);
            cost = new_cost;
            stale_linearization = true;
            converged = change_is_small || cost == 0.0;
        } else {
            // A NaN cost compares false above and lands here too: the step is undone.
            converged = new_cost.is_finite() && change_is_small;
            lambda *= lambda_growth;
            lambda_growth *= 2.0;
            if lambda > MAX_LAMBDA {
                break;
            }
        }
    }
    Ok(OptimizeReport {
        iterations,
        initial_cost,
        final_cost: cost,
        converged,
    })
}
