//! Synthetic scans of a world made of wall segments, for tests and benchmarks.
//!
//! Each beam is cast from the sensor (at the robot origin) and stops at the nearest wall; a beam
//! that hits nothing within range has no return.

use super::scan::Scan;
use crate::geometry::Pose2;

/// A wall from one end point to the other, in map coordinates (metres).
pub type WallInMap = [[f64; 2]; 2];

/// The walls of the closed polygon with corners `corners_in_map` (metres), in order.
pub fn polygon_walls(corners_in_map: &[[f64; 2]]) -> Vec<WallInMap> {
    (0..corners_in_map.len())
        .map(|i| {
            [
                corners_in_map[i],
                corners_in_map[(i + 1) % corners_in_map.len()],
            ]
        })
        .collect()
}

/// Casts `num_beams` beams from a robot at `pose_in_map`, beam `i` at
/// `start_angle_rad + i * angle_step_rad` in the robot frame, against `walls_in_map`.
///
/// Ranges beyond `max_range_m` are beams without a return.
pub fn cast_scan(
    walls_in_map: &[WallInMap],
    pose_in_map: Pose2,
    start_angle_rad: f64,
    angle_step_rad: f64,
    num_beams: usize,
    max_range_m: f64,
) -> Scan {
    let ranges_m: Vec<f64> = (0..num_beams)
        .map(|beam| {
            let angle_in_map_rad =
                pose_in_map.theta_rad + start_angle_rad + beam as f64 * angle_step_rad;
            let direction = [angle_in_map_rad.cos(), angle_in_map_rad.sin()];
            let origin = [pose_in_map.x_m, pose_in_map.y_m];
            walls_in_map
                .iter()
                .filter_map(|wall| ray_hits_wall_m(origin, direction, wall))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    Scan::from_ranges(&ranges_m, start_angle_rad, angle_step_rad, max_range_m)
}

/// [`cast_scan`] in the usual LMS2xx layout: 181 beams 1° apart from −90° to +90°, 20 m range.
pub fn cast_front_scan(walls: &[WallInMap], pose: Pose2) -> Scan {
    cast_scan(
        walls,
        pose,
        -std::f64::consts::FRAC_PI_2,
        1f64.to_radians(),
        181,
        20.0,
    )
}

/// The walls of an irregular room about 9 m × 7 m around the origin, whose outline no shift or
/// turn maps onto itself.
pub fn irregular_room_walls() -> Vec<WallInMap> {
    polygon_walls(&[
        [-4.0, -3.0],
        [5.0, -3.0],
        [5.0, 2.0],
        [1.0, 4.0],
        [-2.0, 4.0],
        [-4.0, 1.0],
    ])
}

/// Distance along the unit ray `origin + t * direction` to `wall`, if the ray meets it ahead.
fn ray_hits_wall_m(origin: [f64; 2], direction: [f64; 2], wall: &WallInMap) -> Option<f64> {
    let [a, b] = *wall;
    let edge = [b[0] - a[0], b[1] - a[1]];
    let to_start = [a[0] - origin[0], a[1] - origin[1]];
    let cross = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
    let denominator = cross(direction, edge);
    if denominator.abs() < 1e-12 {
        return None;
    }
    let range_m = cross(to_start, edge) / denominator;
    let along_wall = cross(to_start, direction) / denominator;
    (range_m > 0.0 && (0.0..=1.0).contains(&along_wall)).then_some(range_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_square_room_ranges() {
        let walls = polygon_walls(&[[-1.0, -1.0], [2.0, -1.0], [2.0, 1.0], [-1.0, 1.0]]);
        let scan = cast_scan(
            &walls,
            Pose2::IDENTITY,
            0.0,
            std::f64::consts::FRAC_PI_2,
            4,
            10.0,
        );
        let expected = [[2.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
        for (point, expected) in scan.points_in_robot().iter().zip(expected) {
            let [x, y] = point.unwrap_or([f64::NAN, f64::NAN]);
            assert!((x - expected[0]).abs() < 1e-9 && (y - expected[1]).abs() < 1e-9);
        }
    }

    #[test]
    fn test_out_of_range_has_no_return() {
        let walls = polygon_walls(&[[5.0, -1.0], [6.0, 0.0], [5.0, 1.0]]);
        let scan = cast_scan(&walls, Pose2::IDENTITY, 0.0, std::f64::consts::PI, 2, 4.0);
        assert_eq!(scan.points_in_robot(), &[None, None]);
    }
}
