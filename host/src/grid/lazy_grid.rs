//! The occupancy a submap drawn from scans would hold, worked out only at the cells asked for.
//!
//! A loop-closure test reads a grid at a scan's few hundred end points, and drawing a chain of
//! tens of scans by ray casting costs far more than reading it. A [`LazyGrid`] keeps each
//! scan's sensor cell and its beams' end cells, sorted by direction. A cell's value is the
//! sequence of updates [`RangeInserter`] would make, scan after scan: a hit where a beam
//! ends in the cell, otherwise a miss where a beam's Bresenham line crosses it, clamped as the
//! grid clamps. Only the beams whose direction passes within half a cell of the cell can cross
//! it, and those are found by direction. The value is the drawn grid's, to the bit.

use super::map_limits::{CellIndex, MapLimits};
use super::probability_grid::{LogOddsBounds, ProbabilityGrid, probability_from_log_odds};
use super::range_inserter::{RangeInserter, chebyshev_length};
use super::submap::SubmapOptions;
use crate::geometry::Pose2;
use crate::scan_match::{BresenhamLine, Scan};

/// What one scan did to one cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Evidence {
    Hit,
    Miss,
}

/// Slices of the pseudo-angle's range indexed per scan, for finding beams by direction.
const DIRECTION_BUCKETS: usize = 256;

/// One scan's beams as the inserter draws them: from the sensor cell to each end cell.
#[derive(Clone, Debug)]
struct ScanRays {
    sensor: CellIndex,
    /// The pseudo-angle ([`pseudo_angle`]) of each beam, from the sensor cell to its end
    /// cell, ascending.
    directions: Vec<f64>,
    /// The end cell of each beam, in the order of `directions`.
    ends: Vec<CellIndex>,
    /// For each of [`DIRECTION_BUCKETS`] equal slices of the pseudo-angle's `[0, 4)`, and for
    /// 4, the first beam at least as far round: where a search by direction starts.
    bucket_starts: Vec<u32>,
    /// The longest beam, in cells along its major axis.
    reach_cells: usize,
    /// Whether a beam ends in the sensor cell (such beams have no direction and cross no
    /// cell, and are not in `ends`).
    hits_sensor_cell: bool,
}

impl ScanRays {
    fn new(sensor: CellIndex, ends: impl IntoIterator<Item = CellIndex>) -> Self {
        let mut hits_sensor_cell = false;
        let mut rays: Vec<(f64, CellIndex)> = ends
            .into_iter()
            .filter(|&end| {
                hits_sensor_cell |= end == sensor;
                end != sensor
            })
            .map(|end| (pseudo_angle(offset(sensor, end)), end))
            .collect();
        rays.sort_by(|a, b| a.0.total_cmp(&b.0));
        let reach_cells = rays
            .iter()
            .map(|&(_, end)| chebyshev_length(sensor, end))
            .max()
            .unwrap_or(0);
        let directions: Vec<f64> = rays.iter().map(|r| r.0).collect();
        let mut beam = 0;
        let bucket_starts = (0..=DIRECTION_BUCKETS)
            .map(|bucket| {
                let start = bucket as f64 * (4.0 / DIRECTION_BUCKETS as f64);
                while directions.get(beam).is_some_and(|&d| d < start) {
                    beam += 1;
                }
                beam as u32
            })
            .collect();
        ScanRays {
            sensor,
            bucket_starts,
            directions,
            ends: rays.iter().map(|r| r.1).collect(),
            reach_cells,
            hits_sensor_cell,
        }
    }

    /// The first beam whose pseudo-angle is at least `direction` (in `[0, 4]`), or the number
    /// of beams.
    fn first_at_least(&self, direction: f64) -> usize {
        let bucket =
            ((direction * (DIRECTION_BUCKETS as f64 / 4.0)) as usize).min(DIRECTION_BUCKETS);
        let start = self.bucket_starts[bucket] as usize;
        let end = self.bucket_starts[(bucket + 1).min(DIRECTION_BUCKETS)] as usize;
        start + self.directions[start..end].partition_point(|&d| d < direction)
    }

    /// What the scan did to `cell`: a hit wins over a miss, as the inserter updates each
    /// cell once a scan, hits first.
    fn evidence(&self, cell: CellIndex) -> Option<Evidence> {
        let distance_cells = chebyshev_length(self.sensor, cell);
        if distance_cells > self.reach_cells {
            return None;
        }
        if distance_cells == 0 {
            // Every beam leaving the sensor cell starts with it.
            return if self.hits_sensor_cell {
                Some(Evidence::Hit)
            } else {
                (!self.ends.is_empty()).then_some(Evidence::Miss)
            };
        }
        // A cell of a Bresenham line lies within half a cell of the line through the centres
        // of its end cells, so the beam's direction is within asin(0.5 / d) ≤ 0.786 / d of the
        // cell's, d its distance in cells (at least its Chebyshev distance); the pseudo-angle
        // changes no faster than the angle. 0.8 leaves room for rounding.
        let direction = pseudo_angle(offset(self.sensor, cell));
        let half_width = 0.8 / distance_cells as f64;
        let (lowest, highest) = (direction - half_width, direction + half_width);
        let mut evidence = None;
        let mut look = |beams: std::ops::Range<usize>| {
            for end in &self.ends[beams] {
                if *end == cell {
                    return true;
                }
                let num_free = chebyshev_length(self.sensor, *end);
                if BresenhamLine::contains_within(self.sensor, *end, cell, num_free) {
                    evidence = Some(Evidence::Miss);
                }
            }
            false
        };
        let all = self.ends.len();
        // The window wraps past the pseudo-angle's 4 back to 0 on one side or the other.
        let hit = if lowest < 0.0 {
            look(self.first_at_least(lowest + 4.0)..all) || look(0..self.first_at_least(highest))
        } else if highest > 4.0 {
            look(self.first_at_least(lowest)..all) || look(0..self.first_at_least(highest - 4.0))
        } else {
            look(self.first_at_least(lowest)..self.first_at_least(highest))
        };
        if hit { Some(Evidence::Hit) } else { evidence }
    }
}

/// A submap's occupancy grid, never drawn: each cell's value is worked out from the scans
/// when it is read. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct LazyGrid {
    limits: MapLimits,
    bounds: LogOddsBounds,
    hit_log_odds: f32,
    miss_log_odds: f32,
    scans: Vec<ScanRays>,
}

impl LazyGrid {
    /// The grid a [`Submap`](super::Submap) of `options` with its frame at `map_from_submap`
    /// holds once `scans` (each with its `robot_pose_in_map`) are reserved for
    /// ([`Submap::reserve_for`](super::Submap::reserve_for)) and inserted in turn. `None` where
    /// that grid would be drawn differently: free rays along beams without a return
    /// ([`RangeInserterOptions::miss_range_m`](super::RangeInserterOptions::miss_range_m)), or
    /// scans too far apart to reserve the grid at once (it would then grow scan by scan).
    pub fn new<'a, I>(options: SubmapOptions, map_from_submap: Pose2, scans: I) -> Option<Self>
    where
        I: IntoIterator<Item = (&'a Scan, Pose2)>,
        I::IntoIter: Clone,
    {
        if options.range_inserter.miss_range_m.is_some() {
            return None;
        }
        let scans = scans.into_iter();
        let mut inserter = RangeInserter::new(options.range_inserter);
        let empty = ProbabilityGrid::new(options.resolution_m, options.grid);
        let submap_from_map = map_from_submap.inverse();
        let box_in_grid = inserter.bounds_of_scans(scans.clone(), submap_from_map);
        let (hit_log_odds, miss_log_odds) = inserter.hit_and_miss_log_odds();
        let mut grid = LazyGrid {
            limits: *empty.limits(),
            bounds: empty.log_odds_bounds(),
            hit_log_odds,
            miss_log_odds,
            scans: Vec::new(),
        };
        let Some((lower, upper)) = box_in_grid else {
            return Some(grid);
        };
        grid.limits = empty.limits_reserved_when_empty(lower, upper)?;
        for (scan, robot_pose_in_map) in scans {
            let grid_from_robot = submap_from_map * robot_pose_in_map;
            if inserter.bounds_in_grid(scan, grid_from_robot).is_none() {
                continue;
            }
            let limits = grid.limits;
            let sensor = limits.cell_index([grid_from_robot.x_m, grid_from_robot.y_m]);
            let ends = inserter
                .hits_in_grid()
                .iter()
                .map(|&p| limits.cell_index(p));
            grid.scans.push(ScanRays::new(sensor, ends));
        }
        Some(grid)
    }

    /// Placement, resolution and size of the grid the scans would be drawn into.
    pub fn limits(&self) -> &MapLimits {
        &self.limits
    }

    /// Probability that `cell` is occupied, or `None` if no scan observed it: as
    /// [`ProbabilityGrid::probability`] of the drawn grid.
    pub fn probability(&self, cell: CellIndex) -> Option<f32> {
        let mut log_odds = None;
        for scan in &self.scans {
            let delta = match scan.evidence(cell) {
                Some(Evidence::Hit) => self.hit_log_odds,
                Some(Evidence::Miss) => self.miss_log_odds,
                None => continue,
            };
            log_odds = Some(self.bounds.updated(log_odds.unwrap_or(f32::NAN), delta));
        }
        log_odds.map(probability_from_log_odds)
    }

    /// Probability that the cell containing `point_in_grid` (metres) is occupied, or `None`
    /// if no scan observed it: as [`ProbabilityGrid::probability_at`] of the drawn grid.
    pub fn probability_at(&self, point_in_grid: [f64; 2]) -> Option<f32> {
        if !point_in_grid.iter().all(|c| c.is_finite()) {
            return None;
        }
        self.probability(self.limits.cell_index(point_in_grid))
    }
}

/// A grid's occupancy probability at a point of its frame, drawn ([`ProbabilityGrid`]) or
/// worked out when read ([`LazyGrid`]): all a match's acceptance test reads of a grid.
pub trait Occupancy {
    /// Probability that the cell containing `point_in_grid` (metres) is occupied, or `None`
    /// if nothing observed it.
    fn probability_at(&self, point_in_grid: [f64; 2]) -> Option<f32>;
}

impl Occupancy for ProbabilityGrid {
    fn probability_at(&self, point_in_grid: [f64; 2]) -> Option<f32> {
        ProbabilityGrid::probability_at(self, point_in_grid)
    }
}

impl Occupancy for LazyGrid {
    fn probability_at(&self, point_in_grid: [f64; 2]) -> Option<f32> {
        LazyGrid::probability_at(self, point_in_grid)
    }
}

/// `to - from`, per axis, in cells.
fn offset(from: CellIndex, to: CellIndex) -> [f64; 2] {
    [0, 1].map(|axis| f64::from(to[axis]) - f64::from(from[axis]))
}

/// A direction's "diamond angle" in `[0, 4)`: increasing with the angle counter-clockwise from
/// +x, as `atan2` does, without a trigonometric call. `v` must not be zero.
fn pseudo_angle(v: [f64; 2]) -> f64 {
    let [x, y] = v;
    if y >= 0.0 {
        if x >= 0.0 {
            y / (x + y)
        } else {
            1.0 - x / (y - x)
        }
    } else if x < 0.0 {
        2.0 - y / (-x - y)
    } else {
        3.0 + x / (x - y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Submap, SubmapOptions};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Scans of a robot in a room with pillars, some beams without a return and some beyond
    /// the inserter's reach, from poses scattered over a few metres.
    fn scans_in_a_room(rng: &mut ChaCha8Rng, count: usize) -> Vec<(Scan, Pose2)> {
        (0..count)
            .map(|_| {
                let pose = Pose2::new(
                    rng.random_range(-3.0..3.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-3.2..3.2),
                );
                let beams = rng.random_range(0..200);
                let points = (0..beams)
                    .map(|beam| {
                        let angle = -1.6 + 3.2 * beam as f64 / beams.max(1) as f64;
                        let range = match rng.random_range(0..20) {
                            0 => return None,
                            1 => rng.random_range(100.0..140.0),
                            2 => rng.random_range(0.0..0.2),
                            _ => rng.random_range(0.3..9.0),
                        };
                        Some([range * angle.cos(), range * angle.sin()])
                    })
                    .collect();
                (Scan::from_points_in_robot(points), pose)
            })
            .collect()
    }

    #[test]
    fn every_cell_holds_what_the_drawn_grid_holds_to_the_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for round in 0..100 {
            let mut options = SubmapOptions::default();
            if round % 2 == 1 {
                options.range_inserter.hit_probability = 0.9;
                options.range_inserter.miss_probability = 0.3;
                options.resolution_m = 0.1;
            }
            let scans = scans_in_a_room(&mut rng, 1 + round % 5);
            let frame = Pose2::new(0.4, -0.7, 0.3);
            let mut drawn = Submap::with_pose_in_map(frame, options);
            drawn.reserve_for(scans.iter().map(|(s, p)| (s, *p)));
            for (scan, pose) in &scans {
                drawn.insert(scan, *pose).expect("not finished");
            }
            let lazy = LazyGrid::new(options, frame, scans.iter().map(|(s, p)| (s, *p)))
                .expect("a room's scans are reserved at once");
            let limits = drawn.grid().limits();
            assert_eq!(lazy.limits(), limits, "round {round}");
            let mut known = 0;
            for row in -2..limits.height_cells() as i32 + 2 {
                for column in -2..limits.width_cells() as i32 + 2 {
                    let expected = drawn.grid().probability([column, row]);
                    known += usize::from(expected.is_some());
                    assert_eq!(
                        lazy.probability([column, row]).map(f32::to_bits),
                        expected.map(f32::to_bits),
                        "round {round}, cell {:?}",
                        [column, row]
                    );
                }
            }
            assert!(known > 0 || scans.iter().all(|(s, _)| s.points_in_robot().is_empty()));
        }
    }

    #[test]
    fn what_the_grid_would_draw_differently_is_refused() {
        let scan = Scan::from_points_in_robot(vec![Some([1.0, 0.0]), None, Some([0.0, 1.0])]);
        let mut options = SubmapOptions::default();
        options.range_inserter.miss_range_m = Some(5.0);
        assert!(LazyGrid::new(options, Pose2::default(), [(&scan, Pose2::default())]).is_none());
        // Two scans 300 m apart need a grid wider than one reserved at once.
        let far = Pose2::new(300.0, 0.0, 0.0);
        let options = SubmapOptions::default();
        let scans = [(&scan, Pose2::default()), (&scan, far)];
        assert!(LazyGrid::new(options, Pose2::default(), scans).is_none());
    }

    #[test]
    fn the_pseudo_angle_orders_directions_as_atan2_does() {
        let directions: Vec<[f64; 2]> = (0..720)
            .map(|i| {
                let angle = -std::f64::consts::PI + i as f64 * std::f64::consts::PI / 360.0;
                [angle.cos() * 3.0, angle.sin() * 3.0]
            })
            .collect();
        let wrapped = |v: [f64; 2]| {
            let a = v[1].atan2(v[0]);
            if a < 0.0 {
                a + 2.0 * std::f64::consts::PI
            } else {
                a
            }
        };
        for pair in directions.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            if wrapped(a) < wrapped(b) {
                assert!(pseudo_angle(a) < pseudo_angle(b), "{a:?} {b:?}");
            }
        }
        assert_eq!(pseudo_angle([1.0, 0.0]), 0.0);
        assert_eq!(pseudo_angle([0.0, -1.0]), 3.0);
    }
}
