//! Corners: two consecutive fitted lines of one cluster meeting at roughly a right angle.
//!
//! For neighbouring segments from [`super::line_split`] that are both long enough, the vertex
//! is the intersection of their fitted lines (more precise than any single return: the beams
//! rarely hit the vertex itself). The corner is kept when the walls meet at an angle within
//! [`CornerOptions::min_angle_rad`]..=[`CornerOptions::max_angle_rad`] and the vertex lies
//! near the ends of both segments (the lines do not merely point at each other).
//!
//! Orientation: the direction, sensor frame, of the bisector from the vertex between the two
//! walls. An inside corner (a room's) has the sensor within that wedge; an outside corner (a
//! building's) does not, and is reported convex.

use serde::{Deserialize, Serialize};

use super::line_split::LineSegment;

/// When two lines make a corner.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CornerOptions {
    /// Smallest angle between the walls, radians; 60°.
    pub min_angle_rad: f64,
    /// Largest angle between the walls, radians; 120°.
    pub max_angle_rad: f64,
    /// Shortest wall (fitted segment), metres; 0.5.
    pub min_line_length_m: f64,
    /// Fewest returns a wall's line is fitted to; 4.
    pub min_line_points: usize,
    /// Farthest the vertex may lie from the facing end of either segment, metres; 0.5.
    pub max_vertex_gap_m: f64,
}

impl Default for CornerOptions {
    /// 60°–120° corners between walls of at least 0.5 m and 4 returns.
    fn default() -> Self {
        CornerOptions {
            min_angle_rad: 60f64.to_radians(),
            max_angle_rad: 120f64.to_radians(),
            min_line_length_m: 0.5,
            min_line_points: 4,
            max_vertex_gap_m: 0.5,
        }
    }
}

/// A corner between two walls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    /// The vertex, sensor frame, metres.
    pub vertex_in_sensor: [f64; 2],
    /// Direction of the bisector from the vertex between the walls, sensor frame, radians.
    pub orientation_rad: f64,
    /// Angle between the walls, radians, in `[0, π]`.
    pub angle_rad: f64,
    /// True for an outside corner (the sensor is outside the wedge the walls enclose).
    pub convex: bool,
}

/// The corners between consecutive segments of `lines` (one cluster's segments in point order,
/// sensor frame), in order (see the [module documentation](self)).
pub fn find_corners(lines: &[LineSegment], options: &CornerOptions) -> Vec<Corner> {
    let long_enough = |line: &LineSegment| {
        line.length_m() >= options.min_line_length_m
            && line.num_fitted_points >= options.min_line_points
    };
    lines
        .windows(2)
        .filter_map(|pair| {
            let [first, second] = pair else {
                return None;
            };
            let adjacent = second.first_index <= first.last_index.saturating_add(1);
            if !(adjacent && long_enough(first) && long_enough(second)) {
                return None;
            }
            let vertex_in_sensor = intersection(first, second)?;
            let gap_m =
                |a: [f64; 2]| (a[0] - vertex_in_sensor[0]).hypot(a[1] - vertex_in_sensor[1]);
            let near = gap_m(first.end_m) <= options.max_vertex_gap_m
                && gap_m(second.start_m) <= options.max_vertex_gap_m;
            if !near {
                return None;
            }
            // Unit vectors from the vertex along each wall, away from it.
            let along_first = [-first.direction[0], -first.direction[1]];
            let along_second = second.direction;
            let cos_angle = along_first[0] * along_second[0] + along_first[1] * along_second[1];
            let angle_rad = cos_angle.clamp(-1.0, 1.0).acos();
            if !(options.min_angle_rad..=options.max_angle_rad).contains(&angle_rad) {
                return None;
            }
            let bisector = [
                along_first[0] + along_second[0],
                along_first[1] + along_second[1],
            ];
            let bisector_norm = bisector[0].hypot(bisector[1]);
            if bisector_norm <= 1e-9 {
                return None;
            }
            let to_sensor = [-vertex_in_sensor[0], -vertex_in_sensor[1]];
            let to_sensor_m = to_sensor[0].hypot(to_sensor[1]);
            let cos_to_sensor = (to_sensor[0] * bisector[0] + to_sensor[1] * bisector[1])
                / (to_sensor_m * bisector_norm);
            let inside = cos_to_sensor > (0.5 * angle_rad).cos();
            Some(Corner {
                vertex_in_sensor,
                orientation_rad: bisector[1].atan2(bisector[0]),
                angle_rad,
                convex: !inside,
            })
        })
        .collect()
}

/// Where the fitted lines of `a` and `b` cross; `None` when they are (nearly) parallel.
fn intersection(a: &LineSegment, b: &LineSegment) -> Option<[f64; 2]> {
    let cross = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
    let denominator = cross(a.direction, b.direction);
    if denominator.abs() < 1e-9 {
        return None;
    }
    let between = [
        b.centroid_m[0] - a.centroid_m[0],
        b.centroid_m[1] - a.centroid_m[1],
    ];
    let along_a_m = cross(between, b.direction) / denominator;
    let vertex = [
        a.centroid_m[0] + along_a_m * a.direction[0],
        a.centroid_m[1] + along_a_m * a.direction[1],
    ];
    vertex.iter().all(|c| c.is_finite()).then_some(vertex)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::line_split::{LineSplitOptions, split_into_lines};
    use crate::landmarks::test_scene::straight;

    fn corners_of(points: &[[f64; 2]]) -> Vec<Corner> {
        let lines = split_into_lines(points, &LineSplitOptions::default());
        find_corners(&lines, &CornerOptions::default())
    }

    #[test]
    fn test_inside_corner() {
        // A room corner at (6, 2) seen from the origin: walls towards −y and towards −x.
        let mut points = straight([6.0, -2.0], [6.0, 2.0], 21);
        points.extend(straight([6.0, 2.0], [1.0, 2.0], 21).into_iter().skip(1));
        let corners = corners_of(&points);
        assert_eq!(corners.len(), 1, "{corners:?}");
        let corner = corners[0];
        assert!((corner.vertex_in_sensor[0] - 6.0).abs() < 1e-9);
        assert!((corner.vertex_in_sensor[1] - 2.0).abs() < 1e-9);
        assert!((corner.angle_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert!((corner.orientation_rad - (-135f64).to_radians()).abs() < 1e-9);
        assert!(!corner.convex);
    }

    #[test]
    fn test_outside_corner() {
        // A box corner at (4, 0) pointing at the sensor.
        let mut points = straight([5.0, -1.0], [4.0, 0.0], 11);
        points.extend(straight([4.0, 0.0], [5.0, 1.0], 11).into_iter().skip(1));
        let corners = corners_of(&points);
        assert_eq!(corners.len(), 1, "{corners:?}");
        assert!(corners[0].convex);
        assert!(corners[0].orientation_rad.abs() < 1e-9);
    }

    #[test]
    fn test_shallow_bend_and_short_walls_are_no_corners() {
        let mut bend = straight([5.0, -2.0], [5.0, 0.0], 11);
        bend.extend(straight([5.0, 0.0], [6.0, 2.0], 11).into_iter().skip(1));
        assert!(corners_of(&bend).is_empty());
        let mut stub = straight([5.0, -2.0], [5.0, 0.0], 11);
        stub.extend(straight([5.0, 0.0], [4.7, 0.0], 3).into_iter().skip(1));
        assert!(corners_of(&stub).is_empty());
    }
}
