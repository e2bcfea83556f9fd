//! A submap as SLAM keeps it: the occupancy grid, the end points with their normals for
//! point-to-line alignment, the scans it holds drawn as one reference for the raster matcher,
//! and which trajectory nodes it spans.

use super::point_map::{PointMap, PointMapOptions};
use crate::geometry::Pose2;
use crate::grid::{CellIndex, Occupancy, Submap, SubmapOptions};
use crate::scan_match::Scan;

/// How well a scan placed in a submap agrees with it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SubmapFit {
    /// Fraction of the scan's end points within the inlier distance of a submap point.
    pub inlier_fraction: f64,
    /// Fraction of the scan's end points away from every submap point and on cells the submap
    /// has seen free: a wall where the submap's beams passed through, which a right pose does
    /// not produce.
    pub free_fraction: f64,
    /// Mean occupancy probability at the end points on cells the submap observed (0 when none
    /// are). End points on cells it never observed are left out: a place seen again from
    /// elsewhere, or outdoors past the vegetation, has parts the submap never saw, and they
    /// say nothing against the match (the inlier and free fractions judge them).
    pub mean_probability: f64,
    /// [`Self::inlier_fraction`] with each end point weighted by its range: the share of the
    /// scanned surface rather than of the beams. Beams fan out, so a far wall gets few end
    /// points, yet it is what fixes the pose along a corridor.
    pub surface_fraction: f64,
    /// [`Self::free_fraction`] weighted by range, as [`Self::surface_fraction`].
    pub free_surface_fraction: f64,
    /// The share of the scanned surface (weighted by range, as [`Self::surface_fraction`])
    /// whose beam passes through a surface the submap holds, well short of its end point: a
    /// beam through a wall, which a right pose does not produce either. It is the other side
    /// of [`Self::free_surface_fraction`]: a pose short of the truth along a corridor puts end
    /// points where the submap saw free space, one beyond it sends beams through the walls
    /// the submap saw. Only [`SlamSubmap::tracking_fit`] walks the beams; [`SlamSubmap::fit`]
    /// leaves it 0.
    pub through_surface_fraction: f64,
}

impl SubmapFit {
    /// How well the scan fits, for choosing between poses: the share of its surface on the
    /// submap's surfaces, less `free_weight` times the share that contradicts it (on cells it
    /// has seen free, or seen through its surfaces).
    pub fn tracking_score(&self, free_weight: f64) -> f64 {
        self.surface_fraction
            - free_weight * (self.free_surface_fraction + self.through_surface_fraction)
    }
}

/// Cells below this occupancy probability count as seen free.
const FREE_PROBABILITY: f32 = 0.4;

/// Cells at or above this occupancy probability count as a surface a beam cannot pass: hit
/// more often than seen free, by more than a single stray return (one hit alone makes 0.9
/// with the pipeline's grid options).
const SURFACE_PROBABILITY: f32 = 0.95;

/// A beam counts as passing through a surface only short of its end point by this many
/// inlier distances: near the end point the wall it hit, thickened by noise, is no
/// contradiction.
const THROUGH_MARGIN_INLIERS: f64 = 3.0;

/// One submap of the trajectory. Its frame is the local pose of its first scan, so a scan's
/// pose in the submap is also its pose relative to that first node.
#[derive(Clone, Debug)]
pub struct SlamSubmap {
    submap: Submap,
    /// `local_from_submap`.
    pose_in_local: Pose2,
    /// End points with normals, in the submap frame.
    points: PointMap,
    /// End points of every inserted scan in the submap frame, one polyline per scan; `None`
    /// once forgotten ([`Self::forget_end_points`]).
    points_in_submap: Option<Vec<Option<[f64; 2]>>>,
    /// The node of every inserted scan, and where the scan lies in the submap
    /// (`submap_from_robot`): enough to draw the end points again from the scans.
    inserted: Vec<(usize, Pose2)>,
    first_node: usize,
    last_node: usize,
}

impl SlamSubmap {
    /// An empty submap whose frame is `pose_in_local`, the pose of node `first_node`.
    pub fn new(
        pose_in_local: Pose2,
        first_node: usize,
        options: SubmapOptions,
        point_options: PointMapOptions,
    ) -> Self {
        SlamSubmap {
            submap: Submap::with_pose_in_map(pose_in_local, options),
            pose_in_local,
            points: PointMap::new(point_options),
            points_in_submap: Some(Vec::new()),
            inserted: Vec::new(),
            first_node,
            last_node: first_node,
        }
    }

    /// Inserts `scan` of node `node`, taken at `robot_pose_in_local`. Nothing happens once
    /// the submap is finished.
    pub fn insert(&mut self, node: usize, scan: &Scan, robot_pose_in_local: Pose2) {
        if self.submap.insert(scan, robot_pose_in_local).is_err() {
            return;
        }
        self.insert_points(node, scan, robot_pose_in_local);
    }

    /// The part of [`Self::insert`] that leaves the grid alone: the end points, for alignment
    /// and for the raster matcher. A submap built this way must have its grid drawn
    /// ([`Self::insert_into_grid`], the same scans at the same poses) before it is fit.
    pub(crate) fn insert_points(&mut self, node: usize, scan: &Scan, robot_pose_in_local: Pose2) {
        let submap_from_robot = self.pose_in_local.inverse() * robot_pose_in_local;
        self.points.insert_scan(scan, submap_from_robot);
        if let Some(points_in_submap) = &mut self.points_in_submap {
            append_in_submap(points_in_submap, scan, submap_from_robot);
        }
        self.inserted.push((node, submap_from_robot));
        self.last_node = node;
    }

    /// The other part of [`Self::insert`]: `scan` into the occupancy grid only. Nothing
    /// happens once the submap is finished.
    pub(crate) fn insert_into_grid(&mut self, scan: &Scan, robot_pose_in_local: Pose2) {
        let _ = self.submap.insert(scan, robot_pose_in_local);
    }

    /// Makes room at once for `scans`, each with its `robot_pose_in_local`, before they are
    /// inserted in turn ([`Submap::reserve_for`]).
    pub fn reserve_for<'a>(&mut self, scans: impl IntoIterator<Item = (&'a Scan, Pose2)>) {
        self.submap.reserve_for(scans);
    }

    /// Stops insertion, and gives back the room kept for what will not be inserted.
    pub fn finish(&mut self) {
        self.submap.finish();
        self.points.shrink_to_fit();
        self.inserted.shrink_to_fit();
        if let Some(points_in_submap) = &mut self.points_in_submap {
            points_in_submap.shrink_to_fit();
        }
    }

    /// The occupancy grid, in the submap frame.
    pub fn grid(&self) -> &crate::grid::ProbabilityGrid {
        self.submap.grid()
    }

    /// The end points with normals, in the submap frame.
    pub fn points(&self) -> &PointMap {
        &self.points
    }

    /// How `points_in_robot` (end points, robot frame), placed at `submap_from_robot`, agree
    /// with the submap; an end point within `inlier_m` of a submap point is an inlier. Judges
    /// the end points only ([`SubmapFit::through_surface_fraction`] is 0): what loop closure's
    /// acceptance test and the final refinement read.
    pub fn fit(
        &self,
        points_in_robot: &[[f64; 2]],
        submap_from_robot: Pose2,
        inlier_m: f64,
    ) -> SubmapFit {
        self.fit_on(
            self.submap.grid(),
            points_in_robot,
            submap_from_robot,
            inlier_m,
        )
    }

    /// [`Self::fit`] with the occupancy read from `occupancy`, a grid of this submap's scans
    /// (a [`LazyGrid`](crate::grid::LazyGrid) of them where the grid is not drawn).
    pub fn fit_on(
        &self,
        occupancy: &impl Occupancy,
        points_in_robot: &[[f64; 2]],
        submap_from_robot: Pose2,
        inlier_m: f64,
    ) -> SubmapFit {
        self.fit_with_beams(
            occupancy,
            points_in_robot,
            submap_from_robot,
            inlier_m,
            false,
        )
    }

    /// [`Self::fit`] with the beams walked too ([`SubmapFit::through_surface_fraction`]), for
    /// [`SubmapFit::tracking_score`].
    pub fn tracking_fit(
        &self,
        points_in_robot: &[[f64; 2]],
        submap_from_robot: Pose2,
        inlier_m: f64,
    ) -> SubmapFit {
        let grid = self.submap.grid();
        self.fit_with_beams(grid, points_in_robot, submap_from_robot, inlier_m, true)
    }

    fn fit_with_beams(
        &self,
        occupancy: &impl Occupancy,
        points_in_robot: &[[f64; 2]],
        submap_from_robot: Pose2,
        inlier_m: f64,
        walk_beams: bool,
    ) -> SubmapFit {
        if points_in_robot.is_empty() {
            return SubmapFit::default();
        }
        let grid = self.submap.grid();
        let (mut inliers, mut free, mut probability_sum) = (0usize, 0usize, 0.0);
        let mut known = 0usize;
        let (mut range_sum_m, mut inlier_range_m, mut free_range_m) = (0.0, 0.0, 0.0);
        let mut through_range_m = 0.0;
        let origin = grid
            .limits()
            .cell_index([submap_from_robot.x_m, submap_from_robot.y_m]);
        for &p in points_in_robot {
            let range_m = p[0].hypot(p[1]);
            range_sum_m += range_m;
            let point = submap_from_robot.transform_point(p);
            if walk_beams
                && self.beam_passes_a_surface(origin, p, range_m, submap_from_robot, inlier_m)
            {
                through_range_m += range_m;
            }
            let inlier = self.is_inlier(point, inlier_m);
            if inlier {
                inliers += 1;
                inlier_range_m += range_m;
            }
            if let Some(probability) = occupancy.probability_at(point) {
                known += 1;
                probability_sum += f64::from(probability);
                if !inlier && probability < FREE_PROBABILITY {
                    free += 1;
                    free_range_m += range_m;
                }
            }
        }
        let n = points_in_robot.len() as f64;
        let surface = |part_m: f64| {
            if range_sum_m > 0.0 {
                part_m / range_sum_m
            } else {
                0.0
            }
        };
        SubmapFit {
            inlier_fraction: inliers as f64 / n,
            free_fraction: free as f64 / n,
            mean_probability: if known > 0 {
                probability_sum / known as f64
            } else {
                0.0
            },
            surface_fraction: surface(inlier_range_m),
            free_surface_fraction: surface(free_range_m),
            through_surface_fraction: surface(through_range_m),
        }
    }

    /// Whether the beam to `point_in_robot` (at `range_m`), from the robot's cell `origin`
    /// with the robot at `submap_from_robot`, crosses a cell the submap holds as a surface
    /// before it comes within [`THROUGH_MARGIN_INLIERS`] × `inlier_m` of its end point.
    fn beam_passes_a_surface(
        &self,
        origin: CellIndex,
        point_in_robot: [f64; 2],
        range_m: f64,
        submap_from_robot: Pose2,
        inlier_m: f64,
    ) -> bool {
        let short_m = range_m - THROUGH_MARGIN_INLIERS * inlier_m;
        if short_m <= 0.0 {
            return false;
        }
        let scale = short_m / range_m;
        let short_point = submap_from_robot
            .transform_point([point_in_robot[0] * scale, point_in_robot[1] * scale]);
        let grid = self.submap.grid();
        let end = grid.limits().cell_index(short_point);
        grid.line_reaches_probability(origin, end, SURFACE_PROBABILITY)
    }

    /// [`SubmapFit::inlier_fraction`] of [`Self::fit`], to the bit, without the grid.
    pub fn inlier_fraction(
        &self,
        points_in_robot: &[[f64; 2]],
        submap_from_robot: Pose2,
        inlier_m: f64,
    ) -> f64 {
        if points_in_robot.is_empty() {
            return 0.0;
        }
        let inliers = points_in_robot
            .iter()
            .filter(|&&p| self.is_inlier(submap_from_robot.transform_point(p), inlier_m))
            .count();
        inliers as f64 / points_in_robot.len() as f64
    }

    /// Whether an end point at `point_in_submap` lies on the submap's surfaces: within
    /// `inlier_m` of one of its points. [`Self::fit`] and [`Self::inlier_fraction`] both ask
    /// this, so that they count the same inliers.
    fn is_inlier(&self, point_in_submap: [f64; 2], inlier_m: f64) -> bool {
        self.points.any_within(point_in_submap, inlier_m)
    }

    /// Every inserted scan in the submap frame, as one reference for the raster matcher;
    /// `None` once the end points were forgotten ([`Self::reference_scan_from`] draws them
    /// again).
    pub fn reference_scan(&self) -> Option<Scan> {
        self.points_in_submap
            .clone()
            .map(Scan::from_points_in_robot)
    }

    /// [`Self::reference_scan`] drawn from the scans it was built from: `node_scan` gives the
    /// scan of a node (the same one inserted). A scan it does not give is left out.
    pub fn reference_scan_from<'a>(&self, node_scan: impl Fn(usize) -> Option<&'a Scan>) -> Scan {
        let mut points_in_submap = Vec::new();
        for &(node, submap_from_robot) in &self.inserted {
            if let Some(scan) = node_scan(node) {
                append_in_submap(&mut points_in_submap, scan, submap_from_robot);
            }
        }
        Scan::from_points_in_robot(points_in_submap)
    }

    /// Frees the end points kept for [`Self::reference_scan`], which a finished submap whose
    /// scans are kept elsewhere does not need: they are the scans again, once per submap
    /// holding them.
    pub fn forget_end_points(&mut self) {
        self.points_in_submap = None;
    }

    /// `local_from_submap`.
    pub fn pose_in_local(&self) -> Pose2 {
        self.pose_in_local
    }

    /// Where each inserted scan was taken, in the submap frame (`submap_from_robot`).
    pub fn scan_poses_in_submap(&self) -> impl Iterator<Item = Pose2> + '_ {
        self.inserted.iter().map(|&(_, pose)| pose)
    }

    /// The node whose pose is the submap frame.
    pub fn first_node(&self) -> usize {
        self.first_node
    }

    /// The last node inserted.
    pub fn last_node(&self) -> usize {
        self.last_node
    }

    /// Scans inserted.
    pub fn num_scans(&self) -> usize {
        self.submap.num_scans()
    }

    /// Whether insertion has stopped.
    pub fn is_finished(&self) -> bool {
        self.submap.is_finished()
    }
}

/// Appends `scan`'s end points in the submap frame, and a break after them.
fn append_in_submap(
    points_in_submap: &mut Vec<Option<[f64; 2]>>,
    scan: &Scan,
    submap_from_robot: Pose2,
) {
    points_in_submap.extend(
        scan.points_in_robot()
            .iter()
            .map(|p| p.map(|p| submap_from_robot.transform_point(p))),
    );
    points_in_submap.push(None);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan_match::synthetic::{cast_front_scan, polygon_walls};

    #[test]
    fn the_surface_fraction_weights_end_points_by_range() {
        // A corridor 2 m wide along x, closed 10 m ahead.
        let walls = polygon_walls(&[[-1.0, -1.0], [10.0, -1.0], [10.0, 1.0], [-1.0, 1.0]]);
        let scan = cast_front_scan(&walls, Pose2::IDENTITY);
        let mut submap = SlamSubmap::new(
            Pose2::IDENTITY,
            0,
            SubmapOptions::default(),
            PointMapOptions::default(),
        );
        // Seen many times, so that the cells the beams pass through count as free.
        for node in 0..20 {
            submap.insert(node, &scan, Pose2::IDENTITY);
        }
        // One end point on the side wall 1 m away, one 0.5 m short of the end wall.
        let points = [[0.0, 1.0], [9.5, 0.0]];
        let fit = submap.fit(&points, Pose2::IDENTITY, 0.1);
        assert_eq!(fit.inlier_fraction, 0.5);
        assert!((fit.surface_fraction - 1.0 / 10.5).abs() < 1e-9, "{fit:?}");
        // The short end point lies where the beams passed through: seen free.
        assert_eq!(fit.free_fraction, 0.5);
        assert!(
            (fit.free_surface_fraction - 9.5 / 10.5).abs() < 1e-9,
            "{fit:?}"
        );
        assert!((fit.tracking_score(0.5) - (1.0 - 0.5 * 9.5) / 10.5).abs() < 1e-9);
    }

    #[test]
    fn a_pose_beyond_the_truth_sends_beams_through_the_walls() {
        // A corridor 2 m wide along x, closed 10 m ahead, seen from 20 poses near its start,
        // so that the far wall is drawn without gaps between the beams' end points (as in a
        // real submap of many scans), into a grid built as the pipeline builds its submaps.
        let walls = polygon_walls(&[[-1.0, -1.0], [10.0, -1.0], [10.0, 1.0], [-1.0, 1.0]]);
        let options = crate::slam::SlamOptions::default();
        let mut submap = SlamSubmap::new(Pose2::IDENTITY, 0, options.submap, options.point_map);
        for node in 0..20 {
            // Turned by fifths of the beams' spacing, so the end points interleave.
            let turn_rad = ((node % 5) as f64 * 0.2).to_radians();
            let pose = Pose2::new(-0.5 + 0.05 * node as f64, 0.0, turn_rad);
            submap.insert(node, &cast_front_scan(&walls, pose), pose);
        }
        let scan = cast_front_scan(&walls, Pose2::IDENTITY);
        let points: Vec<[f64; 2]> = scan.points_in_robot().iter().flatten().copied().collect();
        let fit_at = |x_m: f64| submap.tracking_fit(&points, Pose2::new(x_m, 0.0, 0.0), 0.1);
        let (short, right, beyond) = (fit_at(-1.0), fit_at(0.0), fit_at(1.0));
        assert!(right.through_surface_fraction < 0.02, "{right:?}");
        assert!(right.free_surface_fraction < 0.1, "{right:?}");
        // A metre beyond: the end wall's beams pass through the end wall the submap holds.
        assert!(beyond.through_surface_fraction > 0.2, "{beyond:?}");
        // A metre short: its end points lie where the submap saw free space instead.
        assert!(short.free_surface_fraction > 0.2, "{short:?}");
        assert!(short.through_surface_fraction < 0.05, "{short:?}");
        let score = |fit: SubmapFit| fit.tracking_score(0.5);
        assert!(score(right) > score(beyond) + 0.3, "{right:?} {beyond:?}");
        assert!(score(right) > score(short) + 0.3, "{right:?} {short:?}");
    }

    #[test]
    fn the_inlier_fraction_without_the_grid_is_the_fit_s() {
        let walls = polygon_walls(&[[-1.0, -2.0], [6.0, -2.0], [6.0, 3.0], [-1.0, 3.0]]);
        let mut submap = SlamSubmap::new(
            Pose2::IDENTITY,
            0,
            SubmapOptions::default(),
            PointMapOptions::default(),
        );
        for node in 0..3 {
            let k = node as f64;
            let pose = Pose2::new(0.4 * k, 0.1, 0.05 * k);
            submap.insert(node, &cast_front_scan(&walls, pose), pose);
        }
        let scan = cast_front_scan(&walls, Pose2::new(1.0, 0.3, 0.2));
        let points: Vec<[f64; 2]> = scan.points_in_robot().iter().flatten().copied().collect();
        for pose in [
            Pose2::new(1.0, 0.3, 0.2),
            Pose2::new(1.04, 0.25, 0.21),
            Pose2::new(0.5, 0.0, -0.3),
        ] {
            let fit = submap.fit(&points, pose, 0.1);
            assert_eq!(
                submap.inlier_fraction(&points, pose, 0.1),
                fit.inlier_fraction
            );
        }
        assert!(
            submap
                .fit(&points, Pose2::new(1.0, 0.3, 0.2), 0.1)
                .inlier_fraction
                > 0.9
        );
    }

    #[test]
    fn a_finished_submap_draws_its_reference_again_from_the_scans() {
        // A submap not at the origin, with scans at poses that differ, as along a trajectory.
        let walls = polygon_walls(&[[-1.0, -1.0], [10.0, -1.0], [10.0, 1.0], [-1.0, 1.0]]);
        let options = crate::slam::SlamOptions::default();
        let frame = Pose2::new(0.3, -0.2, 0.1);
        let mut submap = SlamSubmap::new(frame, 4, options.submap, options.point_map);
        let scans: Vec<(Scan, Pose2)> = (0..6)
            .map(|k| {
                let pose = Pose2::new(0.3 + 0.4 * k as f64, -0.2, 0.1 - 0.03 * k as f64);
                (cast_front_scan(&walls, pose), pose)
            })
            .collect();
        for (k, (scan, pose)) in scans.iter().enumerate() {
            submap.insert(4 + k, scan, *pose);
        }
        submap.finish();
        let kept = submap
            .reference_scan()
            .expect("end points kept until forgotten");
        assert!(kept.points_in_robot().iter().flatten().count() > 100);
        submap.forget_end_points();
        assert_eq!(submap.reference_scan(), None);
        let node_scan = |node: usize| node.checked_sub(4).and_then(|k| scans.get(k)).map(|s| &s.0);
        // The same points, to the bit.
        assert_eq!(submap.reference_scan_from(node_scan), kept);
    }
}
