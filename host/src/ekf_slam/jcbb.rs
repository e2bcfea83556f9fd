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
//! distance. A node budget bounds the search; when it runs out the best hypothesis found so
//! far is returned.

use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use statrs::distribution::{ChiSquared, ContinuousCDF};

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

/// `H_a P H_bᵀ` for two sparse Jacobians.
pub fn cross_covariance(
    covariance: &DMatrix<f64>,
    a: &[JacobianBlock],
    b: &[JacobianBlock],
) -> Matrix2<f64> {
    let mut sum = Matrix2::zeros();
    for block_a in a {
        for block_b in b {
            let p = covariance.view(
                (block_a.column, block_b.column),
                (block_a.matrix.ncols(), block_b.matrix.ncols()),
            );
            let product = &block_a.matrix * p * block_b.matrix.transpose();
            sum += Matrix2::new(
                product[(0, 0)],
                product[(0, 1)],
                product[(1, 0)],
                product[(1, 1)],
            );
        }
    }
    sum
}

/// The chi-square quantile at `confidence` for `dof` degrees of freedom.
pub fn chi_square_quantile(dof: usize, confidence: f64) -> f64 {
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
    covariance: &DMatrix<f64>,
    options: &JcbbOptions,
) -> Vec<Option<usize>> {
    let m = candidates.len();
    let thresholds: Vec<f64> = (0..=m)
        .map(|k| chi_square_quantile(2 * k.max(1), options.confidence))
        .collect();
    let mut search = Search {
        candidates,
        noise,
        covariance,
        thresholds,
        best: vec![None; m],
        best_pairings: 0,
        best_distance2: f64::INFINITY,
        nodes_left: options.max_nodes,
    };
    let mut hypothesis = vec![None; m];
    search.descend(0, &mut hypothesis, 0);
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
    covariance: &'a DMatrix<f64>,
    thresholds: Vec<f64>,
    best: Vec<Option<usize>>,
    best_pairings: usize,
    best_distance2: f64,
    nodes_left: usize,
}

impl Search<'_> {
    /// Explores measurement `i` onwards with `pairings` pairings so far in `hypothesis`
    /// (entries: index into the measurement's candidate list).
    fn descend(&mut self, i: usize, hypothesis: &mut Vec<Option<usize>>, pairings: usize) {
        if self.nodes_left == 0 {
            return;
        }
        self.nodes_left -= 1;
        let m = self.candidates.len();
        if i == m {
            if pairings > 0 && pairings >= self.best_pairings {
                let distance2 = self.joint_distance2(hypothesis).unwrap_or(f64::INFINITY);
                if pairings > self.best_pairings || distance2 < self.best_distance2 {
                    self.best = hypothesis.clone();
                    self.best_pairings = pairings;
                    self.best_distance2 = distance2;
                }
            }
            return;
        }
        for c in 0..self.candidates[i].len() {
            let target = self.candidates[i][c].target;
            let taken = hypothesis[..i].iter().enumerate().any(|(k, choice)| {
                choice.is_some_and(|ck| self.candidates[k][ck].target == target)
            });
            if taken {
                continue;
            }
            hypothesis[i] = Some(c);
            let compatible = self
                .joint_distance2(hypothesis)
                .is_some_and(|d2| d2 < self.thresholds[pairings + 1]);
            if compatible {
                self.descend(i + 1, hypothesis, pairings + 1);
            }
            hypothesis[i] = None;
        }
        // Leaving measurement i unpaired can only win if the rest could still beat the best.
        if pairings + (m - i - 1) >= self.best_pairings.max(1) {
            self.descend(i + 1, hypothesis, pairings);
        }
    }

    /// The joint squared Mahalanobis distance of `hypothesis`, `None` if its covariance is
    /// not positive definite.
    fn joint_distance2(&self, hypothesis: &[Option<usize>]) -> Option<f64> {
        let pairs: Vec<(usize, &PairingCandidate)> = hypothesis
            .iter()
            .enumerate()
            .filter_map(|(i, choice)| choice.map(|c| (i, &self.candidates[i][c])))
            .collect();
        let k = pairs.len();
        let mut s = DMatrix::zeros(2 * k, 2 * k);
        let mut nu = DVector::zeros(2 * k);
        for (a, (i, pa)) in pairs.iter().enumerate() {
            nu.fixed_rows_mut::<2>(2 * a).copy_from(&pa.innovation);
            for (b, (_, pb)) in pairs.iter().enumerate().skip(a) {
                let mut block = cross_covariance(self.covariance, &pa.jacobian, &pb.jacobian);
                if a == b {
                    block += self.noise[*i];
                }
                s.fixed_view_mut::<2, 2>(2 * a, 2 * b).copy_from(&block);
                s.fixed_view_mut::<2, 2>(2 * b, 2 * a)
                    .copy_from(&block.transpose());
            }
        }
        let cholesky = s.cholesky()?;
        Some(nu.dot(&cholesky.solve(&nu)))
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
