//! What both matchers share: the raster, the table of candidate transforms, how a scan is drawn,
//! and the result.
//!
//! # Score
//!
//! For a candidate transform `reference_from_new`, a raster of `width_px` × `height_px` pixels is
//! cleared, the reference scan and the transformed new scan are drawn into it as polylines, and
//! the score is the number of set pixels (the size of the union of both drawings). Well aligned
//! scans draw their walls over each other and cover fewer pixels, so the lowest score wins.
//!
//! # Raster
//!
//! The reference robot origin sits at the corner between the four centre pixels: a point
//! (`x_m`, `y_m`) in the reference frame falls in column `floor(x_m / resolution_m) + width_px / 2`
//! and row `floor(y_m / resolution_m) + height_px / 2`. Lines are drawn between these integer
//! vertex pixels with Bresenham's algorithm over their full length, then clipped pixel by pixel:
//! pixels outside the raster are dropped and not counted, and a line leaving the raster keeps
//! exactly the pixels it has inside. A vertex more than [`MAX_VERTEX_OFFSET_PX`] pixels from the
//! origin is treated like a beam without a return.
//!
//! # Drawing a scan
//!
//! Every valid beam end point sets its vertex pixel. Two consecutive beams are joined by a line
//! when both have a return and their end points are at most `max_gap_m` apart (measured in the
//! robot frame, before any transform); otherwise the polyline breaks there. An isolated point is a
//! single pixel.
//!
//! # Candidate table and its quantisation
//!
//! The table is centred on an initial guess `reference_from_new` = (`x_m`, `y_m`, `theta_rad`).
//! Candidate (`rotation_index`, `y_index`, `x_index`) has angle
//! `theta_rad + (rotation_index - rotation_half_steps) * rotation_step_rad` and a translation
//! offset of a whole number of pixels, `(x_index - x_half_steps) * translation_step_px` columns and
//! likewise rows. The translation is quantised to pixels: a new-scan point `p` is drawn at
//! vertex pixel `floor((R(angle) * p + guess translation) / resolution_m) + centre + offset_px`,
//! so a candidate differs from its neighbours by an exact pixel shift. The candidate's transform
//! reports the offset in metres, `offset_px * resolution_m`, added to the guess translation.
//!
//! # Tie-break
//!
//! Candidates are numbered `(rotation_index * num_y + y_index) * num_x + x_index`; among equal
//! scores the lowest number wins.

use std::fmt;

use super::bresenham::BresenhamLine;
use super::scan::Scan;
use crate::geometry::Pose2;

/// Vertices farther than this many pixels from the raster origin (along either axis) are treated
/// as beams without a return, which bounds the cost of drawing one line.
pub const MAX_VERTEX_OFFSET_PX: i64 = 1 << 16;

/// Largest supported raster side, in pixels.
pub const MAX_RASTER_SIDE_PX: u32 = 1 << 14;

/// Largest supported translation offset of the table, `half_steps * translation_step_px`.
pub const MAX_TRANSLATION_OFFSET_PX: u32 = 1 << 12;

/// How scans are drawn into the raster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RasterOptions {
    /// Size of one pixel, in metres per pixel.
    pub resolution_m: f64,
    /// Raster width (x, columns), in pixels.
    pub width_px: u32,
    /// Raster height (y, rows), in pixels.
    pub height_px: u32,
    /// Consecutive beam end points farther apart than this (metres) are not joined by a line.
    pub max_gap_m: f64,
}

impl Default for RasterOptions {
    /// A 256 × 256 raster of 5 cm pixels (12.8 m square), joining beams up to 0.5 m apart.
    fn default() -> Self {
        RasterOptions {
            resolution_m: 0.05,
            width_px: 256,
            height_px: 256,
            max_gap_m: 0.5,
        }
    }
}

/// The table of candidate transforms, centred on the initial guess.
///
/// There are `2 * x_half_steps + 1` translations along x, `2 * y_half_steps + 1` along y and
/// `2 * rotation_half_steps + 1` rotations; see the module docs for how they are numbered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchTable {
    /// Number of translation steps on each side of the guess along x.
    pub x_half_steps: u32,
    /// Number of translation steps on each side of the guess along y.
    pub y_half_steps: u32,
    /// Translation step, in whole pixels (the metric step is this times `resolution_m`).
    pub translation_step_px: u32,
    /// Number of rotation steps on each side of the guess.
    pub rotation_half_steps: u32,
    /// Rotation step, in radians.
    pub rotation_step_rad: f64,
}

impl Default for SearchTable {
    /// 21 × 21 translations one pixel apart and 31 rotations half a degree apart.
    fn default() -> Self {
        SearchTable {
            x_half_steps: 10,
            y_half_steps: 10,
            translation_step_px: 1,
            rotation_half_steps: 15,
            rotation_step_rad: 0.5_f64.to_radians(),
        }
    }
}

impl SearchTable {
    /// Builds a table whose metric translation step `translation_step_m` is rounded to a whole
    /// number of `raster.resolution_m` pixels (at least one).
    pub fn quantised(
        x_half_steps: u32,
        y_half_steps: u32,
        translation_step_m: f64,
        rotation_half_steps: u32,
        rotation_step_rad: f64,
        raster: &RasterOptions,
    ) -> Self {
        let step_px = (translation_step_m / raster.resolution_m).round();
        // `as` saturates, and NaN becomes 0; both are then lifted to one pixel.
        let translation_step_px = (step_px as u32).max(1);
        SearchTable {
            x_half_steps,
            y_half_steps,
            translation_step_px,
            rotation_half_steps,
            rotation_step_rad,
        }
    }

    /// Number of translations along x.
    pub fn num_x(&self) -> usize {
        2 * self.x_half_steps as usize + 1
    }

    /// Number of translations along y.
    pub fn num_y(&self) -> usize {
        2 * self.y_half_steps as usize + 1
    }

    /// Number of rotations.
    pub fn num_rotations(&self) -> usize {
        2 * self.rotation_half_steps as usize + 1
    }

    /// Number of candidates in the table.
    pub fn len(&self) -> usize {
        self.num_rotations() * self.num_y() * self.num_x()
    }

    /// Always false: a table holds at least the initial guess.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The candidate with table number `index`, or `None` past the end of the table.
    pub fn candidate(&self, index: usize) -> Option<Candidate> {
        if index >= self.len() {
            return None;
        }
        let (rest, x_index) = (index / self.num_x(), index % self.num_x());
        let (rotation_index, y_index) = (rest / self.num_y(), rest % self.num_y());
        // Each index is below its axis count, which fits `u32` by construction.
        Some(Candidate {
            rotation_index: rotation_index as u32,
            y_index: y_index as u32,
            x_index: x_index as u32,
        })
    }

    /// The table number of `candidate` (the tie-break order).
    pub fn index_of(&self, candidate: Candidate) -> usize {
        (candidate.rotation_index as usize * self.num_y() + candidate.y_index as usize)
            * self.num_x()
            + candidate.x_index as usize
    }

    /// Angle of rotation `rotation_index` for the guess `initial_reference_from_new`, radians.
    ///
    /// Both matchers derive their rotations from this one function so they agree bit for bit.
    pub(crate) fn angle_rad(&self, initial_reference_from_new: Pose2, rotation_index: u32) -> f64 {
        let steps = i64::from(rotation_index) - i64::from(self.rotation_half_steps);
        initial_reference_from_new.theta_rad + steps as f64 * self.rotation_step_rad
    }

    /// The pixel offset (columns, rows) of the translation indices `x_index`, `y_index`.
    pub(crate) fn offset_px(&self, x_index: u32, y_index: u32) -> [i32; 2] {
        let step = self.translation_step_px as i32;
        [
            (x_index as i32 - self.x_half_steps as i32) * step,
            (y_index as i32 - self.y_half_steps as i32) * step,
        ]
    }

    /// The largest pixel offset along x and y.
    pub(crate) fn max_offset_px(&self) -> [i32; 2] {
        let step = self.translation_step_px as i32;
        [
            self.x_half_steps as i32 * step,
            self.y_half_steps as i32 * step,
        ]
    }

    /// The transform of `candidate` around the guess `initial_reference_from_new`.
    pub fn reference_from_new(
        &self,
        initial_reference_from_new: Pose2,
        raster: &RasterOptions,
        candidate: Candidate,
    ) -> Pose2 {
        let [offset_x_px, offset_y_px] = self.offset_px(candidate.x_index, candidate.y_index);
        Pose2::new(
            initial_reference_from_new.x_m + f64::from(offset_x_px) * raster.resolution_m,
            initial_reference_from_new.y_m + f64::from(offset_y_px) * raster.resolution_m,
            self.angle_rad(initial_reference_from_new, candidate.rotation_index),
        )
    }
}

/// One entry of a [`SearchTable`], by its indices along each axis (all starting at 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Candidate {
    /// Rotation index, `0..num_rotations()`.
    pub rotation_index: u32,
    /// Translation index along y, `0..num_y()`.
    pub y_index: u32,
    /// Translation index along x, `0..num_x()`.
    pub x_index: u32,
}

/// The best candidate of a match.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchResult {
    /// The best transform `M`, mapping points of the new scan into the reference scan's frame,
    /// so that `pose_new = pose_reference * M`.
    pub reference_from_new: Pose2,
    /// The best candidate's place in the table.
    pub candidate: Candidate,
    /// The best candidate's table number (see the module docs for the order).
    pub table_index: usize,
    /// Number of set pixels in the union of both drawings (lower is better).
    pub score_px: u32,
    /// Number of candidates whose exact score was computed.
    pub candidates_evaluated: usize,
}

impl MatchResult {
    /// The result for entry `table_index` of `table` around `initial_reference_from_new`.
    ///
    /// # Errors
    /// [`ScanMatchError::InvalidOptions`] when the table has no such entry.
    pub fn for_table_entry(
        table: &SearchTable,
        raster: &RasterOptions,
        initial_reference_from_new: Pose2,
        table_index: usize,
        score_px: u32,
        candidates_evaluated: usize,
    ) -> Result<MatchResult, ScanMatchError> {
        let candidate = table
            .candidate(table_index)
            .ok_or(ScanMatchError::InvalidOptions("empty search table"))?;
        Ok(MatchResult {
            reference_from_new: table.reference_from_new(
                initial_reference_from_new,
                raster,
                candidate,
            ),
            candidate,
            table_index,
            score_px,
            candidates_evaluated,
        })
    }
}

/// Why a match could not run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScanMatchError {
    /// An option is out of range; the text names it.
    InvalidOptions(&'static str),
    /// The initial guess has a non-finite component.
    NonFiniteGuess,
}

impl fmt::Display for ScanMatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScanMatchError::InvalidOptions(what) => write!(f, "invalid scan-match options: {what}"),
            ScanMatchError::NonFiniteGuess => write!(f, "the initial guess is not finite"),
        }
    }
}

impl std::error::Error for ScanMatchError {}

/// Aligns a new scan with a reference scan over a [`SearchTable`].
pub trait ScanMatcher {
    /// Finds the candidate around `initial_reference_from_new` that draws `new` over
    /// `reference` with the fewest set pixels.
    ///
    /// # Errors
    ///
    /// [`ScanMatchError::NonFiniteGuess`] if the guess has a NaN or infinite component.
    fn match_scans(
        &self,
        reference: &Scan,
        new: &Scan,
        initial_reference_from_new: Pose2,
    ) -> Result<MatchResult, ScanMatchError>;
}

/// Checks the options once, when a matcher is built.
pub(crate) fn validate(raster: &RasterOptions, table: &SearchTable) -> Result<(), ScanMatchError> {
    use ScanMatchError::InvalidOptions;
    if !(raster.resolution_m.is_finite() && raster.resolution_m > 0.0) {
        return Err(InvalidOptions("resolution_m must be finite and positive"));
    }
    if !(1..=MAX_RASTER_SIDE_PX).contains(&raster.width_px)
        || !(1..=MAX_RASTER_SIDE_PX).contains(&raster.height_px)
    {
        return Err(InvalidOptions(
            "raster sides must be between 1 and 16384 pixels",
        ));
    }
    if raster.max_gap_m.is_nan() {
        return Err(InvalidOptions("max_gap_m must not be NaN"));
    }
    if table.translation_step_px == 0 {
        return Err(InvalidOptions("translation_step_px must be at least 1"));
    }
    let max_offset_px = u64::from(table.x_half_steps.max(table.y_half_steps))
        * u64::from(table.translation_step_px);
    if max_offset_px > u64::from(MAX_TRANSLATION_OFFSET_PX) {
        return Err(InvalidOptions(
            "translation offsets must stay within 4096 pixels",
        ));
    }
    if !table.rotation_step_rad.is_finite() {
        return Err(InvalidOptions("rotation_step_rad must be finite"));
    }
    if table.rotation_half_steps > 1 << 20 {
        return Err(InvalidOptions("rotation_half_steps must be at most 2^20"));
    }
    Ok(())
}

/// Rejects guesses with a non-finite component.
pub(crate) fn check_guess(initial_reference_from_new: Pose2) -> Result<(), ScanMatchError> {
    let Pose2 {
        x_m,
        y_m,
        theta_rad,
    } = initial_reference_from_new;
    if x_m.is_finite() && y_m.is_finite() && theta_rad.is_finite() {
        Ok(())
    } else {
        Err(ScanMatchError::NonFiniteGuess)
    }
}

/// A scan reduced to what drawing needs: its valid points and which ones join the next.
#[derive(Clone, Debug)]
pub(crate) struct Polyline {
    points_in_robot: Vec<[f64; 2]>,
    /// `joined_to_next[i]`: a line joins valid point `i` to valid point `i + 1`.
    joined_to_next: Vec<bool>,
}

/// `value` rounded down to an integer, when that lies within ±[`MAX_VERTEX_OFFSET_PX`].
///
/// Exactly `f64::floor`, without a branch on the sign, which vertices on either side of the
/// scan would take at random.
#[inline]
fn floor_within_limit(value: f64) -> Option<i64> {
    let limit = MAX_VERTEX_OFFSET_PX as f64;
    // The floor lies within the limits exactly when the value lies in `[-limit, limit + 1)`;
    // the test also rejects NaN, so the cast truncates a value well inside `i64`.
    if !(value >= -limit && value < limit + 1.0) {
        return None;
    }
    let truncated = value as i64;
    // Truncation rounds negative fractions up: one step back down for those.
    Some(truncated - i64::from(truncated as f64 > value))
}

impl Polyline {
    /// Keeps the valid beams of `scan` and marks the joins allowed by `max_gap_m`.
    pub(crate) fn new(scan: &Scan, max_gap_m: f64) -> Self {
        let mut points_in_robot = Vec::with_capacity(scan.len());
        let mut joined_to_next = Vec::with_capacity(scan.len());
        let mut previous: Option<[f64; 2]> = None;
        for point in scan.points_in_robot() {
            if let (Some(p), Some(q)) = (previous, point) {
                let gap_m = (q[0] - p[0]).hypot(q[1] - p[1]);
                if let Some(joined) = joined_to_next.last_mut() {
                    *joined = gap_m <= max_gap_m;
                }
            }
            if let Some(p) = point {
                points_in_robot.push(*p);
                joined_to_next.push(false);
            }
            previous = *point;
        }
        Polyline {
            points_in_robot,
            joined_to_next,
        }
    }

    /// The vertex pixels (raster column, row, before any table offset) of the points mapped by
    /// `reference_from_new`; `None` for vertices beyond [`MAX_VERTEX_OFFSET_PX`].
    pub(crate) fn vertices_px(
        &self,
        reference_from_new: Pose2,
        raster: &RasterOptions,
    ) -> Vec<Option<[i32; 2]>> {
        let centre = [
            i64::from(raster.width_px / 2),
            i64::from(raster.height_px / 2),
        ];
        // `Pose2::transform_point` spelled out, so the sine and cosine are computed once.
        let (sin, cos) = reference_from_new.theta_rad.sin_cos();
        self.points_in_robot
            .iter()
            .map(|&[x_m, y_m]| {
                let x_in_reference_m = cos * x_m - sin * y_m + reference_from_new.x_m;
                let y_in_reference_m = sin * x_m + cos * y_m + reference_from_new.y_m;
                let column = floor_within_limit(x_in_reference_m / raster.resolution_m)?;
                let row = floor_within_limit(y_in_reference_m / raster.resolution_m)?;
                Some([(column + centre[0]) as i32, (row + centre[1]) as i32])
            })
            .collect()
    }

    /// Calls `set_pixel` for every pixel of the drawing with vertices `vertices_px` (from
    /// [`Polyline::vertices_px`]) shifted by `offset_px`. Pixels may repeat; none is clipped.
    pub(crate) fn draw(
        &self,
        vertices_px: &[Option<[i32; 2]>],
        offset_px: [i32; 2],
        mut set_pixel: impl FnMut([i32; 2]),
    ) {
        debug_assert_eq!(vertices_px.len(), self.joined_to_next.len());
        let shift = |v: [i32; 2]| [v[0] + offset_px[0], v[1] + offset_px[1]];
        for (i, vertex) in vertices_px.iter().enumerate() {
            let Some(vertex) = vertex else { continue };
            let from = shift(*vertex);
            set_pixel(from);
            if !self.joined_to_next[i] {
                continue;
            }
            if let Some(Some(next)) = vertices_px.get(i + 1) {
                // A line to the same or a neighbouring pixel is only its two ends, and the
                // next vertex is drawn as a vertex of its own.
                let gap_px = (next[0] - vertex[0]).abs().max((next[1] - vertex[1]).abs());
                if gap_px > 1 {
                    BresenhamLine::new(from, shift(*next)).for_each(&mut set_pixel);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_candidate_numbering_round_trips() {
        let table = SearchTable {
            x_half_steps: 2,
            y_half_steps: 1,
            translation_step_px: 3,
            rotation_half_steps: 1,
            rotation_step_rad: 0.1,
        };
        assert_eq!(table.len(), 3 * 3 * 5);
        for index in 0..table.len() {
            let candidate = table.candidate(index).unwrap();
            assert_eq!(table.index_of(candidate), index);
        }
        assert_eq!(table.candidate(table.len()), None);
        let first = table.candidate(0).unwrap();
        assert_eq!(table.offset_px(first.x_index, first.y_index), [-6, -3]);
    }

    #[test]
    fn test_quantised_rounds_to_pixels() {
        let raster = RasterOptions::default();
        let table = SearchTable::quantised(10, 10, 0.11, 15, 0.01, &raster);
        assert_eq!(table.translation_step_px, 2);
        let table = SearchTable::quantised(10, 10, 0.0, 15, 0.01, &raster);
        assert_eq!(table.translation_step_px, 1);
    }

    #[test]
    fn test_polyline_breaks_at_gaps_and_missing_beams() {
        let scan = Scan::from_points_in_robot(vec![
            Some([0.0, 0.0]),
            Some([0.2, 0.0]),
            None,
            Some([0.3, 0.0]),
            Some([2.0, 0.0]),
            Some([2.1, 0.0]),
        ]);
        let polyline = Polyline::new(&scan, 0.5);
        assert_eq!(
            polyline.joined_to_next,
            vec![true, false, false, true, false]
        );
    }

    #[test]
    fn test_draw_places_vertices_on_the_raster() {
        let raster = RasterOptions {
            resolution_m: 1.0,
            width_px: 8,
            height_px: 8,
            max_gap_m: 10.0,
        };
        let scan = Scan::from_points_in_robot(vec![Some([0.5, 0.5]), Some([3.5, -0.5])]);
        let polyline = Polyline::new(&scan, raster.max_gap_m);
        let vertices = polyline.vertices_px(Pose2::IDENTITY, &raster);
        assert_eq!(vertices, vec![Some([4, 4]), Some([7, 3])]);
        let mut pixels = Vec::new();
        polyline.draw(&vertices, [0, 1], |p| pixels.push(p));
        assert_eq!(pixels, vec![[4, 5], [4, 5], [5, 5], [6, 4], [7, 4], [7, 4]]);
    }

    proptest::proptest! {
        /// The drawing is every vertex and every line between joined vertices, whichever way
        /// the short lines are taken.
        #[test]
        fn drawing_is_vertices_and_their_lines(
            points in proptest::collection::vec(
                proptest::option::weighted(0.9, (-3.0..3.0f64, -3.0..3.0f64)),
                0..30,
            ),
            max_gap_m in 0.0..2.0f64,
        ) {
            let raster = RasterOptions { resolution_m: 0.1, ..RasterOptions::default() };
            let scan = Scan::from_points_in_robot(
                points.into_iter().map(|p| p.map(|(x, y)| [x, y])).collect(),
            );
            let polyline = Polyline::new(&scan, max_gap_m);
            let vertices = polyline.vertices_px(Pose2::IDENTITY, &raster);
            let mut drawn = std::collections::BTreeSet::new();
            polyline.draw(&vertices, [2, -1], |p| {
                drawn.insert(p);
            });
            let shift = |v: [i32; 2]| [v[0] + 2, v[1] - 1];
            let mut expected = std::collections::BTreeSet::new();
            for (i, vertex) in vertices.iter().enumerate() {
                let Some(vertex) = vertex else { continue };
                expected.insert(shift(*vertex));
                if let (true, Some(Some(next))) = (polyline.joined_to_next[i], vertices.get(i + 1)) {
                    expected.extend(BresenhamLine::new(shift(*vertex), shift(*next)));
                }
            }
            proptest::prop_assert_eq!(drawn, expected);
        }
    }

    #[test]
    fn floor_within_limit_is_floor_inside_the_limit() {
        let limit = MAX_VERTEX_OFFSET_PX as f64;
        for value in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.5,
            2.99,
            -2.99,
            -limit,
            limit,
            limit + 0.5,
        ] {
            assert_eq!(
                floor_within_limit(value),
                Some(value.floor() as i64),
                "{value}"
            );
        }
        for value in [
            limit + 1.0,
            -limit - 1e-9,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            assert_eq!(floor_within_limit(value), None, "{value}");
        }
    }

    proptest::proptest! {
        #[test]
        fn floor_within_limit_matches_the_library(value in -1e5..1e5f64) {
            let floor = value.floor();
            let expected = (floor.abs() <= MAX_VERTEX_OFFSET_PX as f64).then_some(floor as i64);
            proptest::prop_assert_eq!(floor_within_limit(value), expected);
        }
    }

    #[test]
    fn test_far_vertices_are_dropped() {
        let raster = RasterOptions::default();
        let scan = Scan::from_points_in_robot(vec![Some([1e9, 0.0]), Some([0.0, 0.0])]);
        let vertices = Polyline::new(&scan, 1e12).vertices_px(Pose2::IDENTITY, &raster);
        assert_eq!(vertices, vec![None, Some([128, 128])]);
    }

    #[test]
    fn test_validate() {
        let raster = RasterOptions::default();
        let table = SearchTable::default();
        assert_eq!(validate(&raster, &table), Ok(()));
        let bad_raster = RasterOptions {
            resolution_m: 0.0,
            ..raster
        };
        assert!(validate(&bad_raster, &table).is_err());
        let bad_table = SearchTable {
            translation_step_px: 0,
            ..table
        };
        assert!(validate(&raster, &bad_table).is_err());
    }
}
