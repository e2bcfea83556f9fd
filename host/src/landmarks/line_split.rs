//! Line segments in one cluster by split-and-merge (iterative end-point fit; Nguyen et al., "A
//! comparison of line extraction algorithms using 2D range data for indoor mobile robotics",
//! Auton. Robots 23, 2007).
//!
//! Split: the chord from the first to the last point is a line unless some point lies farther
//! than [`LineSplitOptions::split_distance_m`] from it; then the points are split at the
//! farthest one, which goes to both halves, and each half is treated the same way. Merge:
//! neighbouring segments whose joint total-least-squares line keeps every point within the
//! same distance become one. Each segment's line is then fitted by total least squares
//! (orthogonal regression) to its points, leaving out a split point it shares with a
//! neighbour: at a corner that point lies on one wall or the other, or on neither.

use serde::{Deserialize, Serialize};

/// How a cluster is cut into line segments.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LineSplitOptions {
    /// A segment is split when a point lies farther than this from its chord, and two
    /// segments merge when their joint line keeps every point within it, metres; 0.05.
    pub split_distance_m: f64,
}

impl Default for LineSplitOptions {
    /// Split at 5 cm.
    fn default() -> Self {
        LineSplitOptions {
            split_distance_m: 0.05,
        }
    }
}

/// A straight run of points, as [`split_into_lines`] finds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineSegment {
    /// Index of the segment's first point in the input.
    pub first_index: usize,
    /// Index of its last point (inclusive); neighbouring segments share a split point.
    pub last_index: usize,
    /// Mean of the fitted points, metres.
    pub centroid_m: [f64; 2],
    /// Unit direction of the fitted line, from the first point towards the last.
    pub direction: [f64; 2],
    /// The first point projected onto the fitted line, metres.
    pub start_m: [f64; 2],
    /// The last point projected onto the fitted line, metres.
    pub end_m: [f64; 2],
    /// Points the line was fitted to.
    pub num_fitted_points: usize,
}

impl LineSegment {
    /// Distance from [`LineSegment::start_m`] to [`LineSegment::end_m`], metres.
    pub fn length_m(&self) -> f64 {
        (self.end_m[0] - self.start_m[0]).hypot(self.end_m[1] - self.start_m[1])
    }
}

/// Cuts `points_m` (consecutive points of one cluster, metres) into line segments in point
/// order (see the [module documentation](self)). Fewer than two points, or non-finite points,
/// give no segments.
pub fn split_into_lines(points_m: &[[f64; 2]], options: &LineSplitOptions) -> Vec<LineSegment> {
    if points_m.len() < 2 || points_m.iter().flatten().any(|c| !c.is_finite()) {
        return Vec::new();
    }
    let threshold_m = options.split_distance_m;

    // Split, depth first, left half before right half, so the ranges come out in order.
    let mut ranges: Vec<(usize, usize)> = Vec::new();
    let mut pending = vec![(0, points_m.len() - 1)];
    while let Some((first, last)) = pending.pop() {
        match farthest_from_chord(points_m, first, last) {
            Some((split, distance_m)) if distance_m > threshold_m => {
                pending.push((split, last));
                pending.push((first, split));
            }
            _ => ranges.push((first, last)),
        }
    }

    // Merge neighbours while their joint line still fits.
    let mut merged = true;
    while merged {
        merged = false;
        for k in 0..ranges.len().saturating_sub(1) {
            let (first, _) = ranges[k];
            let (_, last) = ranges[k + 1];
            let fits =
                total_least_squares(&points_m[first..=last]).is_some_and(|(centroid, normal)| {
                    points_m[first..=last]
                        .iter()
                        .all(|p| line_distance_m(p, centroid, normal) <= threshold_m)
                });
            if fits {
                ranges[k] = (first, last);
                ranges.remove(k + 1);
                merged = true;
                break;
            }
        }
    }

    let num_ranges = ranges.len();
    ranges
        .iter()
        .enumerate()
        .filter_map(|(k, &(first, last))| {
            // Leave out split points shared with a neighbour, if enough points remain.
            let fit_first = if k > 0 && last - first >= 3 {
                first + 1
            } else {
                first
            };
            let fit_last = if k + 1 < num_ranges && last - fit_first >= 2 {
                last - 1
            } else {
                last
            };
            let fitted = &points_m[fit_first..=fit_last];
            let (centroid_m, normal) = total_least_squares(fitted)?;
            let mut direction = [normal[1], -normal[0]];
            let span = [
                points_m[last][0] - points_m[first][0],
                points_m[last][1] - points_m[first][1],
            ];
            if direction[0] * span[0] + direction[1] * span[1] < 0.0 {
                direction = [-direction[0], -direction[1]];
            }
            let project = |p: &[f64; 2]| {
                let along_m =
                    (p[0] - centroid_m[0]) * direction[0] + (p[1] - centroid_m[1]) * direction[1];
                [
                    centroid_m[0] + along_m * direction[0],
                    centroid_m[1] + along_m * direction[1],
                ]
            };
            Some(LineSegment {
                first_index: first,
                last_index: last,
                centroid_m,
                direction,
                start_m: project(&points_m[first]),
                end_m: project(&points_m[last]),
                num_fitted_points: fitted.len(),
            })
        })
        .collect()
}

/// The point strictly between `first` and `last` farthest from the chord joining them, and
/// its distance; `None` when there is no point between them.
fn farthest_from_chord(points_m: &[[f64; 2]], first: usize, last: usize) -> Option<(usize, f64)> {
    let a = points_m[first];
    let b = points_m[last];
    let chord = [b[0] - a[0], b[1] - a[1]];
    let chord_m = chord[0].hypot(chord[1]);
    (first + 1..last)
        .map(|k| {
            let p = points_m[k];
            let to_p = [p[0] - a[0], p[1] - a[1]];
            let distance_m = if chord_m > 0.0 {
                (chord[0] * to_p[1] - chord[1] * to_p[0]).abs() / chord_m
            } else {
                to_p[0].hypot(to_p[1])
            };
            (k, distance_m)
        })
        .fold(None, |best: Option<(usize, f64)>, candidate| match best {
            Some(b) if b.1 >= candidate.1 => Some(b),
            _ => Some(candidate),
        })
}

/// Total-least-squares line through `points_m`: centroid and unit normal; `None` for fewer
/// than two points or points that all coincide.
fn total_least_squares(points_m: &[[f64; 2]]) -> Option<([f64; 2], [f64; 2])> {
    if points_m.len() < 2 {
        return None;
    }
    let n = points_m.len() as f64;
    let centroid = [
        points_m.iter().map(|p| p[0]).sum::<f64>() / n,
        points_m.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in points_m {
        let (dx, dy) = (p[0] - centroid[0], p[1] - centroid[1]);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    if sxx + syy <= 0.0 {
        return None;
    }
    // The direction of largest spread is at half the angle of (sxx − syy, 2 sxy).
    let angle_rad = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (sin, cos) = angle_rad.sin_cos();
    Some((centroid, [-sin, cos]))
}

/// Distance from `p` to the line through `centroid` with unit `normal`, metres.
fn line_distance_m(p: &[f64; 2], centroid: [f64; 2], normal: [f64; 2]) -> f64 {
    ((p[0] - centroid[0]) * normal[0] + (p[1] - centroid[1]) * normal[1]).abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::test_scene::straight;

    #[test]
    fn test_straight_run_is_one_line() {
        let points = straight([2.0, -1.0], [4.0, 3.0], 20);
        let lines = split_into_lines(&points, &LineSplitOptions::default());
        assert_eq!(lines.len(), 1);
        assert!((lines[0].length_m() - 20f64.sqrt()).abs() < 1e-9);
        assert_eq!((lines[0].first_index, lines[0].last_index), (0, 19));
    }

    #[test]
    fn test_l_shape_is_two_lines() {
        let mut points = straight([5.0, -2.0], [5.0, 1.0], 16);
        points.extend(straight([5.0, 1.0], [2.0, 1.0], 16).into_iter().skip(1));
        let lines = split_into_lines(&points, &LineSplitOptions::default());
        assert_eq!(lines.len(), 2, "{lines:?}");
        assert_eq!(lines[0].last_index, 15);
        assert_eq!(lines[1].first_index, 15);
        assert!(lines[0].direction[1] > 0.999, "{lines:?}");
        assert!(lines[1].direction[0] < -0.999, "{lines:?}");
        assert!((lines[0].end_m[1] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn test_degenerate_inputs() {
        let options = LineSplitOptions::default();
        assert!(split_into_lines(&[], &options).is_empty());
        assert!(split_into_lines(&[[1.0, 1.0]], &options).is_empty());
        assert!(split_into_lines(&[[1.0, 1.0]; 4], &options).is_empty());
        assert!(split_into_lines(&[[1.0, f64::NAN], [2.0, 2.0]], &options).is_empty());
        let nan_options = LineSplitOptions {
            split_distance_m: f64::NAN,
        };
        let points = straight([0.0, 0.0], [1.0, 1.0], 5);
        assert!(split_into_lines(&points, &nan_options).len() <= 4);
    }
}
