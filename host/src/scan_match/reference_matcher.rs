//! The reference scan matcher: the raster-overlap method as originally done with OpenGL, in
//! software and without shortcuts.
//!
//! For every candidate of the [`SearchTable`] it clears a raster, draws the reference scan and
//! the transformed new scan as polylines, counts the set pixels, and keeps the candidate with the
//! fewest (see [`super::search`] for the exact drawing rules, quantisation and tie-break). Its
//! cost is one full raster clear, two drawings and one full count per candidate. It exists to
//! define the answer: [`super::FastMatcher`] must return exactly the same candidate and score.

use super::scan::Scan;
use super::search::{
    Candidate, MatchResult, Polyline, RasterOptions, ScanMatchError, ScanMatcher, SearchTable,
    check_guess, validate,
};
use crate::geometry::Pose2;

/// Exhaustive raster-overlap matcher over a [`SearchTable`].
#[derive(Clone, Debug)]
pub struct ReferenceMatcher {
    raster: RasterOptions,
    table: SearchTable,
}

impl ReferenceMatcher {
    /// Builds a matcher drawing into `raster` and trying every candidate of `table`.
    ///
    /// # Errors
    ///
    /// [`ScanMatchError::InvalidOptions`] if an option is out of range.
    pub fn new(raster: RasterOptions, table: SearchTable) -> Result<Self, ScanMatchError> {
        validate(&raster, &table)?;
        Ok(ReferenceMatcher { raster, table })
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

impl ScanMatcher for ReferenceMatcher {
    /// Scores every candidate around `initial_reference_from_new`, in table order, and keeps the
    /// first one with the lowest score.
    fn match_scans(
        &self,
        reference: &Scan,
        new: &Scan,
        initial_reference_from_new: Pose2,
    ) -> Result<MatchResult, ScanMatchError> {
        check_guess(initial_reference_from_new)?;
        let raster = &self.raster;
        let table = &self.table;
        let width = raster.width_px as usize;
        let height = raster.height_px as usize;
        let mut pixels = vec![false; width * height];
        let set_pixel = |pixels: &mut [bool], [column, row]: [i32; 2]| {
            // Negative coordinates wrap to huge values and fail the bounds check.
            let (column, row) = (column as usize, row as usize);
            if column < width && row < height {
                pixels[row * width + column] = true;
            }
        };

        let reference_polyline = Polyline::new(reference, raster.max_gap_m);
        let reference_vertices_px = reference_polyline.vertices_px(Pose2::IDENTITY, raster);
        let new_polyline = Polyline::new(new, raster.max_gap_m);

        let mut best: Option<(u32, usize)> = None;
        for rotation_index in 0..table.num_rotations() as u32 {
            let rotation_only = Pose2 {
                theta_rad: table.angle_rad(initial_reference_from_new, rotation_index),
                ..initial_reference_from_new
            };
            let new_vertices_px = new_polyline.vertices_px(rotation_only, raster);
            for y_index in 0..table.num_y() as u32 {
                for x_index in 0..table.num_x() as u32 {
                    pixels.fill(false);
                    reference_polyline.draw(&reference_vertices_px, [0, 0], |p| {
                        set_pixel(&mut pixels, p)
                    });
                    let offset_px = table.offset_px(x_index, y_index);
                    new_polyline.draw(&new_vertices_px, offset_px, |p| set_pixel(&mut pixels, p));
                    // At most 2^28 pixels (sides are capped), so the count fits `u32`.
                    let score_px = pixels.iter().filter(|&&set| set).count() as u32;
                    let index = table.index_of(Candidate {
                        rotation_index,
                        y_index,
                        x_index,
                    });
                    if best.is_none_or(|(best_score_px, _)| score_px < best_score_px) {
                        best = Some((score_px, index));
                    }
                }
            }
        }

        // The table always holds at least one candidate, so `best` is set.
        let (score_px, table_index) = best.unwrap_or((0, 0));
        MatchResult::for_table_entry(
            table,
            raster,
            initial_reference_from_new,
            table_index,
            score_px,
            table.len(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small_raster() -> RasterOptions {
        RasterOptions {
            resolution_m: 0.1,
            width_px: 64,
            height_px: 64,
            max_gap_m: 0.5,
        }
    }

    fn l_shape() -> Scan {
        let mut points = Vec::new();
        for i in 0..20 {
            points.push(Some([1.05, -0.95 + 0.1 * i as f64]));
        }
        for i in 0..20 {
            points.push(Some([1.05 - 0.1 * i as f64, 1.05]));
        }
        Scan::from_points_in_robot(points)
    }

    #[test]
    fn test_recovers_a_pixel_shift() {
        let table = SearchTable {
            x_half_steps: 4,
            y_half_steps: 4,
            translation_step_px: 1,
            rotation_half_steps: 2,
            rotation_step_rad: 0.05,
        };
        let matcher = ReferenceMatcher::new(small_raster(), table).unwrap();
        let reference = l_shape();
        // The new scan sees the same corner from 0.3 m further back and 0.2 m to the left.
        let reference_from_new_true = Pose2::new(-0.3, 0.2, 0.0);
        let new = Scan::from_points_in_robot(
            reference
                .points_in_robot()
                .iter()
                .map(|p| p.map(|p| reference_from_new_true.inverse().transform_point(p)))
                .collect(),
        );
        let result = matcher
            .match_scans(&reference, &new, Pose2::IDENTITY)
            .unwrap();
        assert!(
            (result.reference_from_new.x_m + 0.3).abs() < 1e-9,
            "{result:?}"
        );
        assert!(
            (result.reference_from_new.y_m - 0.2).abs() < 1e-9,
            "{result:?}"
        );
        assert_eq!(result.reference_from_new.theta_rad, 0.0);
        assert_eq!(result.candidates_evaluated, 9 * 9 * 5);
    }

    #[test]
    fn test_empty_scans_pick_the_first_candidate() {
        let matcher = ReferenceMatcher::new(small_raster(), SearchTable::default()).unwrap();
        let result = matcher
            .match_scans(&Scan::default(), &Scan::default(), Pose2::IDENTITY)
            .unwrap();
        assert_eq!((result.table_index, result.score_px), (0, 0));
    }

    #[test]
    fn test_rejects_non_finite_guess() {
        let matcher = ReferenceMatcher::new(small_raster(), SearchTable::default()).unwrap();
        let guess = Pose2::new(f64::NAN, 0.0, 0.0);
        assert_eq!(
            matcher.match_scans(&l_shape(), &l_shape(), guess),
            Err(ScanMatchError::NonFiniteGuess)
        );
    }
}
