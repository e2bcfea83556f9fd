//! Visible for testing: a tiny ray caster for synthetic scans of circles and segments, with
//! optional Gaussian range noise from a fixed-seed linear congruential generator.
//!
//! The sensor sits at the origin of the scene's frame, so shapes are given in the sensor
//! frame (`x` forward, `y` left).

use super::range_scan::RangeScan;

/// Something a beam can hit.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Shape {
    /// A circle (a trunk), metres.
    Circle { center_m: [f64; 2], radius_m: f64 },
    /// A wall from `a_m` to `b_m`, metres.
    Segment { a_m: [f64; 2], b_m: [f64; 2] },
}

/// Shapes around a sensor at the origin.
#[derive(Clone, Debug)]
pub(crate) struct Scene {
    shapes: Vec<Shape>,
}

/// Knuth's MMIX linear congruential generator with Box–Muller Gaussian samples.
#[derive(Clone, Debug)]
pub(crate) struct Lcg(u64);

impl Lcg {
    pub(crate) fn new(seed: u64) -> Self {
        Lcg(seed ^ 0x9e37_79b9_7f4a_7c15)
    }

    /// Uniform in `[0, 1)`.
    pub(crate) fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub(crate) fn gaussian(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

impl Scene {
    pub(crate) fn new(shapes: Vec<Shape>) -> Self {
        Scene { shapes }
    }

    /// Distance from the origin along the unit ray at `angle_rad` to the first shape.
    pub(crate) fn ray_cast_m(&self, angle_rad: f64) -> Option<f64> {
        let d = [angle_rad.cos(), angle_rad.sin()];
        self.shapes
            .iter()
            .filter_map(|shape| match *shape {
                Shape::Circle { center_m, radius_m } => {
                    // |t d − c|² = r²  ⇒  t² − 2 t (d·c) + |c|² − r² = 0.
                    let b = d[0] * center_m[0] + d[1] * center_m[1];
                    let c = center_m[0].powi(2) + center_m[1].powi(2) - radius_m.powi(2);
                    let disc = b * b - c;
                    if disc < 0.0 {
                        return None;
                    }
                    let t = b - disc.sqrt();
                    (t > 0.0).then_some(t)
                }
                Shape::Segment { a_m, b_m } => {
                    let cross = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
                    let edge = [b_m[0] - a_m[0], b_m[1] - a_m[1]];
                    let denominator = cross(d, edge);
                    if denominator.abs() < 1e-12 {
                        return None;
                    }
                    let t = cross(a_m, edge) / denominator;
                    let s = cross(a_m, d) / denominator;
                    (t > 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
                }
            })
            .reduce(f64::min)
    }

    /// A scan of `num_beams` beams from `first_angle_rad` in steps of `angle_step_rad`, ranges
    /// with Gaussian noise of `sigma_m` (seeded by `seed`); misses read `max_range_m`.
    pub(crate) fn cast(
        &self,
        first_angle_rad: f64,
        angle_step_rad: f64,
        num_beams: usize,
        max_range_m: f64,
        sigma_m: f64,
        seed: u64,
    ) -> RangeScan {
        let mut rng = Lcg::new(seed);
        let ranges_m = (0..num_beams)
            .map(|beam| {
                let angle_rad = first_angle_rad + beam as f64 * angle_step_rad;
                let noise_m = sigma_m * rng.gaussian();
                match self.ray_cast_m(angle_rad) {
                    Some(range_m) if range_m < max_range_m => range_m + noise_m,
                    _ => max_range_m,
                }
            })
            .collect();
        RangeScan::new(ranges_m, first_angle_rad, angle_step_rad, max_range_m)
    }
}

/// `n` evenly spaced points from `from` to `to` (both included), metres.
pub(crate) fn straight(from: [f64; 2], to: [f64; 2], n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            let f = i as f64 / (n - 1) as f64;
            [
                from[0] + f * (to[0] - from[0]),
                from[1] + f * (to[1] - from[1]),
            ]
        })
        .collect()
}
