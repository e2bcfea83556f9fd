//! The exact raster matcher set up for a search window around a guess.

use crate::scan_match::{FastMatcher, RasterOptions, ScanMatchError, SearchTable};

/// A [`FastMatcher`] over ±`window_m` (both axes) and ±`window_rad`, in steps of one
/// `resolution_m` pixel and `rotation_step_rad`, on a square raster of `raster_side_px`.
///
/// # Errors
/// When these do not make a valid raster or table.
pub(crate) fn window_matcher(
    window_m: f64,
    window_rad: f64,
    resolution_m: f64,
    rotation_step_rad: f64,
    raster_side_px: u32,
) -> Result<FastMatcher, ScanMatchError> {
    let raster = RasterOptions {
        resolution_m,
        width_px: raster_side_px,
        height_px: raster_side_px,
        max_gap_m: 0.5,
    };
    let half_steps = (window_m / resolution_m).round() as u32;
    let rotation_half_steps = (window_rad / rotation_step_rad).round() as u32;
    let table = SearchTable::quantised(
        half_steps,
        half_steps,
        resolution_m,
        rotation_half_steps,
        rotation_step_rad,
        &raster,
    );
    FastMatcher::new(raster, table)
}
