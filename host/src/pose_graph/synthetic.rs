//! Synthetic pose graphs with known true poses, for tests and benchmarks.
//!
//! Each generator lays out a true trajectory, measures odometry between consecutive poses and
//! loop closures between revisits, corrupts every measurement with seeded Gaussian noise, and
//! starts every node at the pose dead reckoning gives (the first node at its true pose, fixed).
//! The same arguments always give the same graph.
//!
//! * [`circle_laps`]: laps around one circle, each pose closed against the same place on the
//!   previous lap.
//! * [`manhattan_grid`]: a random walk on a grid of streets, each pose closed against earlier
//!   visits of the same intersection, in the spirit of the Manhattan benchmark of Olson et al.,
//!   "Fast Iterative Optimization of Pose Graphs with Poor Initial Estimates" (2006).

use std::f64::consts::{FRAC_PI_2, TAU};

use super::edge::Edge;
use super::graph::PoseGraph;
use super::node::NodeId;
use crate::geometry::Pose2;

/// Standard deviations of the measurement noise, and the seed of its generator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Noise {
    /// Standard deviation of each translation component of a measurement, in metres; `> 0`.
    pub sigma_xy_m: f64,
    /// Standard deviation of the rotation of a measurement, in radians; `> 0`.
    pub sigma_theta_rad: f64,
    /// Seed of the pseudo-random generator.
    pub seed: u64,
}

impl Default for Noise {
    fn default() -> Self {
        Noise {
            sigma_xy_m: 0.05,
            sigma_theta_rad: 0.01,
            seed: 1,
        }
    }
}

/// A synthetic pose graph and the true poses of its nodes.
#[derive(Clone, Debug)]
pub struct SyntheticGraph {
    /// The graph, with noisy measurements and dead-reckoned initial poses.
    pub graph: PoseGraph,
    /// The true pose of every node, indexed like the graph's nodes.
    pub truth_in_map: Vec<Pose2>,
}

impl SyntheticGraph {
    /// The root mean square distance between the graph's node positions and the true ones, in
    /// metres.
    pub fn rms_position_error_m(&self) -> f64 {
        let count = self.truth_in_map.len().max(1) as f64;
        let sum_sq: f64 = self
            .graph
            .nodes()
            .iter()
            .zip(&self.truth_in_map)
            .map(|(node, truth)| {
                let dx = node.pose_in_map.x_m - truth.x_m;
                let dy = node.pose_in_map.y_m - truth.y_m;
                dx * dx + dy * dy
            })
            .sum();
        (sum_sq / count).sqrt()
    }
}

/// `lap_count` laps of `nodes_per_lap` poses each around a circle of `radius_m`, driving
/// counter-clockwise; every pose of a later lap is closed against the same place on the lap
/// before. Gives `lap_count · nodes_per_lap` nodes.
pub fn circle_laps(
    lap_count: usize,
    nodes_per_lap: usize,
    radius_m: f64,
    noise: &Noise,
) -> SyntheticGraph {
    let node_count = lap_count * nodes_per_lap;
    let step_rad = TAU / nodes_per_lap.max(1) as f64;
    let truth_in_map: Vec<Pose2> = (0..node_count)
        .map(|i| {
            let angle_rad = i as f64 * step_rad;
            Pose2::new(
                radius_m * angle_rad.cos(),
                radius_m * angle_rad.sin(),
                angle_rad + FRAC_PI_2,
            )
        })
        .collect();
    let closures: Vec<(usize, usize)> = (nodes_per_lap..node_count)
        .map(|i| (i - nodes_per_lap, i))
        .collect();
    build(truth_in_map, &closures, noise)
}

/// A walk of `node_count` one-metre steps on a `grid_size × grid_size` grid of streets, turning
/// left or right at a quarter of the intersections and never leaving the grid. Every pose is
/// closed against up to `closures_per_node` of the most recent earlier visits of the same
/// intersection (the previous pose excepted).
pub fn manhattan_grid(
    node_count: usize,
    grid_size: usize,
    closures_per_node: usize,
    noise: &Noise,
) -> SyntheticGraph {
    let mut random = Lcg::new(noise.seed ^ 0x6d61_6e68_6174_7461);
    let grid_size = grid_size.max(2) as i64;
    let mut cell = (0_i64, 0_i64);
    let mut heading = 0_i64; // quarter turns counter-clockwise from +x
    let mut visits: Vec<Vec<usize>> = vec![Vec::new(); (grid_size * grid_size) as usize];
    let mut truth_in_map = Vec::with_capacity(node_count);
    let mut closures = Vec::new();
    for i in 0..node_count {
        if i > 0 {
            let draw = random.uniform();
            let mut turn = if draw < 0.125 {
                1
            } else if draw < 0.25 {
                3
            } else {
                0
            };
            // Turn further until the next step stays on the grid.
            loop {
                let next_heading = (heading + turn) % 4;
                let next = step(cell, next_heading);
                if (0..grid_size).contains(&next.0) && (0..grid_size).contains(&next.1) {
                    heading = next_heading;
                    cell = next;
                    break;
                }
                turn += 1;
            }
        }
        let index = (cell.1 * grid_size + cell.0) as usize;
        let earlier = &mut visits[index];
        closures.extend(
            earlier
                .iter()
                .rev()
                .filter(|&&j| j + 1 < i)
                .take(closures_per_node)
                .map(|&j| (j, i)),
        );
        earlier.push(i);
        truth_in_map.push(Pose2::new(
            cell.0 as f64,
            cell.1 as f64,
            heading as f64 * FRAC_PI_2,
        ));
    }
    build(truth_in_map, &closures, noise)
}

/// The cell one step from `cell` along `heading` (quarter turns from +x).
fn step(cell: (i64, i64), heading: i64) -> (i64, i64) {
    match heading {
        0 => (cell.0 + 1, cell.1),
        1 => (cell.0, cell.1 + 1),
        2 => (cell.0 - 1, cell.1),
        _ => (cell.0, cell.1 - 1),
    }
}

/// Builds the graph of `truth_in_map` with noisy odometry between consecutive poses and noisy
/// `closures` (`(from, to)` node indices); initial poses come from the noisy odometry.
fn build(truth_in_map: Vec<Pose2>, closures: &[(usize, usize)], noise: &Noise) -> SyntheticGraph {
    let mut random = Lcg::new(noise.seed);
    let information =
        Edge::information_from_std_devs(noise.sigma_xy_m, noise.sigma_xy_m, noise.sigma_theta_rad);
    let mut measure = |from: usize, to: usize| {
        let exact = truth_in_map[from].inverse() * truth_in_map[to];
        exact
            * Pose2::new(
                noise.sigma_xy_m * random.gaussian(),
                noise.sigma_xy_m * random.gaussian(),
                noise.sigma_theta_rad * random.gaussian(),
            )
    };
    let odometry: Vec<Pose2> = (1..truth_in_map.len()).map(|i| measure(i - 1, i)).collect();
    let closure_measurements: Vec<Pose2> = closures
        .iter()
        .map(|&(from, to)| measure(from, to))
        .collect();

    let mut graph = PoseGraph::new();
    let mut dead_reckoned = truth_in_map.first().copied().unwrap_or(Pose2::IDENTITY);
    let mut edges = Vec::with_capacity(odometry.len() + closures.len());
    for i in 0..truth_in_map.len() {
        if i > 0 {
            dead_reckoned = dead_reckoned * odometry[i - 1];
            edges.push(Edge::new(
                NodeId(i - 1),
                NodeId(i),
                odometry[i - 1],
                information,
            ));
        }
        // Finite by construction: the truth and the noise are finite.
        let _ = graph.add_node(dead_reckoned);
    }
    for (&(from, to), &measured) in closures.iter().zip(&closure_measurements) {
        edges.push(Edge::new(NodeId(from), NodeId(to), measured, information));
    }
    for edge in edges {
        // Valid by construction: existing, distinct nodes and a diagonal positive information.
        let _ = graph.add_edge(edge);
    }
    SyntheticGraph {
        graph,
        truth_in_map,
    }
}

/// A 64-bit linear congruential generator (Knuth's MMIX constants): deterministic, portable and
/// good enough for test noise.
#[derive(Clone, Debug)]
pub(crate) struct Lcg {
    state: u64,
}

impl Lcg {
    /// A generator started from `seed`.
    pub(crate) fn new(seed: u64) -> Self {
        Lcg {
            state: seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1),
        }
    }

    /// A uniform sample in `(0, 1)`.
    pub(crate) fn uniform(&mut self) -> f64 {
        self.state = self
            .state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        // The top 53 bits, shifted off zero.
        ((self.state >> 11) as f64 + 0.5) / (1_u64 << 53) as f64
    }

    /// A standard normal sample (Box–Muller).
    pub(crate) fn gaussian(&mut self) -> f64 {
        let radius = (-2.0 * self.uniform().ln()).sqrt();
        radius * (TAU * self.uniform()).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_generators_are_deterministic() {
        let noise = Noise::default();
        let a = manhattan_grid(300, 8, 2, &noise);
        let b = manhattan_grid(300, 8, 2, &noise);
        assert_eq!(a.truth_in_map, b.truth_in_map);
        assert_eq!(a.graph.edges(), b.graph.edges());
        assert!(a.graph.edges().len() > 400, "{}", a.graph.edges().len());
    }

    #[test]
    fn test_nearly_noiseless_circle_starts_near_truth() {
        let noise = Noise {
            sigma_xy_m: 1e-6,
            sigma_theta_rad: 1e-6,
            seed: 3,
        };
        let circle = circle_laps(2, 20, 5.0, &noise);
        assert_eq!(circle.graph.nodes().len(), 40);
        assert_eq!(circle.graph.edges().len(), 39 + 20);
        assert!(circle.rms_position_error_m() < 1e-4);
    }

    #[test]
    fn test_gaussian_has_unit_spread() {
        let mut random = Lcg::new(7);
        let samples: Vec<f64> = (0..20_000).map(|_| random.gaussian()).collect();
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let variance =
            samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / samples.len() as f64;
        assert!(
            mean.abs() < 0.03 && (variance - 1.0).abs() < 0.05,
            "{mean} {variance}"
        );
    }
}
