//! Least-squares circle fit: Kåsa's algebraic fit as the start, refined by Levenberg–Marquardt
//! on the geometric distance.
//!
//! Kåsa (1976, "A circle fitting procedure and its error analysis") minimises
//! `Σ (x² + y² + D x + E y + F)²`, a linear problem with a closed-form answer that is biased
//! towards small radii on short arcs. A few damped Gauss–Newton (Levenberg–Marquardt) steps on
//! `Σ (|p_i − c| − r)²` then remove the bias (Chernov, "Circular and Linear Regression", 2010,
//! ch. 4). Points are shifted to their mean first, which keeps the normal equations well
//! conditioned at long range.
//!
//! Collinear points have no circle: the algebraic system is singular and the fit returns
//! `None`, as it does for fewer than three points or non-finite coordinates.

use nalgebra::{Matrix3, Vector3};

/// A fitted circle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircleFit {
    /// Centre, in the frame of the fitted points, metres.
    pub center_m: [f64; 2],
    /// Radius, metres.
    pub radius_m: f64,
    /// Root mean square of the points' distances to the circle, metres.
    pub rms_residual_m: f64,
}

/// Fits a circle to `points_m` (at least three, metres): Kåsa's algebraic fit followed by at
/// most `iterations` Levenberg–Marquardt steps on the geometric distance (see the
/// [module documentation](self)). Returns `None` for fewer than three points, non-finite
/// points, or points on a line.
pub fn fit_circle(points_m: &[[f64; 2]], iterations: usize) -> Option<CircleFit> {
    if points_m.len() < 3 || points_m.iter().flatten().any(|c| !c.is_finite()) {
        return None;
    }
    let n = points_m.len() as f64;
    let mean_m = [
        points_m.iter().map(|p| p[0]).sum::<f64>() / n,
        points_m.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    let local_m: Vec<[f64; 2]> = points_m
        .iter()
        .map(|p| [p[0] - mean_m[0], p[1] - mean_m[1]])
        .collect();

    let (mut center_m, mut radius_m) = kasa_fit(&local_m)?;
    let mut cost = geometric_cost(&local_m, center_m, radius_m);
    let mut damping = 1e-3;
    for _ in 0..iterations {
        // Normal equations of the geometric residuals e_i = |p_i − c| − r.
        let mut jtj = Matrix3::<f64>::zeros();
        let mut jte = Vector3::<f64>::zeros();
        for p in &local_m {
            let dx = p[0] - center_m[0];
            let dy = p[1] - center_m[1];
            let distance_m = dx.hypot(dy);
            if distance_m < 1e-12 {
                continue;
            }
            let row = Vector3::new(-dx / distance_m, -dy / distance_m, -1.0);
            jtj += row * row.transpose();
            jte += row * (distance_m - radius_m);
        }
        let mut stepped = false;
        while damping < 1e9 {
            let mut damped = jtj;
            for k in 0..3 {
                damped[(k, k)] *= 1.0 + damping;
            }
            let Some(step) = damped.cholesky().map(|c| c.solve(&(-jte))) else {
                damping *= 10.0;
                continue;
            };
            let new_center_m = [center_m[0] + step[0], center_m[1] + step[1]];
            let new_radius_m = radius_m + step[2];
            let new_cost = geometric_cost(&local_m, new_center_m, new_radius_m);
            if new_cost.is_finite() && new_cost <= cost {
                center_m = new_center_m;
                radius_m = new_radius_m;
                cost = new_cost;
                damping = (damping * 0.1).max(1e-9);
                stepped = step.norm() > 1e-10;
                break;
            }
            damping *= 10.0;
        }
        if !stepped {
            break;
        }
    }

    let fit = CircleFit {
        center_m: [center_m[0] + mean_m[0], center_m[1] + mean_m[1]],
        radius_m: radius_m.abs(),
        rms_residual_m: (cost / n).sqrt(),
    };
    let finite = fit.center_m.iter().all(|c| c.is_finite()) && fit.radius_m.is_finite();
    finite.then_some(fit)
}

/// Kåsa's algebraic circle through `points_m` (centred on their mean): centre and radius.
fn kasa_fit(points_m: &[[f64; 2]]) -> Option<([f64; 2], f64)> {
    // Least squares on rows [x, y, 1] · [D, E, F] = −(x² + y²).
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    for p in points_m {
        let row = Vector3::new(p[0], p[1], 1.0);
        ata += row * row.transpose();
        atb -= row * (p[0] * p[0] + p[1] * p[1]);
    }
    // Collinear points make `ata` singular; reject before the solve magnifies rounding.
    let scale = ata[(0, 0)] + ata[(1, 1)];
    if scale <= 0.0 || ata.determinant().abs() <= 1e-9 * scale * scale * ata[(2, 2)] {
        return None;
    }
    let solution = ata.cholesky()?.solve(&atb);
    let center_m = [-solution[0] / 2.0, -solution[1] / 2.0];
    let radius_squared_m2 = center_m[0].powi(2) + center_m[1].powi(2) - solution[2];
    (radius_squared_m2 > 0.0).then(|| (center_m, radius_squared_m2.sqrt()))
}

/// `Σ (|p_i − c| − r)²`, square metres.
fn geometric_cost(points_m: &[[f64; 2]], center_m: [f64; 2], radius_m: f64) -> f64 {
    points_m
        .iter()
        .map(|p| ((p[0] - center_m[0]).hypot(p[1] - center_m[1]) - radius_m).powi(2))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::test_scene::Lcg;

    fn arc(
        center_m: [f64; 2],
        radius_m: f64,
        from_rad: f64,
        to_rad: f64,
        n: usize,
    ) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let a = from_rad + (to_rad - from_rad) * i as f64 / (n - 1) as f64;
                [
                    center_m[0] + radius_m * a.cos(),
                    center_m[1] + radius_m * a.sin(),
                ]
            })
            .collect()
    }

    #[test]
    fn test_exact_arc() {
        let points = arc([10.0, -3.0], 0.4, 2.0, 4.0, 7);
        let fit = fit_circle(&points, 10).expect("an arc has a circle");
        assert!((fit.center_m[0] - 10.0).abs() < 1e-9);
        assert!((fit.center_m[1] + 3.0).abs() < 1e-9);
        assert!((fit.radius_m - 0.4).abs() < 1e-9);
        assert!(fit.rms_residual_m < 1e-9);
    }

    #[test]
    fn test_noisy_short_arc_is_refined() {
        let mut rng = Lcg::new(7);
        let mut points = arc([5.0, 0.0], 0.5, 2.4, 3.9, 15);
        for p in &mut points {
            p[0] += 0.002 * rng.gaussian();
            p[1] += 0.002 * rng.gaussian();
        }
        let fit = fit_circle(&points, 20).expect("an arc has a circle");
        assert!((fit.radius_m - 0.5).abs() < 0.03, "{fit:?}");
        assert!((fit.center_m[0] - 5.0).abs() < 0.03, "{fit:?}");
        assert!(fit.rms_residual_m < 0.004, "{fit:?}");
    }

    #[test]
    fn test_degenerate_inputs() {
        assert_eq!(fit_circle(&[], 10), None);
        assert_eq!(fit_circle(&[[0.0, 0.0], [1.0, 1.0]], 10), None);
        let line: Vec<[f64; 2]> = (0..10).map(|i| [i as f64, 2.0 * i as f64]).collect();
        assert_eq!(fit_circle(&line, 10), None);
        assert_eq!(fit_circle(&[[1.0, 1.0]; 5], 10), None);
        let with_nan = [[0.0, 0.0], [f64::NAN, 1.0], [1.0, 0.0]];
        assert_eq!(fit_circle(&with_nan, 10), None);
    }
}
