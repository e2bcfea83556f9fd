//! Data association for a batch of measurements by Joint Compatibility Branch and Bound
//! (Neira and Tardós, "Data association in stochastic mapping using the joint compatibility
//! test", IEEE T-RA 2001).
//!
//! Each measurement comes with its individually compatible candidates (pairings that pass a
//! Mahalanobis gate on their own). JCBB searches the interpretation tree for the hypothesis
//! with the most pairings whose innovations are *jointly* compatible, i.e. whose stacked
//! innovation `ν` passes `νᵀ S⁻¹ ν < χ²(2k, confidence)` with the full joint covariance `S`
//! including the correlations through the robot and the map. One spurious pairing rarely
//! survives that test next to correct ones, which is what makes the batch robust where
//! nearest-neighbour gating is not. Ties in the number of pairings go to the lower joint
//! distance. A branch is cut when the measurements left that have any candidate could not
//! bring it level with the best hypothesis found. A node budget bounds the search; when it
//! runs out the best hypothesis found so far is returned.

use std::cell::RefCell;
use std::collections::HashMap;

use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// Read access to the entries of a state covariance: the matrix itself, or a view of one not
/// yet formed (the state a map join forms, [`crate::ekf_slam::joined_state`]).
pub trait CovarianceEntries {
    /// Entry `(row, column)`.
    fn entry(&self, row: usize, column: usize) -> f64;
}

impl CovarianceEntries for DMatrix<f64> {
    fn entry(&self, row: usize, column: usize) -> f64 {
        self[(row, column)]
    }
}

/// One block of a pairing's Jacobian: `matrix` (2 × w) multiplies state entries
/// `column .. column + w`.
#[derive(Debug, Clone, PartialEq)]
pub struct JacobianBlock {
    /// First state entry the block multiplies.
    pub column: usize,
    /// The block, two rows.
    pub matrix: DMatrix<f64>,
}

/// A measurement paired with one candidate target.
#[derive(Debug, Clone, PartialEq)]
pub struct PairingCandidate {
    /// Index of the target (a landmark).
    pub target: usize,
    /// Innovation of the pairing.
    pub innovation: Vector2<f64>,
    /// Jacobian of the predicted measurement with respect to the state, as sparse blocks.
    pub jacobian: Vec<JacobianBlock>,
    /// Individual squared Mahalanobis distance.
    pub distance2: f64,
}

/// Settings of the joint compatibility search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JcbbOptions {
    /// Confidence of the joint chi-square test.
    pub confidence: f64,
    /// Largest number of interpretation-tree nodes visited.
    pub max_nodes: usize,
}

impl Default for JcbbOptions {
    /// 99 % and 20 000 nodes.
    fn default() -> Self {
        JcbbOptions {
            confidence: 0.99,
            max_nodes: 20_000,
        }
    }
}

impl PairingCandidate {
    /// The pairing of `target` with this `innovation` and `jacobian`, its distance taken with
    /// the state `covariance` and measurement `noise`; `None` when `H P Hᵀ + R` is singular.
    pub fn new(
        target: usize,
        innovation: Vector2<f64>,
        jacobian: Vec<JacobianBlock>,
        covariance: &(impl CovarianceEntries + ?Sized),
        noise: &Matrix2<f64>,
    ) -> Option<PairingCandidate> {
        let s = cross_covariance(covariance, &jacobian, &jacobian) + noise;
        let distance2 = (innovation.transpose() * s.try_inverse()? * innovation)[0];
        Some(PairingCandidate {
            target,
            innovation,
            jacobian,
            distance2,
        })
    }
}

/// `H_a P H_bᵀ` for two sparse Jacobians.
pub fn cross_covariance(
    covariance: &(impl CovarianceEntries + ?Sized),
    a: &[JacobianBlock],
    b: &[JacobianBlock],
) -> Matrix2<f64> {
    let mut sum = Matrix2::zeros();
    for block_a in a {
        for block_b in b {
            for r in 0..block_a.matrix.ncols() {
                for c in 0..block_b.matrix.ncols() {
                    let p = covariance.entry(block_a.column + r, block_b.column + c);
                    if p == 0.0 {
                        continue;
                    }
                    for i in 0..2 {
                        let ap = block_a.matrix[(i, r)] * p;
                        for j in 0..2 {
                            sum[(i, j)] += ap * block_b.matrix[(j, c)];
                        }
                    }
                }
            }
        }
    }
    sum
}

/// The chi-square quantile at `confidence` for `dof` degrees of freedom.
///
/// The inverse CDF is an iterative search of a few microseconds and every scan asks for a
/// dozen quantiles, always the same few, so they are remembered per thread.
pub fn chi_square_quantile(dof: usize, confidence: f64) -> f64 {
    thread_local! {
        static KNOWN: RefCell<HashMap<(usize, u64), f64>> = RefCell::new(HashMap::new());
    }
    let key = (dof, confidence.to_bits());
    if let Some(known) = KNOWN.with(|known| known.borrow().get(&key).copied()) {
        return known;
    }
    let quantile = compute_chi_square_quantile(dof, confidence);
    KNOWN.with(|known| known.borrow_mut().insert(key, quantile));
    quantile
}

/// [`chi_square_quantile`] without the memory.
fn compute_chi_square_quantile(dof: usize, confidence: f64) -> f64 {
    match ChiSquared::new(dof.max(1) as f64) {
        Ok(distribution) => distribution.inverse_cdf(confidence),
        // Unreachable for dof ≥ 1; fall back to a bound that accepts nothing.
        Err(_) => 0.0,
    }
}

/// Runs JCBB. `candidates[i]` are measurement `i`'s individually compatible pairings,
/// `noise[i]` its measurement noise, `covariance` the state covariance. Returns one entry per
/// measurement: the chosen candidate's `target`, or `None`. No target is used twice.
pub fn jcbb(
    candidates: &[Vec<PairingCandidate>],
    noise: &[Matrix2<f64>],
    covariance: &(impl CovarianceEntries + ?Sized),
    options: &JcbbOptions,
) -> Vec<Option<usize>> {
    let m = candidates.len();
    let thresholds: Vec<f64> = (0..=m)
        .map(|k| chi_square_quantile(2 * k.max(1), options.confidence))
        .collect();
    // Every pairing's cross-covariance with every other, computed once: the search only
    // assembles blocks.
    let offsets: Vec<usize> = candidates
        .iter()
        .scan(0, |next, list| {
            let first = *next;
            *next += list.len();
            Some(first)
        })
        .collect();
    let flat: Vec<&PairingCandidate> = candidates.iter().flatten().collect();
    let mut cross = vec![Matrix2::zeros(); flat.len() * flat.len()];
    for (a, pa) in flat.iter().enumerate() {
        for (b, pb) in flat.iter().enumerate().skip(a) {
            let block = cross_covariance(covariance, &pa.jacobian, &pb.jacobian);
            cross[a * flat.len() + b] = block;
            cross[b * flat.len() + a] = block.transpose();
        }
    }
    // reachable[i]: measurements from i on that have a candidate at all, the most pairings
    // the rest of the tree can still add.
    let mut reachable = vec![0; m + 1];
    for i in (0..m).rev() {
        reachable[i] = reachable[i + 1] + usize::from(!candidates[i].is_empty());
    }
    let mut search = Search {
        candidates,
        noise,
        offsets,
        reachable,
        paired: Vec::with_capacity(m),
        rows: [vec![0.0; 2 * m], vec![0.0; 2 * m]],
        cross,
        flat_len: flat.len(),
        thresholds,
        best: vec![None; m],
        best_pairings: 0,
        best_distance2: f64::INFINITY,
        nodes_left: options.max_nodes,
        factor: DMatrix::zeros(2 * m, 2 * m),
        whitened: DVector::zeros(2 * m),
    };
    let mut hypothesis = vec![None; m];
    search.descend(0, &mut hypothesis, 0, 0.0);
    search
        .best
        .iter()
        .enumerate()
        .map(|(i, choice)| choice.map(|c| candidates[i][c].target))
        .collect()
}

/// The state of one search.
struct Search<'a> {
    candidates: &'a [Vec<PairingCandidate>],
    noise: &'a [Matrix2<f64>],
    /// Index of each measurement's first candidate in the flat list.
    offsets: Vec<usize>,
    /// Measurements from each index on that have a candidate.
    reachable: Vec<usize>,
    /// Flat indices of the current hypothesis's pairings, in order.
    paired: Vec<usize>,
    /// Scratch rows of the factor's extension.
    rows: [Vec<f64>; 2],
    /// `H_a P H_bᵀ` for flat candidates `a`, `b`, row-major.
    cross: Vec<Matrix2<f64>>,
    flat_len: usize,
    /// Lower Cholesky factor of the current hypothesis's joint covariance (top-left block).
    factor: DMatrix<f64>,
    /// The current hypothesis's innovation whitened by `factor`.
    whitened: DVector<f64>,
    thresholds: Vec<f64>,
    best: Vec<Option<usize>>,
    best_pairings: usize,
    best_distance2: f64,
    nodes_left: usize,
}

impl Search<'_> {
    /// Explores measurement `i` onwards with `pairings` pairings so far in `hypothesis`
    /// (entries: index into the measurement's candidate list) whose joint squared distance
    /// is `distance2`; rows `0..2·pairings` of `self.factor` and `self.whitened` hold the
    /// Cholesky factor of their joint covariance and the whitened innovation.
    fn descend(
        &mut self,
        i: usize,
        hypothesis: &mut Vec<Option<usize>>,
        pairings: usize,
        distance2: f64,
    ) {
        if self.nodes_left == 0 {
            return;
        }
        self.nodes_left -= 1;
        let m = self.candidates.len();
        if i == m {
            let better = pairings > self.best_pairings
                || (pairings == self.best_pairings && distance2 < self.best_distance2);
            if pairings > 0 && better {
                self.best = hypothesis.clone();
                self.best_pairings = pairings;
                self.best_distance2 = distance2;
            }
            return;
        }
        for c in 0..self.candidates[i].len() {
            // Pairing i can only win if the rest could still reach the best.
            if pairings + 1 + self.reachable[i + 1] < self.best_pairings {
                break;
            }
            let target = self.candidates[i][c].target;
            let taken = hypothesis[..i].iter().enumerate().any(|(k, choice)| {
                choice.is_some_and(|ck| self.candidates[k][ck].target == target)
            });
            if taken {
                continue;
            }
            let Some(added) = self.extend(i, c, pairings) else {
                continue;
            };
            if distance2 + added < self.thresholds[pairings + 1] {
                hypothesis[i] = Some(c);
                self.paired.push(self.offsets[i] + c);
                self.descend(i + 1, hypothesis, pairings + 1, distance2 + added);
                self.paired.pop();
                hypothesis[i] = None;
            }
        }
        // Leaving measurement i unpaired can only win if the rest could still beat the best.
        if pairings + self.reachable[i + 1] >= self.best_pairings.max(1) {
            self.descend(i + 1, hypothesis, pairings, distance2);
        }
    }

    /// Extends the Cholesky factor of the hypothesis's joint covariance by pairing
    /// measurement `i` with its candidate `c` as pairing number `k` (rows `2k`, `2k + 1`), and
    /// returns what the pairing adds to the joint squared distance; `None` when the joint
    /// covariance is not positive definite. O(k²) instead of refactoring the whole matrix.
    fn extend(&mut self, i: usize, c: usize, k: usize) -> Option<f64> {
        let flat = self.offsets[i] + c;
        debug_assert_eq!(self.paired.len(), k);
        // Solve L11 x = s for each of the two new rows of S21 (forward substitution).
        let mut rows = std::mem::take(&mut self.rows);
        let extension = self.extension(&mut rows, flat, i, c, k);
        self.rows = rows;
        extension
    }

    /// [`Self::extend`] with its scratch rows.
    fn extension(
        &mut self,
        rows: &mut [Vec<f64>; 2],
        flat: usize,
        i: usize,
        c: usize,
        k: usize,
    ) -> Option<f64> {
        for row in rows.iter_mut() {
            row.resize(2 * k, 0.0);
        }
        for (r, row) in rows.iter_mut().enumerate() {
            for (a, &fa) in self.paired.iter().enumerate() {
                let block = self.cross[flat * self.flat_len + fa];
                row[2 * a] = block[(r, 0)];
                row[2 * a + 1] = block[(r, 1)];
            }
            for q in 0..2 * k {
                let solved: f64 = row[..q]
                    .iter()
                    .enumerate()
                    .map(|(p, x)| self.factor[(q, p)] * x)
                    .sum();
                row[q] = (row[q] - solved) / self.factor[(q, q)];
            }
        }
        let own = self.cross[flat * self.flat_len + flat] + self.noise[i];
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let m00 = own[(0, 0)] - dot(&rows[0], &rows[0]);
        let m10 = own[(1, 0)] - dot(&rows[1], &rows[0]);
        let m11 = own[(1, 1)] - dot(&rows[1], &rows[1]);
        if m00.is_nan() || m00 <= 0.0 {
            return None;
        }
        let l00 = m00.sqrt();
        let l10 = m10 / l00;
        let rest = m11 - l10 * l10;
        if rest.is_nan() || rest <= 0.0 {
            return None;
        }
        let l11 = rest.sqrt();
        let nu = self.candidates[i][c].innovation;
        let whitened = &self.whitened;
        let w0 = (nu[0] - dot(&rows[0], &whitened.as_slice()[..2 * k])) / l00;
        let w1 = (nu[1] - dot(&rows[1], &whitened.as_slice()[..2 * k]) - l10 * w0) / l11;
        for (r, row) in rows.iter().enumerate() {
            for (q, value) in row.iter().enumerate() {
                self.factor[(2 * k + r, q)] = *value;
            }
        }
        self.factor[(2 * k, 2 * k)] = l00;
        self.factor[(2 * k + 1, 2 * k)] = l10;
        self.factor[(2 * k + 1, 2 * k + 1)] = l11;
        self.whitened[2 * k] = w0;
        self.whitened[2 * k + 1] = w1;
        Some(w0 * w0 + w1 * w1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A direct observation of 2D point `target` stored at `column` of a state, with the
    /// observation `z` and point estimate `at`.
    fn direct(target: usize, z: [f64; 2], at: [f64; 2]) -> PairingCandidate {
        PairingCandidate {
            target,
            innovation: Vector2::new(z[0] - at[0], z[1] - at[1]),
            jacobian: vec![JacobianBlock {
                column: 2 * target,
                matrix: DMatrix::identity(2, 2),
            }],
            distance2: 0.0,
        }
    }

    #[test]
    fn quantile_matches_tables() {
        assert!((chi_square_quantile(2, 0.99) - 9.2103).abs() < 1e-3);
        assert!((chi_square_quantile(4, 0.95) - 9.4877).abs() < 1e-3);
    }

    #[test]
    fn joint_test_rejects_the_consistent_shift_of_one_outlier() {
        // Three points fully correlated through a common offset of large variance: the
        // observations are all shifted by the same 3 m, except the last one which also
        // matches a second point 3 m off in the other direction.
        let points = [[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [17.0, 0.0]];
        let n = 2 * points.len();
        let common = 25.0;
        let mut covariance = DMatrix::identity(n, n) * 0.01;
        for a in 0..points.len() {
            for b in 0..points.len() {
                for d in 0..2 {
                    covariance[(2 * a + d, 2 * b + d)] += common;
                }
            }
        }
        let z = [[3.0, 0.0], [13.0, 0.0], [23.0, 0.0]];
        let candidates = vec![
            vec![direct(0, z[0], points[0])],
            vec![direct(1, z[1], points[1])],
            // The nearest in isolation is point 3 (at 17 m, 6 m away vs 3 m... both gate).
            vec![direct(3, z[2], points[3]), direct(2, z[2], points[2])],
        ];
        let noise = vec![Matrix2::identity() * 0.01; 3];
        let chosen = jcbb(&candidates, &noise, &covariance, &JcbbOptions::default());
        assert_eq!(chosen, vec![Some(0), Some(1), Some(2)]);
    }

    #[test]
    fn no_target_is_used_twice() {
        let covariance = DMatrix::identity(2, 2);
        let candidates = vec![
            vec![direct(0, [0.1, 0.0], [0.0, 0.0])],
            vec![direct(0, [0.0, 0.1], [0.0, 0.0])],
        ];
        let noise = vec![Matrix2::identity() * 0.01; 2];
        let chosen = jcbb(&candidates, &noise, &covariance, &JcbbOptions::default());
        assert_eq!(chosen.iter().filter(|c| c.is_some()).count(), 1);
    }

    #[test]
    fn empty_batch() {
        let chosen = jcbb(&[], &[], &DMatrix::zeros(0, 0), &JcbbOptions::default());
        assert!(chosen.is_empty());
    }
}
