//! The affine map from pixel coordinates to model (CRS) coordinates.
//!
//! Stored in GDAL's geotransform order: `x = c0 + col·c1 + row·c2`, `y = c3 + col·c4 + row·c5`,
//! where `(col, row) = (0, 0)` is the **outer** top-left corner of the top-left pixel and
//! `(width, height)` the outer bottom-right corner. Every source (GeoTIFF tie point and pixel
//! scale, GeoTIFF ModelTransformation, ESRI world file) is brought to this one convention when
//! it is read, including GeoTIFF's `PixelIsPoint` and the world file's pixel-centre origin.

use serde::Serialize;

use super::GeoImageError;

/// Pixel → model affine transform in GDAL geotransform order (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GeoTransform(pub [f64; 6]);

impl GeoTransform {
    /// From a GeoTIFF tie point `(i, j) → (x, y)` and pixel scale `(sx, sy)`: raster point
    /// `(i, j)` (pixel-corner convention) lies at model `(x, y)`; model y grows upward while rows
    /// grow downward, so the row step is `-sy`.
    pub fn from_tiepoint_and_scale(
        raster_ij: [f64; 2],
        model_xy: [f64; 2],
        scale: [f64; 2],
    ) -> Self {
        let [i, j] = raster_ij;
        let [x, y] = model_xy;
        let [sx, sy] = scale;
        GeoTransform([x - i * sx, sx, 0.0, y + j * sy, 0.0, -sy])
    }

    /// From the 4×4 row-major GeoTIFF ModelTransformationTag (only the 2D part is used).
    pub fn from_model_transformation(m: &[f64; 16]) -> Self {
        GeoTransform([m[3], m[0], m[1], m[7], m[4], m[5]])
    }

    /// From an ESRI world file's six numbers in file order `A, D, B, E, C, F`, where `(C, F)`
    /// is the **centre** of the top-left pixel: the corner is half a pixel up and left of it.
    pub fn from_world_file(lines: [f64; 6]) -> Self {
        let [a, d, b, e, c, f] = lines;
        GeoTransform([c - 0.5 * a - 0.5 * b, a, b, f - 0.5 * d - 0.5 * e, d, e])
    }

    /// The transform of a raster whose model coordinates refer to pixel **centres** (GeoTIFF
    /// `RasterPixelIsPoint`), moved to the corner convention: raster point `(0, 0)` is then the
    /// centre of pixel (0, 0), so the corner lies at raster `(-0.5, -0.5)` of the given map.
    /// This is GDAL's default handling.
    pub fn shifted_from_pixel_is_point(self) -> Self {
        let [x, y] = self.apply(-0.5, -0.5);
        let [_, c1, c2, _, c4, c5] = self.0;
        GeoTransform([x, c1, c2, y, c4, c5])
    }

    /// Model coordinates of pixel coordinates `(col, row)`.
    pub fn apply(&self, col: f64, row: f64) -> [f64; 2] {
        let [c0, c1, c2, c3, c4, c5] = self.0;
        [c0 + col * c1 + row * c2, c3 + col * c4 + row * c5]
    }

    /// Pixel coordinates `[col, row]` of model coordinates `(x, y)`.
    ///
    /// # Errors
    /// [`GeoImageError::SingularTransform`] when the linear part has no inverse.
    pub fn invert(&self, x: f64, y: f64) -> Result<[f64; 2], GeoImageError> {
        let [c0, c1, c2, c3, c4, c5] = self.0;
        let det = c1 * c5 - c2 * c4;
        if !det.is_finite() || det.abs() < f64::MIN_POSITIVE {
            return Err(GeoImageError::SingularTransform);
        }
        let (dx, dy) = (x - c0, y - c3);
        Ok([(c5 * dx - c2 * dy) / det, (-c4 * dx + c1 * dy) / det])
    }

    /// Whether the transform has rotation or shear terms.
    pub fn is_rotated(&self) -> bool {
        self.0[2] != 0.0 || self.0[4] != 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiepoint_not_at_origin_gives_same_corner() {
        // Tie point at raster (431, 134) of a 1000 m grid whose corner is (4302000, 2811000).
        let gt = GeoTransform::from_tiepoint_and_scale(
            [431.0, 134.0],
            [4302000.0 + 431_000.0, 2811000.0 - 134_000.0],
            [1000.0, 1000.0],
        );
        assert_eq!(gt.0, [4302000.0, 1000.0, 0.0, 2811000.0, 0.0, -1000.0]);
    }

    #[test]
    fn world_file_origin_is_pixel_centre() {
        let gt = GeoTransform::from_world_file([2.0, 0.0, 0.0, -3.0, 101.0, 198.5]);
        assert_eq!(gt.apply(0.0, 0.0), [100.0, 200.0]);
        assert_eq!(gt.apply(0.5, 0.5), [101.0, 198.5]);
    }

    #[test]
    fn pixel_is_point_moves_half_a_pixel() {
        let m = [
            1000.0, 0.0, 0.0, 4302000.0, 0.0, -1000.0, 0.0, 2811000.0, 0.0, 0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, 1.0,
        ];
        let gt = GeoTransform::from_model_transformation(&m).shifted_from_pixel_is_point();
        assert_eq!(gt.apply(0.0, 0.0), [4301500.0, 2811500.0]);
    }

    #[test]
    fn inverse_undoes_a_rotated_transform() {
        let gt = GeoTransform([
            100.0,
            17.320508075688775,
            5.0,
            200.0,
            10.0,
            -8.660254037844387,
        ]);
        assert!(gt.is_rotated());
        let [x, y] = gt.apply(3.25, 7.5);
        let [col, row] = gt.invert(x, y).unwrap();
        assert!((col - 3.25).abs() < 1e-12 && (row - 7.5).abs() < 1e-12);
    }

    #[test]
    fn singular_transform_is_an_error() {
        let gt = GeoTransform([0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        assert!(matches!(
            gt.invert(1.0, 1.0),
            Err(GeoImageError::SingularTransform)
        ));
    }
}
