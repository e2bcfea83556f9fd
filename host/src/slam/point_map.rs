//! A submap's scan end points as a point cloud with surface normals, indexed for
//! nearest-neighbour queries on a uniform grid ([`PointGrid`]).
//!
//! Each end point gets the normal of the surface it lies on from its neighbouring beams in the
//! same scan (the direction of least spread of the points around it); points without a
//! well-defined surface (isolated returns, the tip of a corner) are left out, since a
//! point-to-line alignment cannot use them. A point closer than
//! [`PointMapOptions::min_spacing_m`] to one already kept is dropped, so revisiting the same wall
//! does not grow the map.

use super::point_grid::PointGrid;
use crate::geometry::Pose2;
use crate::scan_match::Scan;

/// Cell size of the grid that indexes the points, metres: about three points of a wall a
/// cell at the default spacing, and the last ICP stages' correspondence distances within
/// the query's cell and its neighbours.
const INDEX_CELL_M: f64 = 0.2;

/// How end points become map points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointMapOptions {
    /// Points of the same scan within this distance of an end point estimate its normal,
    /// metres, plus [`Self::normal_radius_per_m`] per metre of the point's range (far beams
    /// are farther apart, and a far wall is what fixes the pose along a corridor).
    pub normal_radius_m: f64,
    /// Growth of the normal radius with range, metres per metre.
    pub normal_radius_per_m: f64,
    /// Neighbouring beams on each side considered for the normal.
    pub normal_beams: usize,
    /// Largest ratio of the spread across the surface to the spread along it; above it the
    /// point has no clear surface and is not kept.
    pub max_flatness_ratio: f64,
    /// A point closer than this to one already kept is dropped, metres.
    pub min_spacing_m: f64,
}

impl Default for PointMapOptions {
    fn default() -> Self {
        PointMapOptions {
            normal_radius_m: 0.3,
            normal_radius_per_m: 0.1,
            normal_beams: 3,
            max_flatness_ratio: 0.2,
            min_spacing_m: 0.03,
        }
    }
}

/// A map point, in the map's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapPoint {
    /// Where it is, metres.
    pub point: [f64; 2],
    /// The unit normal of its surface.
    pub normal: [f64; 2],
}

/// End points with normals in one frame. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct PointMap {
    options: PointMapOptions,
    index: PointGrid,
    /// In the order of the index's points.
    points: Vec<MapPoint>,
}

impl PointMap {
    /// Gives back the room kept for points that will not come: for a map that is complete.
    pub fn shrink_to_fit(&mut self) {
        self.index.shrink_to_fit();
        self.points.shrink_to_fit();
    }

    /// An empty map.
    pub fn new(options: PointMapOptions) -> Self {
        PointMap {
            options,
            index: PointGrid::new(INDEX_CELL_M),
            points: Vec::new(),
        }
    }

    /// Adds the end points of `scan`, taken at `map_from_robot`.
    pub fn insert_scan(&mut self, scan: &Scan, map_from_robot: Pose2) {
        for (point_in_robot, normal_in_robot) in points_with_normals(scan, &self.options) {
            let point = map_from_robot.transform_point(point_in_robot);
            if self.any_within(point, self.options.min_spacing_m) {
                continue;
            }
            let (sin, cos) = map_from_robot.theta_rad.sin_cos();
            let [nx, ny] = normal_in_robot;
            let normal = [cos * nx - sin * ny, sin * nx + cos * ny];
            self.index.push(point);
            self.points.push(MapPoint { point, normal });
        }
    }

    /// The kept point nearest to `point`, within `max_distance_m`.
    pub fn nearest_within(&self, point: [f64; 2], max_distance_m: f64) -> Option<&MapPoint> {
        let (index, _) = self.index.nearest_within(point, max_distance_m)?;
        self.points.get(index)
    }

    /// The kept point nearest to `point` within `max_distance_m`, by its number in
    /// [`Self::points`], and how far every other kept point lies at least (squared, capped at
    /// `max_distance_m²`): see [`PointGrid::nearest_two_within`].
    pub fn nearest_two_within(&self, point: [f64; 2], max_distance_m: f64) -> (Option<usize>, f64) {
        let (nearest, others_sq) = self.index.nearest_two_within(point, max_distance_m);
        (nearest.map(|(index, _)| index), others_sq)
    }

    /// Whether a kept point lies within `max_distance_m` of `point`: [`Self::nearest_within`]
    /// `.is_some()`, found faster.
    pub fn any_within(&self, point: [f64; 2], max_distance_m: f64) -> bool {
        self.index.any_within(point, max_distance_m)
    }

    /// Every kept point.
    pub fn points(&self) -> &[MapPoint] {
        &self.points
    }

    /// Points kept.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when no point was kept.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// The end points of `scan` that lie on a clear surface, each with its unit normal, in the
/// robot frame.
pub fn points_with_normals(scan: &Scan, options: &PointMapOptions) -> Vec<([f64; 2], [f64; 2])> {
    let points = scan.points_in_robot();
    let mut out = Vec::with_capacity(points.len());
    // One buffer for every beam's neighbours: a scan has hundreds of beams, and an
    // allocation for each, over a run of hours, leaves the allocator ever slower.
    let window = options.normal_beams.saturating_mul(2).saturating_add(1);
    let mut neighbours: Vec<[f64; 2]> = Vec::with_capacity(window.min(points.len()));
    for (index, point) in points.iter().enumerate() {
        let Some(center) = *point else { continue };
        let range_m = center[0].hypot(center[1]);
        let radius_sq = (options.normal_radius_m + options.normal_radius_per_m * range_m).powi(2);
        let first = index.saturating_sub(options.normal_beams);
        let last = (index + options.normal_beams).min(points.len() - 1);
        neighbours.clear();
        neighbours.extend(
            points[first..=last]
                .iter()
                .flatten()
                .copied()
                .filter(|p| (p[0] - center[0]).powi(2) + (p[1] - center[1]).powi(2) <= radius_sq),
        );
        if let Some(normal) = surface_normal(&neighbours, options.max_flatness_ratio) {
            out.push((center, normal));
        }
    }
    out
}

/// The unit normal of the line through `points` (at least three), or `None` when they do not
/// lie along a line: the ratio of the smaller to the larger standard deviation about their
/// centroid exceeds `max_flatness_ratio`.
fn surface_normal(points: &[[f64; 2]], max_flatness_ratio: f64) -> Option<[f64; 2]> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let mean = points
        .iter()
        .fold([0.0, 0.0], |m, p| [m[0] + p[0] / n, m[1] + p[1] / n]);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let (dx, dy) = (p[0] - mean[0], p[1] - mean[1]);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    // Eigenvalues of the 2×2 scatter matrix; the normal is the eigenvector of the smaller.
    let half_trace = 0.5 * (sxx + syy);
    let root = (0.25 * (sxx - syy).powi(2) + sxy * sxy).sqrt();
    let (larger, smaller) = (half_trace + root, (half_trace - root).max(0.0));
    if larger <= 0.0 || (smaller / larger).sqrt() > max_flatness_ratio {
        return None;
    }
    // Direction of the larger eigenvalue, turned by 90°.
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (sin, cos) = angle.sin_cos();
    Some([-sin, cos])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall_scan() -> Scan {
        // A wall along y = 2 seen from the origin, plus one isolated return.
        let mut points: Vec<Option<[f64; 2]>> = (-10..=10)
            .map(|i| Some([f64::from(i) * 0.1, 2.0]))
            .collect();
        points.push(None);
        points.push(Some([5.0, -3.0]));
        Scan::from_points_in_robot(points)
    }

    #[test]
    fn wall_points_get_the_wall_normal_and_isolated_points_none() {
        let found = points_with_normals(&wall_scan(), &PointMapOptions::default());
        assert_eq!(found.len(), 21);
        for (_, [nx, ny]) in found {
            assert!(
                nx.abs() < 1e-9 && (ny.abs() - 1.0).abs() < 1e-9,
                "{nx} {ny}"
            );
        }
    }

    #[test]
    fn inserted_points_are_moved_into_the_map_frame_and_thinned() {
        let mut map = PointMap::new(PointMapOptions::default());
        let pose = Pose2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2);
        map.insert_scan(&wall_scan(), pose);
        assert_eq!(map.len(), 21);
        // In the map the wall lies along x = -1 with a normal along x.
        let point = map
            .nearest_within([-1.0, 1.0], 0.01)
            .map(|p| (p.point, p.normal));
        let (geom, normal) = point.unwrap_or(([9.0, 9.0], [0.0, 0.0]));
        assert!((geom[0] + 1.0).abs() < 1e-9 && (geom[1] - 1.0).abs() < 1e-9);
        assert!((normal[0].abs() - 1.0).abs() < 1e-9);
        // The same scan again adds nothing.
        map.insert_scan(&wall_scan(), pose);
        assert_eq!(map.len(), 21);
        assert!(map.nearest_within([5.0, 5.0], 0.5).is_none());
    }
}
