//! The sparse normal equations `H Δ = −b` of a pose graph and their damped Cholesky solve.
//!
//! Each free node owns three consecutive variables `(x, y, theta)`; fixed nodes own none. An
//! edge between free nodes `i` and `j` touches the 3×3 blocks `ii`, `jj` and `ij` of `H`, so the
//! pattern of `H` is the node graph with every node blown up into a 3×3 block. The lower
//! triangle of that pattern is laid out once in compressed sparse column form and every edge
//! remembers where its blocks sit in the value array. `faer` computes a fill-reducing ordering
//! (approximate minimum degree) and the symbolic supernodal factorisation once for that layout;
//! each solve only refills the values and refactorises them numerically, in a workspace that is
//! also allocated once.
//!
//! Damping is Marquardt's: the diagonal of `H` is scaled by `1 + lambda`, which keeps the step
//! invariant to the units of the variables (metres against radians).

use std::fmt;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::{Matrix3, Vector3};

use super::edge::Edge;
use super::error::PoseGraphError;
use super::node::{Node, NodeId};
use super::robust_kernel::{robust_cost, robust_weight};
use crate::geometry::Pose2;

/// Offsets into the value array of the three columns of one stored 3×3 block. In an
/// off-diagonal block the entry in row `m`, column `k` is at `block[k] + m`; a diagonal block
/// stores only its lower triangle, entry `(m, k)` with `m >= k` at `block[k] + m − k`.
type Block = [usize; 3];

/// Where one edge adds into `H` and `b`; `None` for the parts that belong to a fixed node.
#[derive(Clone, Copy, Debug)]
struct EdgeSlots {
    /// Index of the first variable of the `from` node.
    from_variable: Option<usize>,
    /// Index of the first variable of the `to` node.
    to_variable: Option<usize>,
    /// Diagonal block of the `from` node.
    from_from: Option<Block>,
    /// Diagonal block of the `to` node.
    to_to: Option<Block>,
    /// The off-diagonal block, in the lower triangle; `true` if it holds `H_from,to` (the
    /// `from` node has the larger index), `false` if it holds `H_to,from`.
    off_diagonal: Option<(Block, bool)>,
}

/// The layout, values and factorisation of the normal equations of one graph topology (same
/// nodes, same edges, same fixed set).
pub(crate) struct NormalEquations {
    /// The edges with at least one free end, in edge order: the only ones the free nodes'
    /// equations and cost depend on.
    active_edges: Vec<usize>,
    /// For each of those, where it adds into `H` and `b`.
    edge_slots: Vec<EdgeSlots>,
    /// The free nodes, in order; free node `k` owns variables `3k..3k + 3`.
    free_nodes: Vec<usize>,
    /// Column pointers of the lower triangle of `H`; the first entry of every column is its
    /// diagonal.
    column_pointers: Vec<usize>,
    /// Row indices of the lower triangle of `H`, sorted within each column.
    row_indices: Vec<usize>,
    /// The values of the lower triangle of `H` at the last linearisation, without damping.
    hessian: Vec<f64>,
    /// The same with Marquardt damping, as last factorised.
    damped: Vec<f64>,
    /// The gradient vector `b`.
    gradient: Vec<f64>,
    /// The last step `Δ`.
    step: Vec<f64>,
    /// The fill-reducing ordering and symbolic factorisation of the pattern of `H`.
    symbolic: SymbolicCholesky<usize>,
    /// The values of the Cholesky factor, laid out by `symbolic`.
    factor_values: Vec<f64>,
    /// Scratch memory for the numeric factorisation and the solves.
    workspace: MemBuffer,
}

impl fmt::Debug for NormalEquations {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("NormalEquations")
            .field("variables", &self.gradient.len())
            .field("hessian_nonzeros", &self.hessian.len())
            .field("factor_nonzeros", &self.factor_values.len())
            .finish_non_exhaustive()
    }
}

impl NormalEquations {
    /// Lays out the normal equations for `nodes` and `edges`, orders and factorises their
    /// pattern symbolically and allocates the workspace.
    ///
    /// # Errors
    ///
    /// [`PoseGraphError::MissingNode`] if an edge names a node outside `nodes`;
    /// [`PoseGraphError::SolverSetup`] if the solver runs out of memory or index range.
    #[cfg(test)]
    pub(crate) fn new(nodes: &[Node], edges: &[Edge]) -> Result<Self, PoseGraphError> {
        let is_free = |node: NodeId| nodes.get(node.0).is_some_and(|node| !node.fixed);
        let free_nodes = (0..nodes.len()).filter(|&n| !nodes[n].fixed).collect();
        let active_edges = (0..edges.len())
            .filter(|&e| is_free(edges[e].from) || is_free(edges[e].to))
            .collect();
        Self::for_free_part(nodes, edges, free_nodes, active_edges)
    }

    /// [`Self::new`] given the graph's free nodes and the edges with a free end, each in
    /// order: the layout, and every pass of the solve, then cost what the free part holds,
    /// however much of the graph is fixed.
    ///
    /// # Errors
    ///
    /// As [`Self::new`].
    pub(crate) fn for_free_part(
        nodes: &[Node],
        edges: &[Edge],
        free_nodes: Vec<usize>,
        active_edges: Vec<usize>,
    ) -> Result<Self, PoseGraphError> {
        let block_count = free_nodes.len();
        let block_of = |node: NodeId| {
            if node.0 >= nodes.len() {
                return Err(PoseGraphError::MissingNode(node));
            }
            Ok(free_nodes.binary_search(&node.0).ok())
        };
        let active: Vec<&Edge> = active_edges.iter().map(|&e| &edges[e]).collect();

        // Block rows strictly below the diagonal in every block column, sorted.
        let mut lower_rows = vec![Vec::new(); block_count];
        for edge in &active {
            if let (Some(a), Some(b)) = (block_of(edge.from)?, block_of(edge.to)?) {
                lower_rows[a.min(b)].push(a.max(b));
            }
        }
        for rows in &mut lower_rows {
            rows.sort_unstable();
            rows.dedup();
        }

        let variable_count = 3 * block_count;
        let mut column_pointers = Vec::with_capacity(variable_count + 1);
        let mut row_indices = Vec::new();
        column_pointers.push(0);
        for (column, rows) in lower_rows.iter().enumerate() {
            for k in 0..3 {
                row_indices.extend(3 * column + k..3 * column + 3);
                for &row in rows {
                    row_indices.extend(3 * row..3 * row + 3);
                }
                column_pointers.push(row_indices.len());
            }
        }
        let diagonal_block =
            |block: usize| -> Block { [0, 1, 2].map(|k| column_pointers[3 * block + k]) };
        let off_diagonal_block = |row: usize, column: usize| -> Block {
            // Every edge between free nodes put `row` into `lower_rows[column]` above.
            let index = lower_rows[column].partition_point(|&r| r < row);
            [0, 1, 2].map(|k| column_pointers[3 * column + k] + (3 - k) + 3 * index)
        };
        let mut edge_slots = Vec::with_capacity(active.len());
        for edge in &active {
            let from = block_of(edge.from)?;
            let to = block_of(edge.to)?;
            let off_diagonal = match (from, to) {
                (Some(from), Some(to)) if from > to => Some((off_diagonal_block(from, to), true)),
                (Some(from), Some(to)) => Some((off_diagonal_block(to, from), false)),
                _ => None,
            };
            edge_slots.push(EdgeSlots {
                from_variable: from.map(|block| 3 * block),
                to_variable: to.map(|block| 3 * block),
                from_from: from.map(diagonal_block),
                to_to: to.map(diagonal_block),
                off_diagonal,
            });
        }

        let value_count = row_indices.len();
        let pattern = SymbolicSparseColMatRef::new_checked(
            variable_count,
            variable_count,
            &column_pointers,
            None,
            &row_indices,
        );
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|_| PoseGraphError::SolverSetup)?;
        let scratch = StackReq::or(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        );
        let workspace = MemBuffer::try_new(scratch).map_err(|_| PoseGraphError::SolverSetup)?;
        Ok(NormalEquations {
            active_edges,
            edge_slots,
            free_nodes,
            column_pointers,
            row_indices,
            hessian: vec![0.0; value_count],
            damped: vec![0.0; value_count],
            gradient: vec![0.0; variable_count],
            step: vec![0.0; variable_count],
            factor_values: vec![0.0; symbolic.len_val()],
            symbolic,
            workspace,
        })
    }

    /// The number of scalar variables, three per free node.
    pub(crate) fn variable_count(&self) -> usize {
        self.gradient.len()
    }

    /// Linearises every edge with a free end at the poses of `nodes`, fills `H` and `b` with
    /// the robustly reweighted contributions `w Jᵀ Ω J` and `w Jᵀ Ω e`, and returns their total
    /// robust cost ([`Self::free_cost`]: an edge between two fixed nodes
    /// adds a constant). `nodes` and `edges` must be those the layout was built for.
    pub(crate) fn linearize(&mut self, nodes: &[Node], edges: &[Edge]) -> f64 {
        self.hessian.fill(0.0);
        self.gradient.fill(0.0);
        let mut cost = 0.0;
        for (&index, slots) in self.active_edges.iter().zip(&self.edge_slots) {
            let edge = &edges[index];
            let from_in_map = nodes[edge.from.0].pose_in_map;
            let to_in_map = nodes[edge.to.0].pose_in_map;
            let linearization = edge.linearize(from_in_map, to_in_map);
            let weighted_error = edge.information * linearization.error;
            let chi2 = linearization.error.dot(&weighted_error);
            cost += robust_cost(edge.kernel, chi2);
            let weight = robust_weight(edge.kernel, chi2);
            let information = edge.information * weight;
            let weighted_error = weighted_error * weight;
            // Jᵀ Ω of each end, shared by its diagonal and off-diagonal blocks.
            let from_t_info = linearization.jacobian_from.transpose() * information;
            let to_t_info = linearization.jacobian_to.transpose() * information;
            if let (Some(block), Some(variable)) = (slots.from_from, slots.from_variable) {
                add_diagonal_block(
                    &mut self.hessian,
                    block,
                    &(from_t_info * linearization.jacobian_from),
                );
                add_vector(
                    &mut self.gradient,
                    variable,
                    &(linearization.jacobian_from.transpose() * weighted_error),
                );
            }
            if let (Some(block), Some(variable)) = (slots.to_to, slots.to_variable) {
                add_diagonal_block(
                    &mut self.hessian,
                    block,
                    &(to_t_info * linearization.jacobian_to),
                );
                add_vector(
                    &mut self.gradient,
                    variable,
                    &(linearization.jacobian_to.transpose() * weighted_error),
                );
            }
            if let Some((block, holds_from_to)) = slots.off_diagonal {
                let from_to = from_t_info * linearization.jacobian_to;
                let stored = if holds_from_to {
                    from_to
                } else {
                    from_to.transpose()
                };
                add_block(&mut self.hessian, block, &stored);
            }
        }
        cost
    }

    /// Solves `(H + lambda · diag(H)) Δ = −b` at the last linearisation and returns the
    /// reduction of the cost that the linear model predicts for `Δ`.
    ///
    /// # Errors
    ///
    /// [`PoseGraphError::Factorization`] if the damped matrix is not positive definite.
    pub(crate) fn solve_damped(&mut self, lambda: f64) -> Result<f64, PoseGraphError> {
        self.damped.copy_from_slice(&self.hessian);
        let diagonal = &self.column_pointers[..self.gradient.len()];
        for &index in diagonal {
            self.damped[index] += lambda * self.hessian[index];
        }
        let variable_count = self.gradient.len();
        let matrix = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(
                variable_count,
                variable_count,
                &self.column_pointers,
                None,
                &self.row_indices,
            ),
            &self.damped,
        );
        let stack = MemStack::new(&mut self.workspace);
        let factor = self
            .symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.factor_values,
                matrix,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                stack,
                Default::default(),
            )
            .map_err(|_| PoseGraphError::Factorization)?;
        for (step, gradient) in self.step.iter_mut().zip(&self.gradient) {
            *step = -gradient;
        }
        factor.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut self.step, variable_count, 1),
            Par::Seq,
            MemStack::new(&mut self.workspace),
        );
        // The Gauss–Newton model of the cost F = Σ eᵀ Ω e changes by 2 bᵀΔ + Δᵀ H Δ; with the
        // damped equations this reduction equals Δᵀ (lambda · diag(H) Δ − b).
        let predicted = diagonal
            .iter()
            .zip(self.step.iter().zip(&self.gradient))
            .map(|(&index, (&step, &gradient))| {
                step * (lambda * self.hessian[index] * step - gradient)
            })
            .sum();
        Ok(predicted)
    }

    /// Writes into `candidate` the poses of `nodes` moved by the last step; fixed nodes are
    /// copied unchanged.
    pub(crate) fn apply_step(&self, nodes: &[Node], candidate: &mut [Node]) {
        for (block, &node) in self.free_nodes.iter().enumerate() {
            let step = &self.step[3 * block..3 * block + 3];
            let pose = nodes[node].pose_in_map;
            candidate[node] = Node {
                pose_in_map: Pose2::new(
                    pose.x_m + step[0],
                    pose.y_m + step[1],
                    pose.theta_rad + step[2],
                ),
                ..nodes[node]
            };
        }
    }

    /// The total robust cost of the edges with a free end at the poses of `nodes`: what
    /// optimisation can change. An edge between two fixed nodes adds a constant, and leaving it
    /// out keeps the stopping test relative to what the free nodes can still gain however much
    /// of the graph is fixed.
    pub(crate) fn free_cost(&self, nodes: &[Node], edges: &[Edge]) -> f64 {
        self.active_edges
            .iter()
            .map(|&index| {
                let edge = &edges[index];
                let chi2 = edge.chi2(nodes[edge.from.0].pose_in_map, nodes[edge.to.0].pose_in_map);
                robust_cost(edge.kernel, chi2)
            })
            .sum()
    }

    /// The first variable of `node`, `None` for a fixed node.
    #[cfg(test)]
    fn variable_of(&self, node: NodeId) -> Option<usize> {
        self.free_nodes
            .binary_search(&node.0)
            .ok()
            .map(|block| 3 * block)
    }
}

/// Adds the lower triangle of the symmetric 3×3 `matrix` into the diagonal block at `block`.
fn add_diagonal_block(values: &mut [f64], block: Block, matrix: &Matrix3<f64>) {
    for (k, &start) in block.iter().enumerate() {
        for m in k..3 {
            values[start + m - k] += matrix[(m, k)];
        }
    }
}

/// Adds the 3×3 `matrix` into the off-diagonal block at `block`.
fn add_block(values: &mut [f64], block: Block, matrix: &Matrix3<f64>) {
    for (k, &start) in block.iter().enumerate() {
        for m in 0..3 {
            values[start + m] += matrix[(m, k)];
        }
    }
}

/// Adds `vector` into the three variables starting at `variable`.
fn add_vector(values: &mut [f64], variable: usize, vector: &Vector3<f64>) {
    for m in 0..3 {
        values[variable + m] += vector[m];
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;

    /// Five nodes, the first and the fourth fixed, with edges pointing both ways.
    fn nodes_and_edges() -> (Vec<Node>, Vec<Edge>) {
        let poses = [
            Pose2::new(0.0, 0.0, 0.0),
            Pose2::new(1.1, 0.1, 0.2),
            Pose2::new(2.0, 0.9, 1.4),
            Pose2::new(1.2, 2.1, 2.9),
            Pose2::new(-0.1, 1.0, -1.7),
        ];
        let nodes: Vec<Node> = poses
            .iter()
            .enumerate()
            .map(|(i, &pose_in_map)| Node {
                pose_in_map,
                fixed: i == 0 || i == 3,
            })
            .collect();
        let information = Matrix3::new(40.0, 3.0, 1.0, 3.0, 30.0, -2.0, 1.0, -2.0, 200.0);
        let step = Pose2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2);
        let pairs = [(0, 1), (2, 1), (2, 3), (4, 3), (4, 0), (1, 4), (4, 2)];
        let edges = pairs
            .iter()
            .map(|&(from, to)| Edge::new(NodeId(from), NodeId(to), step, information))
            .collect();
        (nodes, edges)
    }

    #[test]
    fn test_sparse_system_matches_dense_assembly() {
        let (nodes, edges) = nodes_and_edges();
        let mut system = NormalEquations::new(&nodes, &edges).unwrap();
        let cost = system.linearize(&nodes, &edges);
        let variable_count = system.variable_count();
        assert_eq!(variable_count, 9);

        // Dense H = Σ Jᵀ Ω J and b = Σ Jᵀ Ω e over the free variables.
        let mut dense_h = DMatrix::<f64>::zeros(variable_count, variable_count);
        let mut dense_b = DVector::<f64>::zeros(variable_count);
        let mut dense_cost = 0.0;
        for edge in &edges {
            let from_in_map = nodes[edge.from.0].pose_in_map;
            let to_in_map = nodes[edge.to.0].pose_in_map;
            let linearization = edge.linearize(from_in_map, to_in_map);
            dense_cost += edge.chi2(from_in_map, to_in_map);
            let mut jacobian = DMatrix::<f64>::zeros(3, variable_count);
            let ends = [
                (edge.from, linearization.jacobian_from),
                (edge.to, linearization.jacobian_to),
            ];
            for (node, block) in ends {
                if let Some(variable) = system.variable_of(node) {
                    jacobian.view_mut((0, variable), (3, 3)).copy_from(&block);
                }
            }
            dense_h += jacobian.transpose() * edge.information * &jacobian;
            dense_b += jacobian.transpose() * (edge.information * linearization.error);
        }
        assert!((cost - dense_cost).abs() < 1e-9 * dense_cost);

        let mut sparse_h = DMatrix::<f64>::zeros(variable_count, variable_count);
        for column in 0..variable_count {
            let entries = system.column_pointers[column]..system.column_pointers[column + 1];
            for index in entries {
                let row = system.row_indices[index];
                assert!(row >= column, "upper-triangle entry ({row}, {column})");
                sparse_h[(row, column)] += system.hessian[index];
                if row != column {
                    sparse_h[(column, row)] += system.hessian[index];
                }
            }
        }
        assert!((&sparse_h - &dense_h).amax() < 1e-9 * dense_h.amax());
        let sparse_b = DVector::from_column_slice(&system.gradient);
        assert!((&sparse_b - &dense_b).amax() < 1e-9 * dense_b.amax());

        // The damped solve against a dense Cholesky of the same damped matrix.
        let lambda = 0.25;
        system.solve_damped(lambda).unwrap();
        let mut damped_h = dense_h.clone();
        for i in 0..variable_count {
            damped_h[(i, i)] *= 1.0 + lambda;
        }
        let dense_step = damped_h.cholesky().unwrap().solve(&(-dense_b));
        let sparse_step = DVector::from_column_slice(&system.step);
        assert!((&sparse_step - &dense_step).amax() < 1e-9 * dense_step.amax());
    }
}
