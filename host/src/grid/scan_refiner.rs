//! Sub-cell refinement of a scan's pose against an occupancy grid, by least squares.
//!
//! The correlative matchers find the best pose on a lattice of candidates; this one polishes a
//! pose to a fraction of a cell, the role Cartographer gives its Ceres scan matcher (Hess et al.
//! 2016, "Real-Time Loop Closure in 2D LIDAR SLAM", section IV), written out here for the three
//! pose parameters. It minimises, over the pose `T = (x, y, θ)` (`grid_from_robot`),
//!
//! ```text
//! Σ_i (1 − P(T · p_i))²  +  w_t · |t − t_guess|²  +  w_r · (θ − θ_guess)²
//! ```
//!
//! where `p_i` are the scan's end points in the robot frame and `P` the bicubic interpolation of
//! the grid's occupancy probability ([`InterpolatedGrid`]; unknown cells read low). The sum pulls
//! every end point onto an occupied cell; the two small weights hold the pose near the guess
//! where the scan alone does not fix it (a long corridor).
//!
//! The minimiser is Newton's method with Levenberg–Marquardt damping. Its matrix is the exact
//! Hessian `JᵀJ + Σ r ∇²r`, from the interpolation's second derivatives: the residuals stay
//! large (a wall cell is rarely more than 0.9 occupied), and the Gauss–Newton matrix `JᵀJ`
//! alone then underestimates the curvature and overshoots. Far from a minimum, where that
//! matrix is indefinite, the damping grows until it is not. No step moves a point by more than
//! about one cell, the width of the slope it follows.
//!
//! It runs coarse to fine: first on the grid blurred by about a cell
//! ([`GridLevel::Smoothed`]), reading at most 60 points spread over the scan, whose wider slopes
//! lead in from farther off; then on the sharp grid with every point, which fixes the pose
//! precisely. This converges from about a cell and a degree and a half off; beyond that,
//! run a correlative matcher first.

use serde::{Deserialize, Serialize};

use super::interpolated_grid::{GridLevel, InterpolatedGrid};
use crate::scan_match::{Pose2, Scan};

/// Damping of the first step, relative to the diagonal of the Newton matrix; small, so that a
/// well-posed problem takes plain Newton steps.
const INITIAL_DAMPING: f64 = 1e-3;

/// Damping beyond which a stage gives up: its steps would be negligible.
const MAX_DAMPING: f64 = 1e12;

/// At most this many points, spread evenly over the scan, are read in the coarse stage.
const COARSE_POINTS: usize = 60;

/// The coarse stage stops at steps this many times the options' minimum steps.
const COARSE_STEP_SCALE: f64 = 10.0;

/// Weights of the cost and when the iteration stops.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ScanRefinerOptions {
    /// `w_t`: weight of the squared distance between the refined and the guessed translation,
    /// per square metre; 20. A point on a wall adds a curvature of order `(1 / resolution_m)²`
    /// (hundreds per m² at 5 cm), so this hardly biases a scan that fixes the pose.
    pub translation_weight_per_m2: f64,
    /// `w_r`: weight of the squared difference between the refined and the guessed heading, per
    /// square radian; 20.
    pub rotation_weight_per_rad2: f64,
    /// Most iterations (passes over the points) in each of the two stages; 20.
    pub max_iterations: u32,
    /// A stage ends once a step would move the pose by less than this, in metres, ...; 0.3 mm.
    pub min_translation_step_m: f64,
    /// ... and turn it by less than this, in radians; 0.3 mrad.
    pub min_rotation_step_rad: f64,
}

impl Default for ScanRefinerOptions {
    /// Weak pulls towards the guess (20 per m², 20 per rad²), at most 20 iterations per stage,
    /// done when a step falls below 0.3 mm and 0.3 mrad.
    fn default() -> Self {
        ScanRefinerOptions {
            translation_weight_per_m2: 20.0,
            rotation_weight_per_rad2: 20.0,
            max_iterations: 20,
            min_translation_step_m: 3e-4,
            min_rotation_step_rad: 3e-4,
        }
    }
}

/// The outcome of [`ScanRefiner::refine`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refinement {
    /// The refined pose of the robot in the grid frame.
    pub grid_from_robot: Pose2,
    /// Mean interpolated occupancy probability at the scan's end points placed by
    /// `grid_from_robot`, clamped to `[0, 1]`: how well the scan fits the grid. A scan caught
    /// in the wrong place scores well below a matched one.
    pub mean_probability: f64,
    /// Iterations run over both stages, each one pass over the points the stage reads (not
    /// counting the pass at each stage's start).
    pub iterations: u32,
    /// True if the final stage ended on a step below the minimum; false if its iteration limit
    /// (or its damping limit) ended it.
    pub converged: bool,
}

/// Refines scan poses against an [`InterpolatedGrid`]; see the module documentation.
#[derive(Clone, Copy, Debug, Default)]
pub struct ScanRefiner {
    options: ScanRefinerOptions,
}

impl ScanRefiner {
    /// A refiner applying `options`.
    pub fn new(options: ScanRefinerOptions) -> Self {
        ScanRefiner { options }
    }

    /// The options the refiner applies.
    pub fn options(&self) -> &ScanRefinerOptions {
        &self.options
    }

    /// Aligns `scan` within `grid` starting from `initial_grid_from_robot`, which should be
    /// within about a cell and a degree of the answer.
    ///
    /// Returns `None` if the scan has no end point or the guess is not finite. From a guess too
    /// far off the result may be no better than the guess; a low
    /// [`Refinement::mean_probability`] tells.
    pub fn refine(
        &self,
        scan: &Scan,
        grid: &InterpolatedGrid,
        initial_grid_from_robot: Pose2,
    ) -> Option<Refinement> {
        let guess = [
            initial_grid_from_robot.x_m,
            initial_grid_from_robot.y_m,
            initial_grid_from_robot.theta_rad,
        ];
        let points_in_robot: Vec<[f64; 2]> =
            scan.points_in_robot().iter().flatten().copied().collect();
        if points_in_robot.is_empty() || !guess.iter().all(|v| v.is_finite()) {
            return None;
        }
        let num_points = points_in_robot.len() as f64;
        let sum_squared_range_m2: f64 = points_in_robot
            .iter()
            .map(|p| p[0] * p[0] + p[1] * p[1])
            .sum();
        let problem = Problem {
            points_in_robot: &points_in_robot,
            grid,
            guess,
            rms_range_m: (sum_squared_range_m2 / num_points).sqrt(),
        };
        // Coarse to fine: the smoothed grid, read at a subset of the points, brings the pose
        // within reach of the sharp grid, which then places it precisely with every point.
        let coarse = Stage {
            level: GridLevel::Smoothed,
            point_stride: points_in_robot.len().div_ceil(COARSE_POINTS),
            step_scale: COARSE_STEP_SCALE,
        };
        let fine = Stage {
            level: GridLevel::Sharp,
            point_stride: 1,
            step_scale: 1.0,
        };
        let coarse = self.minimise(&problem, coarse, guess);
        let fine = self.minimise(&problem, fine, coarse.pose);
        let [x_m, y_m, theta_rad] = fine.pose;
        Some(Refinement {
            grid_from_robot: Pose2::new(x_m, y_m, theta_rad),
            mean_probability: (fine.equations.sum_probability / num_points).clamp(0.0, 1.0),
            iterations: coarse.iterations + fine.iterations,
            converged: fine.converged,
        })
    }

    /// Damped Newton iterations on `problem` as `stage` says, from `start`.
    fn minimise(&self, problem: &Problem<'_>, stage: Stage, start: [f64; 3]) -> Minimum {
        let min_translation_step_m = stage.step_scale * self.options.min_translation_step_m;
        let min_rotation_step_rad = stage.step_scale * self.options.min_rotation_step_rad;
        // Trust region: no point moves by more than about a cell in one step, the displacement
        // of a point being estimated as translation plus rotation times its typical range.
        let max_displacement_m = problem.grid.resolution_m();
        let mut pose = start;
        let mut current = self.evaluate(problem, stage, pose);
        let mut damping = INITIAL_DAMPING;
        let mut iterations = 0;
        let mut converged = false;
        while iterations < self.options.max_iterations {
            let Some(step) = current.damped_step(damping) else {
                // Far from a minimum the Newton matrix can be indefinite; more damping makes
                // it diagonally dominant, and costs no pass over the points.
                damping *= 10.0;
                if damping > MAX_DAMPING {
                    break;
                }
                continue;
            };
            let translation_m = step[0].hypot(step[1]);
            if translation_m < min_translation_step_m && step[2].abs() < min_rotation_step_rad {
                converged = true;
                break;
            }
            let displacement_m = translation_m + step[2].abs() * problem.rms_range_m;
            let scale = (max_displacement_m / displacement_m).min(1.0);
            let candidate_pose = [
                pose[0] + scale * step[0],
                pose[1] + scale * step[1],
                pose[2] + scale * step[2],
            ];
            let candidate = self.evaluate(problem, stage, candidate_pose);
            iterations += 1;
            if candidate.cost < current.cost {
                pose = candidate_pose;
                current = candidate;
                damping = (damping * 0.1).max(1e-9);
            } else {
                damping *= 10.0;
            }
        }
        Minimum {
            pose,
            equations: current,
            iterations,
            converged,
        }
    }

    /// The cost of `problem` at `pose` (`[x_m, y_m, theta_rad]`) on the grid level of `stage`,
    /// with its derivatives.
    fn evaluate(&self, problem: &Problem<'_>, stage: Stage, pose: [f64; 3]) -> NormalEquations {
        let (sin, cos) = pose[2].sin_cos();
        // Each point read stands for `point_stride` points, keeping the balance with the pulls
        // towards the guess.
        let w = stage.point_stride as f64;
        // Upper triangle of the Newton matrix, the gradient, the cost, the probabilities.
        let [mut h_xx, mut h_xy, mut h_xt, mut h_yy, mut h_yt, mut h_tt] = [0.0f64; 6];
        let [mut g_x, mut g_y, mut g_t] = [0.0f64; 3];
        let (mut cost, mut sum_probability) = (0.0f64, 0.0f64);
        // Four points at a time, the interpolation running on all four at once; the last group
        // is filled up with copies of its first point, which are then left out.
        let mut points = problem.points_in_robot.iter().step_by(stage.point_stride);
        loop {
            let mut group = [[0.0f64; 2]; 4];
            let mut rotated = [[0.0f64; 2]; 4];
            let mut group_len = 0;
            for &[x, y] in points.by_ref().take(4) {
                // The point rotated into the grid frame, then translated.
                rotated[group_len] = [cos * x - sin * y, sin * x + cos * y];
                group[group_len] = [
                    rotated[group_len][0] + pose[0],
                    rotated[group_len][1] + pose[1],
                ];
                group_len += 1;
            }
            if group_len == 0 {
                break;
            }
            for lane in group_len..4 {
                group[lane] = group[0];
            }
            let at_group = problem.grid.evaluate_four(stage.level, group);
            for (at_point, rotated) in at_group.iter().zip(&rotated).take(group_len) {
                let [px, py] = at_point.gradient_per_m;
                let [[pxx, pxy], [_, pyy]] = at_point.hessian_per_m2;
                // How the point moves as θ turns: the rotated point turned by a quarter turn.
                let [nx, ny] = [-rotated[1], rotated[0]];
                // Residual r = 1 − P. Its Jacobian in (x, y, θ) is −(px, py, pt); its second
                // derivatives are −(P's Hessian carried through the motion of the point), the
                // θθ term adding the point's curved path: ∂²(point)/∂θ² = −rotated.
                let r = 1.0 - at_point.probability;
                let pt = px * nx + py * ny;
                let pxn = pxx * nx + pxy * ny;
                let pyn = pxy * nx + pyy * ny;
                let ptt = nx * pxn + ny * pyn - (px * rotated[0] + py * rotated[1]);
                // Newton matrix JᵀJ + r ∇²r, gradient Jᵀr, cost r², each counted w times.
                let wr = w * r;
                h_xx += w * px * px - wr * pxx;
                h_xy += w * px * py - wr * pxy;
                h_xt += w * px * pt - wr * pxn;
                h_yy += w * py * py - wr * pyy;
                h_yt += w * py * pt - wr * pyn;
                h_tt += w * pt * pt - wr * ptt;
                g_x -= wr * px;
                g_y -= wr * py;
                g_t -= wr * pt;
                cost += wr * r;
                sum_probability += at_point.probability;
            }
        }
        let guess = problem.guess;
        let mut equations = NormalEquations {
            newton: [[h_xx, h_xy, h_xt], [0.0, h_yy, h_yt], [0.0, 0.0, h_tt]],
            gradient: [g_x, g_y, g_t],
            cost,
            sum_probability,
        };
        // The pulls towards the guess: residuals sqrt(w) * (pose - guess).
        let w_t = self.options.translation_weight_per_m2;
        let w_r = self.options.rotation_weight_per_rad2;
        for (axis, weight) in [(0, w_t), (1, w_t), (2, w_r)] {
            let offset = pose[axis] - guess[axis];
            equations.cost += weight * offset * offset;
            equations.gradient[axis] += weight * offset;
            equations.newton[axis][axis] += weight;
        }
        equations
    }
}

/// What one refinement works on.
struct Problem<'a> {
    /// The scan's end points, robot frame, metres.
    points_in_robot: &'a [[f64; 2]],
    grid: &'a InterpolatedGrid,
    /// The initial guess, `[x_m, y_m, theta_rad]`.
    guess: [f64; 3],
    /// Root mean square distance of the points from the sensor, metres.
    rms_range_m: f64,
}

/// One stage of the coarse-to-fine minimisation.
#[derive(Clone, Copy, Debug)]
struct Stage {
    /// The grid level read.
    level: GridLevel,
    /// Every `point_stride`-th point is read.
    point_stride: usize,
    /// The stage stops at steps below this multiple of the options' minimum steps.
    step_scale: f64,
}

/// Where one stage of the minimisation ended.
struct Minimum {
    pose: [f64; 3],
    equations: NormalEquations,
    iterations: u32,
    converged: bool,
}

/// Half the gradient and half the Hessian of the cost at one pose.
#[derive(Clone, Copy, Debug, Default)]
struct NormalEquations {
    /// `JᵀJ + Σ r ∇²r`, the Newton Hessian; only the upper triangle is filled.
    newton: [[f64; 3]; 3],
    /// `Jᵀr`, half the gradient of the cost.
    gradient: [f64; 3],
    /// `rᵀr`, the cost.
    cost: f64,
    /// Sum of the probabilities at the points.
    sum_probability: f64,
}

impl NormalEquations {
    /// The damped Newton step: solves `(H + damping · |diag(H)|) step = −Jᵀr`; `None` if the
    /// damped matrix is not positive definite.
    fn damped_step(&self, damping: f64) -> Option<[f64; 3]> {
        solve_damped(self.newton, self.gradient, damping)
    }
}

/// Solves `(a + damping · |diag(a)|) x = −gradient` by Cholesky factorisation, reading the
/// upper triangle of the symmetric `a`; `None` if the damped matrix is not positive definite.
fn solve_damped(mut a: [[f64; 3]; 3], gradient: [f64; 3], damping: f64) -> Option<[f64; 3]> {
    for (i, row) in a.iter_mut().enumerate() {
        row[i] += damping * row[i].abs().max(1e-12);
    }
    // `l lᵀ = a` with `l` lower-triangular; a pivot that is not positive means `a` is not
    // positive definite.
    let pivot = |square: f64| (square > 0.0 && square.is_finite()).then(|| square.sqrt());
    let l00 = pivot(a[0][0])?;
    let l10 = a[0][1] / l00;
    let l20 = a[0][2] / l00;
    let l11 = pivot(a[1][1] - l10 * l10)?;
    let l21 = (a[1][2] - l20 * l10) / l11;
    let l22 = pivot(a[2][2] - l20 * l20 - l21 * l21)?;
    // Forward substitution `l z = −gradient`, then back substitution `lᵀ x = z`.
    let z0 = -gradient[0] / l00;
    let z1 = (-gradient[1] - l10 * z0) / l11;
    let z2 = (-gradient[2] - l20 * z0 - l21 * z1) / l22;
    let x2 = z2 / l22;
    let x1 = (z1 - l21 * x2) / l11;
    let x0 = (z0 - l10 * x1 - l20 * x2) / l00;
    Some([x0, x1, x2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::probability_grid::{ProbabilityGrid, ProbabilityGridOptions};
    use crate::grid::range_inserter::RangeInserterOptions;
    use crate::scan_match::synthetic::{WallInMap, cast_scan, polygon_walls};
    use std::f64::consts::PI;

    /// An L-shaped room about 9 m × 7 m with a square pillar, turned by 0.3 rad so that no wall
    /// runs along the grid axes.
    fn room_walls() -> Vec<WallInMap> {
        let turn = Pose2::new(0.4, -0.2, 0.3);
        let polygons = [
            vec![
                [-3.0, -2.5],
                [5.5, -2.5],
                [5.5, 1.0],
                [2.0, 1.0],
                [2.0, 4.5],
                [-3.0, 4.5],
            ],
            vec![[1.0, -1.0], [1.6, -1.0], [1.6, -0.4], [1.0, -0.4]],
        ];
        polygons
            .iter()
            .flat_map(|polygon| {
                let turned: Vec<[f64; 2]> =
                    polygon.iter().map(|&c| turn.transform_point(c)).collect();
                polygon_walls(&turned)
            })
            .collect()
    }

    /// A 180-degree scan of 361 beams half a degree apart, as the LMS2xx gives.
    fn scan_at(walls: &[WallInMap], pose_in_map: Pose2) -> Scan {
        cast_scan(walls, pose_in_map, -PI / 2.0, PI / 360.0, 361, 30.0)
    }

    /// A young submap of the room: 5 cm cells, 24 scans from poses along a short sweeping path.
    fn room_grid(walls: &[WallInMap]) -> ProbabilityGrid {
        let poses: Vec<Pose2> = (0..24)
            .map(|k| {
                let k = k as f64 * 0.5;
                Pose2::new(-1.5 + 0.25 * k, 0.3 + 0.1 * (k * 0.7).sin(), k * 0.55)
            })
            .collect();
        let scans: Vec<Scan> = poses.iter().map(|&pose| scan_at(walls, pose)).collect();
        ProbabilityGrid::from_scans(
            poses.iter().copied().zip(&scans),
            0.05,
            ProbabilityGridOptions::default(),
            RangeInserterOptions::default(),
        )
    }

    #[test]
    fn test_converges_to_truth_from_nearby_guesses() {
        let walls = room_walls();
        let grid = InterpolatedGrid::new(&room_grid(&walls));
        let refiner = ScanRefiner::default();
        let truths = [
            Pose2::new(-0.8, 0.45, 0.2),
            Pose2::new(0.6, 0.1, 2.5),
            Pose2::new(0.1, 1.1, -1.3),
        ];
        // One cell and one degree off, along every combination of axes.
        let offset_m = 0.05;
        let offset_rad = 1f64.to_radians();
        for truth in truths {
            let scan = scan_at(&walls, truth);
            for dx in [-offset_m, 0.0, offset_m] {
                for dy in [-offset_m, 0.0, offset_m] {
                    for dtheta in [-offset_rad, 0.0, offset_rad] {
                        let guess =
                            Pose2::new(truth.x_m + dx, truth.y_m + dy, truth.theta_rad + dtheta);
                        let refined = refiner.refine(&scan, &grid, guess).unwrap();
                        let error = refined.grid_from_robot.inverse() * truth;
                        let error_m = error.x_m.hypot(error.y_m);
                        let error_deg = error.theta_rad.to_degrees().abs();
                        assert!(
                            error_m < 0.01 && error_deg < 0.2,
                            "truth {truth:?} guess {guess:?}: {refined:?}, off by {error_m} m, \
                             {error_deg} deg"
                        );
                        assert!(refined.mean_probability > 0.75, "{refined:?}");
                        assert!(refined.converged, "{refined:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn test_far_guess_scores_low() {
        let walls = room_walls();
        let grid = InterpolatedGrid::new(&room_grid(&walls));
        let truth = Pose2::new(0.2, 0.3, 0.4);
        let scan = scan_at(&walls, truth);
        let refiner = ScanRefiner::default();
        let matched = refiner.refine(&scan, &grid, truth).unwrap();
        let lost = refiner
            .refine(&scan, &grid, Pose2::new(0.9, -0.4, 0.9))
            .unwrap();
        assert!(
            lost.mean_probability < matched.mean_probability - 0.2,
            "{lost:?} vs {matched:?}"
        );
    }

    #[test]
    fn test_no_iterations_returns_the_guess() {
        let walls = room_walls();
        let grid = InterpolatedGrid::new(&room_grid(&walls));
        let scan = scan_at(&walls, Pose2::IDENTITY);
        let guess = Pose2::new(0.03, -0.02, 0.01);
        let refiner = ScanRefiner::new(ScanRefinerOptions {
            max_iterations: 0,
            ..ScanRefinerOptions::default()
        });
        let refined = refiner.refine(&scan, &grid, guess).unwrap();
        assert_eq!(refined.grid_from_robot, guess);
        assert_eq!(refined.iterations, 0);
        assert!(!refined.converged);
    }

    #[test]
    fn test_empty_scan_or_bad_guess() {
        let walls = room_walls();
        let grid = InterpolatedGrid::new(&room_grid(&walls));
        let refiner = ScanRefiner::default();
        let empty = Scan::from_points_in_robot(vec![None, None]);
        assert_eq!(refiner.refine(&empty, &grid, Pose2::IDENTITY), None);
        let scan = scan_at(&walls, Pose2::IDENTITY);
        assert_eq!(
            refiner.refine(&scan, &grid, Pose2::new(f64::NAN, 0.0, 0.0)),
            None
        );
    }

    #[test]
    fn test_solve_damped() {
        let upper = [[4.0, 1.0, 0.5], [0.0, 3.0, -0.2], [0.0, 0.0, 2.0]];
        let full = [[4.0, 1.0, 0.5], [1.0, 3.0, -0.2], [0.5, -0.2, 2.0]];
        let gradient = [1.0, -2.0, 0.5];
        let step = solve_damped(upper, gradient, 0.0).unwrap();
        for i in 0..3 {
            let row: f64 = (0..3).map(|j| full[i][j] * step[j]).sum();
            assert!((row + gradient[i]).abs() < 1e-12);
        }
        let indefinite = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(solve_damped(indefinite, gradient, 0.5).is_none());
        assert!(solve_damped(indefinite, gradient, 3.0).is_some());
    }

    /// Time per call, by hand, in release mode:
    /// `cargo test --release -p host grid::scan_refiner -- --ignored --nocapture`.
    #[test]
    #[ignore = "timing, run by hand in release mode"]
    fn time_refine() {
        let walls = room_walls();
        let grid = InterpolatedGrid::new(&room_grid(&walls));
        let refiner = ScanRefiner::default();
        let truth = Pose2::new(-0.8, 0.45, 0.2);
        let guess = Pose2::new(truth.x_m + 0.04, truth.y_m - 0.03, truth.theta_rad + 0.015);
        let scans = [
            ("361 beams, 0.5 deg", scan_at(&walls, truth)),
            (
                "181 beams, 1 deg",
                cast_scan(&walls, truth, -PI / 2.0, PI / 180.0, 181, 30.0),
            ),
        ];
        for (name, scan) in &scans {
            // The fastest of several batches, to see past other load on the machine.
            let mut best_us = f64::INFINITY;
            let mut iterations = 0;
            for _ in 0..20 {
                let calls = 200;
                let start = std::time::Instant::now();
                for _ in 0..calls {
                    let refined = refiner
                        .refine(
                            std::hint::black_box(scan),
                            &grid,
                            std::hint::black_box(guess),
                        )
                        .unwrap();
                    iterations = refined.iterations;
                }
                best_us = best_us.min(start.elapsed().as_secs_f64() * 1e6 / calls as f64);
            }
            println!("{name}: {best_us:.1} us per call, {iterations} iterations");
        }
    }
}
