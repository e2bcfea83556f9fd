//! The fast scan matcher: the same answer as [`super::ReferenceMatcher`], found by a
//! multi-resolution branch and bound over bit-packed rasters (Olson 2009, "Real-Time Correlative
//! Scan Matching"; Hess et al. 2016, "Real-Time Loop Closure in 2D LIDAR SLAM").
//!
//! # Why it returns exactly the reference's answer
//!
//! The score of a candidate is the size of the union of both drawings, `|ref| + uncovered`, where
//! `uncovered` counts the pixels of the shifted new drawing that fall inside the raster and off
//! the reference drawing. `|ref|` is the same for every candidate, so minimising the union is
//! minimising `uncovered`, which is computed exactly:
//!
//! * The new scan is drawn once per rotation ([`RotatedScan`]); every translation of the table is
//!   a whole-pixel shift of that drawing (the table is quantised to pixels, see
//!   [`super::search`]), read from bit-packed rows with word shifts and popcounts.
//! * For a block of `2^k` × `2^k` translations of one rotation, each new-scan pixel that lands on
//!   an unblocked pixel of the level-`k` max-pooled grid ([`PrecomputationGrids`]) is uncovered for
//!   every translation of the block, so their count is a lower bound on `uncovered` over the
//!   block (pixels clipped by the raster count as blocked, which keeps the bound admissible).
//! * Blocks wait in one queue, lowest bound first, and the block at its head is split into
//!   its four children unless its `(bound, lowest table number)` is not below the best
//!   `(uncovered, table number)` scored so far; the search ends when the lowest bound left is
//!   above the best's. Every block left then holds only candidates that score higher or tie
//!   with a higher table number. The guess is scored before anything else, so that a good
//!   guess keeps most blocks out of the queue from the start. Taking the lowest bound first
//!   splits no block that a search in any other order could have ruled out (but for ties of
//!   the bound, which the queue takes in any order).
//! * Bounds are whole pixel counts no larger than the new drawing, so the queue is a bucket
//!   per count ([`BlockQueue`]): a push and a pop cost the same however many blocks wait,
//!   where a binary heap's grow with their number.
//!
//! # Trade-off against the reference
//!
//! The reference clears, draws and counts a full raster per candidate. This matcher draws each
//! rotation once, keeps a few max-pooled copies of the reference, and evaluates a candidate
//! with a handful of word operations per occupied row, visiting only the candidates whose block
//! bounds cannot be ruled out. It costs more code and some memory per match.

use super::bit_grid::BitGrid;
use super::pose_region::PoseRegion;
use super::precomputation_grid::PrecomputationGrids;
use super::rotated_scan::RotatedScan;
use super::scan::Scan;
use super::search::{
    Candidate, MatchResult, Polyline, RasterOptions, ScanMatchError, ScanMatcher, SearchTable,
    check_guess, validate,
};
use crate::geometry::Pose2;

/// Deepest supported branch-and-bound level (blocks of `2^16` translations a side).
pub const MAX_BRANCH_AND_BOUND_DEPTH: u32 = 16;

/// Branch-and-bound raster-overlap matcher, exact with respect to [`super::ReferenceMatcher`].
#[derive(Clone, Debug)]
pub struct FastMatcher {
    raster: RasterOptions,
    table: SearchTable,
    branch_and_bound_depth: u32,
}

impl FastMatcher {
    /// Builds a matcher drawing into `raster` and searching `table`, with a branch-and-bound
    /// depth chosen from the table size.
    ///
    /// # Errors
    ///
    /// [`ScanMatchError::InvalidOptions`] if an option is out of range.
    pub fn new(raster: RasterOptions, table: SearchTable) -> Result<Self, ScanMatchError> {
        validate(&raster, &table)?;
        let widest = table.num_x().max(table.num_y());
        // Top-level blocks as wide as the largest power of two within the table, one or two a
        // side: a whole rotation is ruled out with a few bounds, and as the best candidate so
        // far is scored first, most rotations are. (Half as wide costs more bounds on three
        // of the four benchmark logs.)
        let depth = widest.ilog2().min(MAX_BRANCH_AND_BOUND_DEPTH);
        Ok(FastMatcher {
            raster,
            table,
            branch_and_bound_depth: depth,
        })
    }

    /// Uses top-level blocks of `2^depth` × `2^depth` translations (capped at
    /// [`MAX_BRANCH_AND_BOUND_DEPTH`]); depth 0 scores every candidate. The result does not
    /// depend on it, only the speed.
    pub fn with_branch_and_bound_depth(mut self, depth: u32) -> Self {
        self.branch_and_bound_depth = depth.min(MAX_BRANCH_AND_BOUND_DEPTH);
        self
    }

    /// The branch-and-bound depth in use.
    pub fn branch_and_bound_depth(&self) -> u32 {
        self.branch_and_bound_depth
    }

    /// The raster options.
    pub fn raster(&self) -> &RasterOptions {
        &self.raster
    }

    /// The candidate table.
    pub fn table(&self) -> &SearchTable {
        &self.table
    }
}

/// A reference scan drawn and max-pooled for one [`FastMatcher`]: what its searches need of
/// the reference. Made once by [`FastMatcher::prepare`], it serves every search against the
/// same reference ([`FastMatcher::match_prepared`]), as a finished submap's does.
#[derive(Clone, Debug)]
pub struct PreparedReference {
    /// The raster, translation step and depth it was drawn for.
    made_for: (RasterOptions, u32, u32),
    grids: PrecomputationGrids,
    /// Pixels of the reference drawing.
    reference_px: u32,
}

impl PreparedReference {
    /// Pixels of the reference drawing ([`MatchResult::score_px`] is these plus what the new
    /// scan adds).
    pub fn reference_px(&self) -> u32 {
        self.reference_px
    }
}

impl FastMatcher {
    /// Draws `reference` into this matcher's raster and pools it for its search.
    pub fn prepare(&self, reference: &Scan) -> PreparedReference {
        let raster = &self.raster;
        // The reference drawing, clipped to the raster, and its max-pooled levels.
        let width = raster.width_px as usize;
        let height = raster.height_px as usize;
        let mut reference_grid = BitGrid::new(width, height, 0);
        let reference_polyline = Polyline::new(reference, raster.max_gap_m);
        let reference_vertices_px = reference_polyline.vertices_px(Pose2::IDENTITY, raster);
        reference_polyline.draw(&reference_vertices_px, [0, 0], |[column, row]| {
            // Negative coordinates wrap to huge values and fail the bounds check.
            let (column, row) = (column as usize, row as usize);
            if column < width && row < height {
                reference_grid.set(column, row);
            }
        });
        let step_px = self.table.translation_step_px;
        let depth = self.branch_and_bound_depth;
        PreparedReference {
            made_for: (*raster, step_px, depth),
            reference_px: reference_grid.count_ones(),
            grids: PrecomputationGrids::new(&reference_grid, step_px as usize, depth),
        }
    }

    /// [`ScanMatcher::match_scans`] against a reference this matcher prepared.
    ///
    /// # Errors
    ///
    /// [`ScanMatchError::InvalidOptions`] if another matcher (raster, translation step or
    /// depth) prepared `reference`, and as [`ScanMatcher::match_scans`].
    pub fn match_prepared(
        &self,
        reference: &PreparedReference,
        new: &Scan,
        initial_reference_from_new: Pose2,
    ) -> Result<MatchResult, ScanMatchError> {
        self.search_prepared(reference, new, initial_reference_from_new, None, None)?
            .ok_or(ScanMatchError::InvalidOptions("empty search table"))
    }

    /// [`Self::match_prepared`] over the candidates in `region` only: the best match among the
    /// poses it holds, found without splitting a block of candidates the region rules out.
    /// `None` when it holds no candidate.
    ///
    /// # Errors
    ///
    /// As [`Self::match_prepared`].
    pub fn match_prepared_within(
        &self,
        reference: &PreparedReference,
        new: &Scan,
        initial_reference_from_new: Pose2,
        region: &dyn PoseRegion,
    ) -> Result<Option<MatchResult>, ScanMatchError> {
        self.search_prepared(
            reference,
            new,
            initial_reference_from_new,
            None,
            Some(region),
        )
    }

    /// [`Self::match_prepared`] over the candidates outside `excluded` only: the best match
    /// of another hypothesis than the one `excluded` surrounds. `None` when every candidate
    /// lies within it.
    ///
    /// # Errors
    ///
    /// As [`Self::match_prepared`].
    pub fn match_prepared_outside(
        &self,
        reference: &PreparedReference,
        new: &Scan,
        initial_reference_from_new: Pose2,
        excluded: Excluded,
    ) -> Result<Option<MatchResult>, ScanMatchError> {
        self.search_prepared(
            reference,
            new,
            initial_reference_from_new,
            Some(excluded),
            None,
        )
    }

    /// How many pixels the drawing of `new` at `candidate` (around `initial_reference_from_new`)
    /// sets inside the raster: what [`MatchResult::score_px`] less the reference's pixels is
    /// out of, so that `drawn - uncovered` is the overlap of the two drawings.
    pub fn drawn_px(
        &self,
        new: &Scan,
        initial_reference_from_new: Pose2,
        candidate: Candidate,
    ) -> u32 {
        let raster = &self.raster;
        let table = &self.table;
        let rotation_only = Pose2 {
            theta_rad: table.angle_rad(initial_reference_from_new, candidate.rotation_index),
            ..initial_reference_from_new
        };
        let polyline = Polyline::new(new, raster.max_gap_m);
        let vertices_px = polyline.vertices_px(rotation_only, raster);
        let margin_px = table.max_offset_px().map(|m| m as usize);
        let drawing = RotatedScan::new(&polyline, &vertices_px, raster, margin_px);
        let mut empty = BitGrid::new(raster.width_px as usize, raster.height_px as usize, 0);
        empty.fill_padding();
        drawing.uncovered_px(
            &empty,
            table.offset_px(candidate.x_index, candidate.y_index),
        )
    }

    /// The search of [`Self::match_prepared`], over the candidates outside `excluded`.
    fn search_prepared(
        &self,
        reference: &PreparedReference,
        new: &Scan,
        initial_reference_from_new: Pose2,
        excluded: Option<Excluded>,
        region: Option<&dyn PoseRegion>,
    ) -> Result<Option<MatchResult>, ScanMatchError> {
        check_guess(initial_reference_from_new)?;
        let raster = &self.raster;
        let table = &self.table;
        let depth = self.branch_and_bound_depth;
        if reference.made_for != (*raster, table.translation_step_px, depth) {
            return Err(ScanMatchError::InvalidOptions(
                "reference prepared by another matcher",
            ));
        }
        let grids = &reference.grids;
        let reference_px = reference.reference_px;

        // The new scan, drawn once per rotation.
        let new_polyline = Polyline::new(new, raster.max_gap_m);
        let margin_px = table.max_offset_px().map(|m| m as usize);
        let region = region.map(|region| BlockRegion {
            region,
            guess: initial_reference_from_new,
            resolution_m: raster.resolution_m,
        });
        // Not the rotations of which the region holds no pose.
        let last = [table.num_x() as u32 - 1, table.num_y() as u32 - 1];
        let rotated_scans: Vec<Option<RotatedScan>> = (0..table.num_rotations() as u32)
            .map(|rotation_index| {
                if region.is_some_and(|r| !r.may_hold(table, rotation_index, [0, 0], last)) {
                    return None;
                }
                let rotation_only = Pose2 {
                    theta_rad: table.angle_rad(initial_reference_from_new, rotation_index),
                    ..initial_reference_from_new
                };
                let vertices_px = new_polyline.vertices_px(rotation_only, raster);
                Some(RotatedScan::new(
                    &new_polyline,
                    &vertices_px,
                    raster,
                    margin_px,
                ))
            })
            .collect();

        let mut search = Search {
            table,
            grids,
            rotated_scans: &rotated_scans,
            best: (u32::MAX, usize::MAX),
            candidates_evaluated: 0,
            guess_index: None,
            excluded,
            region,
            queue: BlockQueue::default(),
        };
        // The guess itself first: a real candidate, so that its score bounds the search from
        // the start without changing the answer.
        let guess = Candidate {
            rotation_index: table.rotation_half_steps,
            y_index: table.y_half_steps,
            x_index: table.x_half_steps,
        };
        if !excluded.is_some_and(|e| e.contains(guess)) {
            search.push(Block {
                level: 0,
                rotation_index: guess.rotation_index,
                y_index: guess.y_index,
                x_index: guess.x_index,
            });
            search.guess_index = Some(table.index_of(guess));
        }
        let block_side = 1usize << depth;
        for rotation_index in 0..table.num_rotations() as u32 {
            for y_index in (0..table.num_y()).step_by(block_side) {
                for x_index in (0..table.num_x()).step_by(block_side) {
                    search.push(Block {
                        level: depth,
                        rotation_index,
                        y_index: y_index as u32,
                        x_index: x_index as u32,
                    });
                }
            }
        }
        search.explore();

        let (uncovered_px, table_index) = search.best;
        if table_index == usize::MAX {
            return Ok(None);
        }
        MatchResult::for_table_entry(
            table,
            raster,
            initial_reference_from_new,
            table_index,
            reference_px + uncovered_px,
            search.candidates_evaluated,
        )
        .map(Some)
    }
}

impl ScanMatcher for FastMatcher {
    /// Finds the reference matcher's answer (lowest score, then lowest table number) around
    /// `initial_reference_from_new`.
    fn match_scans(
        &self,
        reference: &Scan,
        new: &Scan,
        initial_reference_from_new: Pose2,
    ) -> Result<MatchResult, ScanMatchError> {
        check_guess(initial_reference_from_new)?;
        self.match_prepared(&self.prepare(reference), new, initial_reference_from_new)
    }
}

/// The candidates within `half_steps` table steps (x, y, rotation) of `around`, left out of
/// a search ([`FastMatcher::match_prepared_outside`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Excluded {
    /// The candidate at the centre.
    pub around: Candidate,
    /// How far either way, in table steps along x, y and rotation.
    pub half_steps: [u32; 3],
}

impl Excluded {
    /// Whether `candidate` is left out.
    pub fn contains(&self, candidate: Candidate) -> bool {
        let within = |a: u32, b: u32, half: u32| a.abs_diff(b) <= half;
        within(candidate.x_index, self.around.x_index, self.half_steps[0])
            && within(candidate.y_index, self.around.y_index, self.half_steps[1])
            && within(
                candidate.rotation_index,
                self.around.rotation_index,
                self.half_steps[2],
            )
    }
}

/// A square of `2^level` × `2^level` table translations of one rotation, named by its corner
/// with the lowest indices.
#[derive(Clone, Copy, Debug)]
struct Block {
    level: u32,
    rotation_index: u32,
    y_index: u32,
    x_index: u32,
}

/// A block with its lower bound on `uncovered` and its lowest table number.
#[derive(Clone, Copy, Debug)]
struct BoundedBlock {
    block: Block,
    /// `(lower bound on uncovered pixels, lowest table number in the block)`.
    key: (u32, usize),
}

/// Blocks waiting to be split, taken lowest bound first (ties in any order): one stack per
/// bound, and the lowest bound that may hold a block.
#[derive(Debug, Default)]
struct BlockQueue {
    /// `buckets[b]` holds the blocks of bound `b`.
    buckets: Vec<Vec<BoundedBlock>>,
    /// No bucket below this holds a block.
    lowest: usize,
}

impl BlockQueue {
    fn push(&mut self, bounded: BoundedBlock) {
        let bound = bounded.key.0 as usize;
        if bound >= self.buckets.len() {
            self.buckets.resize_with(bound + 1, Vec::new);
        }
        self.buckets[bound].push(bounded);
        self.lowest = self.lowest.min(bound);
    }

    /// A block of the lowest bound waiting, if any.
    fn pop(&mut self) -> Option<BoundedBlock> {
        while let Some(bucket) = self.buckets.get_mut(self.lowest) {
            if let Some(bounded) = bucket.pop() {
                return Some(bounded);
            }
            self.lowest += 1;
        }
        None
    }
}

/// A [`PoseRegion`] and what places a search's candidates in its frame.
#[derive(Clone, Copy)]
struct BlockRegion<'a> {
    region: &'a dyn PoseRegion,
    /// The search's guess, at the table's centre.
    guess: Pose2,
    /// The raster's pixel size, metres.
    resolution_m: f64,
}

impl BlockRegion<'_> {
    /// Whether the region may hold a pose of rotation `rotation_index` with its translation
    /// indices (x, y) from `first` to `last`.
    fn may_hold(
        &self,
        table: &SearchTable,
        rotation_index: u32,
        first: [u32; 2],
        last: [u32; 2],
    ) -> bool {
        // As `SearchTable::reference_from_new` places a candidate.
        let at = |[x_index, y_index]: [u32; 2]| {
            let offset_px = table.offset_px(x_index, y_index);
            [
                self.guess.x_m + f64::from(offset_px[0]) * self.resolution_m,
                self.guess.y_m + f64::from(offset_px[1]) * self.resolution_m,
            ]
        };
        let heading_rad = table.angle_rad(self.guess, rotation_index);
        self.region.may_hold(heading_rad, at(first), at(last))
    }
}

/// State of one branch-and-bound search.
struct Search<'a> {
    table: &'a SearchTable,
    grids: &'a PrecomputationGrids,
    /// The new scan drawn at each rotation; `None` where the region holds none of its poses.
    rotated_scans: &'a [Option<RotatedScan>],
    /// `(uncovered pixels, table number)` of the best candidate so far.
    best: (u32, usize),
    candidates_evaluated: usize,
    /// The table number of the guess, once scored (it is scored first).
    guess_index: Option<usize>,
    /// Candidates never scored (their blocks' bounds still hold for the rest).
    excluded: Option<Excluded>,
    /// The poses the search may take.
    region: Option<BlockRegion<'a>>,
    /// Blocks waiting, lowest bound first.
    queue: BlockQueue,
}

impl Search<'_> {
    /// Bounds `block` from below (at level 0 the bound is the candidate's exact `uncovered`)
    /// and queues it unless it cannot beat the best candidate scored so far.
    fn push(&mut self, block: Block) {
        let lowest_index = self.table.index_of(Candidate {
            rotation_index: block.rotation_index,
            y_index: block.y_index,
            x_index: block.x_index,
        });
        if block.level == 0 && self.guess_index == Some(lowest_index) {
            // Scored first of all.
            return;
        }
        if block.level == 0
            && self.excluded.is_some_and(|e| {
                e.contains(Candidate {
                    rotation_index: block.rotation_index,
                    y_index: block.y_index,
                    x_index: block.x_index,
                })
            })
        {
            return;
        }
        let Some(rotated_scan) = &self.rotated_scans[block.rotation_index as usize] else {
            return;
        };
        if let Some(region) = self.region {
            let side = 1u32 << block.level;
            let last = |index: u32, count: usize| (index + side - 1).min(count as u32 - 1);
            let last = [
                last(block.x_index, self.table.num_x()),
                last(block.y_index, self.table.num_y()),
            ];
            let first = [block.x_index, block.y_index];
            if !region.may_hold(self.table, block.rotation_index, first, last) {
                return;
            }
        }
        let offset_px = self.table.offset_px(block.x_index, block.y_index);
        let uncovered = rotated_scan.uncovered_px(self.grids.level(block.level), offset_px);
        let key = (uncovered, lowest_index);
        if block.level == 0 {
            self.candidates_evaluated += 1;
            self.best = self.best.min(key);
        }
        if key <= self.best {
            self.queue.push(BoundedBlock { block, key });
        }
    }

    /// Takes blocks lowest bound first and splits those whose key is below the best
    /// candidate's scored so far, until the lowest bound left is above the best's.
    fn explore(&mut self) {
        while let Some(BoundedBlock { block, key }) = self.queue.pop() {
            if key.0 > self.best.0 {
                return;
            }
            if key >= self.best {
                continue;
            }
            // Candidates enter `best` when scored, so this block has children.
            let half = 1u32 << (block.level - 1);
            for y_index in [block.y_index, block.y_index + half] {
                for x_index in [block.x_index, block.x_index + half] {
                    if y_index as usize >= self.table.num_y()
                        || x_index as usize >= self.table.num_x()
                    {
                        continue;
                    }
                    self.push(Block {
                        level: block.level - 1,
                        rotation_index: block.rotation_index,
                        y_index,
                        x_index,
                    });
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan_match::reference_matcher::ReferenceMatcher;
    use crate::scan_match::synthetic::{cast_scan, polygon_walls};
    use proptest::prelude::*;
    use std::f64::consts::{PI, TAU};

    /// A star-shaped room around the map origin: corners at sorted angles and random radii.
    fn room() -> impl Strategy<Value = Vec<[f64; 2]>> {
        prop::collection::vec((0.0..TAU, 0.4..7.0f64), 3..9).prop_map(|mut corners| {
            corners.sort_by(|a, b| a.0.total_cmp(&b.0));
            corners
                .into_iter()
                .map(|(angle, radius)| [radius * angle.cos(), radius * angle.sin()])
                .collect()
        })
    }

    fn pose(linear_m: f64, angular_rad: f64) -> impl Strategy<Value = Pose2> {
        (
            -linear_m..=linear_m,
            -linear_m..=linear_m,
            -angular_rad..=angular_rad,
        )
            .prop_map(|(x_m, y_m, theta_rad)| Pose2::new(x_m, y_m, theta_rad))
    }

    /// Two scans of one room from nearby poses, beams sometimes dropped.
    fn room_pair() -> impl Strategy<Value = (Scan, Scan)> {
        (
            room(),
            pose(0.3, PI),
            pose(0.4, 0.2),
            3usize..120,
            0.2..TAU,
            1.0..9.0f64,
            prop::collection::vec(any::<bool>(), 120),
        )
            .prop_map(|(corners, first, motion, beams, fov, max_range_m, drop)| {
                let walls = polygon_walls(&corners);
                let step = fov / beams as f64;
                let cast = |pose| {
                    let scan = cast_scan(&walls, pose, -fov / 2.0, step, beams, max_range_m);
                    let points = scan.points_in_robot().iter().zip(&drop);
                    Scan::from_points_in_robot(
                        points.map(|(p, &d)| if d { None } else { *p }).collect(),
                    )
                };
                (cast(first), cast(first * motion))
            })
    }

    /// Arbitrary points, some far outside any raster, some missing.
    fn wild_scan() -> impl Strategy<Value = Scan> {
        prop::collection::vec(
            prop::option::weighted(0.8, (-40.0..40.0f64, -40.0..40.0f64)),
            0..40,
        )
        .prop_map(|points| {
            Scan::from_points_in_robot(points.into_iter().map(|p| p.map(|(x, y)| [x, y])).collect())
        })
    }

    fn degenerate_scan() -> impl Strategy<Value = Scan> {
        prop_oneof![
            Just(Scan::default()),
            Just(Scan::from_points_in_robot(vec![None; 5])),
            ((-3.0..3.0f64, -3.0..3.0f64), 1usize..20)
                .prop_map(|((x, y), n)| Scan::from_points_in_robot(vec![Some([x, y]); n])),
            wild_scan(),
        ]
    }

    fn scan_pair() -> impl Strategy<Value = (Scan, Scan)> {
        prop_oneof![
            3 => room_pair(),
            1 => (room_pair(), degenerate_scan()).prop_map(|((reference, _), new)| (reference, new)),
            1 => (room_pair(), degenerate_scan()).prop_map(|((_, new), reference)| (reference, new)),
            1 => (degenerate_scan(), degenerate_scan()),
        ]
    }

    fn raster() -> impl Strategy<Value = RasterOptions> {
        (
            0.03..0.4f64,
            1u32..72,
            1u32..72,
            prop_oneof![Just(f64::INFINITY), 0.0..1.5f64],
        )
            .prop_map(
                |(resolution_m, width_px, height_px, max_gap_m)| RasterOptions {
                    resolution_m,
                    width_px,
                    height_px,
                    max_gap_m,
                },
            )
    }

    fn table() -> impl Strategy<Value = SearchTable> {
        (0u32..6, 0u32..6, 1u32..4, 0u32..3, 0.0..0.2f64).prop_map(
            |(x_half_steps, y_half_steps, translation_step_px, rotation_half_steps, step_rad)| {
                SearchTable {
                    x_half_steps,
                    y_half_steps,
                    translation_step_px,
                    rotation_half_steps,
                    rotation_step_rad: step_rad,
                }
            },
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn prop_fast_equals_reference(
            (reference, new) in scan_pair(),
            raster in raster(),
            table in table(),
            guess in pose(0.5, 0.3),
            depth in prop::option::of(0u32..5),
        ) {
            let reference_matcher = ReferenceMatcher::new(raster, table).unwrap();
            let mut fast_matcher = FastMatcher::new(raster, table).unwrap();
            if let Some(depth) = depth {
                fast_matcher = fast_matcher.with_branch_and_bound_depth(depth);
            }
            let expected = reference_matcher.match_scans(&reference, &new, guess).unwrap();
            let actual = fast_matcher.match_scans(&reference, &new, guess).unwrap();
            prop_assert_eq!(actual.table_index, expected.table_index);
            prop_assert_eq!(actual.score_px, expected.score_px);
            prop_assert_eq!(actual.candidate, expected.candidate);
            prop_assert_eq!(actual.reference_from_new, expected.reference_from_new);
            prop_assert!(actual.candidates_evaluated <= expected.candidates_evaluated);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// Outside an excluded box the branch and bound finds what scoring every candidate
        /// of the rest finds; and a box without the best candidate changes nothing.
        #[test]
        fn prop_outside_an_excluded_box_the_search_finds_the_best_of_the_rest(
            (reference, new) in scan_pair(),
            raster in raster(),
            table in table(),
            guess in pose(0.5, 0.3),
            centre in (0.0..1.0f64, 0.0..1.0f64, 0.0..1.0f64),
            half_steps in (0u32..3, 0u32..3, 0u32..2),
        ) {
            let fast = FastMatcher::new(raster, table).unwrap();
            let every = fast.clone().with_branch_and_bound_depth(0);
            let pick = |unit: f64, count: usize| ((unit * count as f64) as u32).min(count as u32 - 1);
            let excluded = Excluded {
                around: Candidate {
                    x_index: pick(centre.0, table.num_x()),
                    y_index: pick(centre.1, table.num_y()),
                    rotation_index: pick(centre.2, table.num_rotations()),
                },
                half_steps: [half_steps.0, half_steps.1, half_steps.2],
            };
            let outside = |matcher: &FastMatcher| {
                matcher
                    .match_prepared_outside(&matcher.prepare(&reference), &new, guess, excluded)
                    .unwrap()
            };
            let (found, expected) = (outside(&fast), outside(&every));
            prop_assert_eq!(found.map(|r| (r.table_index, r.score_px)), expected.map(|r| (r.table_index, r.score_px)));
            if let Some(found) = found {
                prop_assert!(!excluded.contains(found.candidate));
            } else {
                prop_assert!((0..table.len()).all(|i| excluded.contains(table.candidate(i).unwrap())));
            }
            let best = fast.match_scans(&reference, &new, guess).unwrap();
            if !excluded.contains(best.candidate) {
                prop_assert_eq!(found.map(|r| r.table_index), Some(best.table_index));
            }
        }
    }

    /// The poses within `radius_m` of `centre_m` headed within `half_turn_rad` of
    /// `heading_rad`: a region whose blocks it rules out only in part.
    struct Disc {
        centre_m: [f64; 2],
        radius_m: f64,
        heading_rad: f64,
        half_turn_rad: f64,
    }

    impl PoseRegion for Disc {
        fn may_hold(&self, heading_rad: f64, min_m: [f64; 2], max_m: [f64; 2]) -> bool {
            let near = |axis: usize| {
                (min_m[axis] - self.centre_m[axis])
                    .max(self.centre_m[axis] - max_m[axis])
                    .max(0.0)
            };
            let turn = crate::geometry::wrap_angle_rad(heading_rad - self.heading_rad);
            near(0).hypot(near(1)) <= self.radius_m && turn.abs() <= self.half_turn_rad
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// Within a region the branch and bound finds what scoring every candidate of the
        /// region finds; and a region holding the best candidate changes nothing.
        #[test]
        fn prop_within_a_region_the_search_finds_the_best_of_it(
            (reference, new) in scan_pair(),
            raster in raster(),
            table in table(),
            guess in pose(0.5, 0.3),
            centre in (-0.5..0.5f64, -0.5..0.5f64),
            radius_m in 0.0..0.4f64,
            turn in (-0.1..0.1f64, 0.0..0.1f64),
        ) {
            let fast = FastMatcher::new(raster, table).unwrap();
            let every = fast.clone().with_branch_and_bound_depth(0);
            let region = Disc {
                centre_m: [guess.x_m + centre.0, guess.y_m + centre.1],
                radius_m,
                heading_rad: guess.theta_rad + turn.0,
                half_turn_rad: turn.1,
            };
            let within = |matcher: &FastMatcher| {
                matcher
                    .match_prepared_within(&matcher.prepare(&reference), &new, guess, &region)
                    .unwrap()
            };
            let (found, expected) = (within(&fast), within(&every));
            prop_assert_eq!(found.map(|r| (r.table_index, r.score_px)), expected.map(|r| (r.table_index, r.score_px)));
            let held = |candidate: Candidate| {
                let pose = table.reference_from_new(guess, &raster, candidate);
                region.may_hold(pose.theta_rad, [pose.x_m, pose.y_m], [pose.x_m, pose.y_m])
            };
            if let Some(found) = found {
                prop_assert!(held(found.candidate));
            } else {
                prop_assert!((0..table.len()).all(|i| !held(table.candidate(i).unwrap())));
            }
            let best = fast.match_scans(&reference, &new, guess).unwrap();
            if held(best.candidate) {
                prop_assert_eq!(found.map(|r| r.table_index), Some(best.table_index));
            }
        }
    }

    #[test]
    fn the_drawn_pixels_less_the_uncovered_ones_are_the_overlap() {
        let walls = polygon_walls(&[[-3.0, -2.0], [4.0, -2.5], [3.0, 3.0], [-2.0, 2.0]]);
        let scan = cast_scan(&walls, Pose2::IDENTITY, -PI, 0.05, 125, 8.0);
        let table = SearchTable {
            x_half_steps: 3,
            y_half_steps: 3,
            translation_step_px: 1,
            rotation_half_steps: 2,
            rotation_step_rad: 0.02,
        };
        let matcher = FastMatcher::new(RasterOptions::default(), table).unwrap();
        let reference = matcher.prepare(&scan);
        let found = matcher
            .match_prepared(&reference, &scan, Pose2::IDENTITY)
            .unwrap();
        // The scan on itself: nothing uncovered, and the overlap is its whole drawing.
        assert_eq!(found.score_px, reference.reference_px());
        assert_eq!(
            matcher.drawn_px(&scan, Pose2::IDENTITY, found.candidate),
            reference.reference_px()
        );
    }

    #[test]
    fn test_depth_zero_scores_every_candidate() {
        let table = SearchTable {
            x_half_steps: 2,
            y_half_steps: 1,
            translation_step_px: 1,
            rotation_half_steps: 1,
            rotation_step_rad: 0.1,
        };
        let matcher = FastMatcher::new(RasterOptions::default(), table)
            .unwrap()
            .with_branch_and_bound_depth(0);
        let scan = Scan::from_points_in_robot(vec![Some([1.0, 0.0]), Some([1.0, 0.3])]);
        let result = matcher.match_scans(&scan, &scan, Pose2::IDENTITY).unwrap();
        // Every candidate ties below the first one found, so all 45 get scored.
        assert!(result.candidates_evaluated <= table.len());
        assert_eq!(result.candidate.rotation_index, 1);
    }

    #[test]
    fn test_a_prepared_reference_serves_its_own_matcher_only() {
        let walls = polygon_walls(&[[-3.0, -2.0], [4.0, -2.5], [3.0, 3.0], [-2.0, 2.0]]);
        let cast = |pose| cast_scan(&walls, pose, -PI, 0.05, 125, 8.0);
        let (reference, new) = (cast(Pose2::IDENTITY), cast(Pose2::new(0.3, -0.2, 0.1)));
        let table = SearchTable {
            x_half_steps: 5,
            y_half_steps: 5,
            translation_step_px: 1,
            rotation_half_steps: 4,
            rotation_step_rad: 0.03,
        };
        let matcher = FastMatcher::new(RasterOptions::default(), table).unwrap();
        let prepared = matcher.prepare(&reference);
        for guess in [Pose2::IDENTITY, Pose2::new(0.2, -0.1, 0.05)] {
            assert_eq!(
                matcher.match_prepared(&prepared, &new, guess).unwrap(),
                matcher.match_scans(&reference, &new, guess).unwrap()
            );
        }
        let other = matcher.clone().with_branch_and_bound_depth(1);
        assert!(matches!(
            other.match_prepared(&prepared, &new, Pose2::IDENTITY),
            Err(ScanMatchError::InvalidOptions(_))
        ));
    }

    #[test]
    fn test_invalid_options_are_rejected() {
        let raster = RasterOptions {
            width_px: 0,
            ..RasterOptions::default()
        };
        assert!(matches!(
            FastMatcher::new(raster, SearchTable::default()),
            Err(ScanMatchError::InvalidOptions(_))
        ));
    }
}
