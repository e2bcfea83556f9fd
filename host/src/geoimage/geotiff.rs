//! Reading the geo-referencing of a GeoTIFF (OGC GeoTIFF 1.1): the pixel-to-model transform
//! from `ModelTiepointTag` + `ModelPixelScaleTag` or from `ModelTransformationTag`, the raster
//! type (`PixelIsArea` / `PixelIsPoint`) and the CRS from the GeoKey directory.
//!
//! Tags are decoded by the `tiff` crate. With `RasterPixelIsPoint` the file's transform maps
//! pixel centres; it is moved half a pixel to the corner convention, as GDAL does by default.
//! A tie point need not be at raster (0, 0). Several tie points without a pixel scale (ground
//! control points) are not supported.

use std::io::BufReader;
use std::path::Path;

use tiff::decoder::Decoder;
use tiff::tags::Tag;

use super::GeoImageError;
use super::crs::Crs;
use super::geo_keys::{GeoKeys, key};
use super::geo_keys_crs::crs_from_geo_keys;
use super::geo_transform::GeoTransform;

/// `GTRasterTypeGeoKey` value for "pixel is point".
const RASTER_PIXEL_IS_POINT: u16 = 2;

/// What a TIFF file says about its size and geo-referencing.
#[derive(Debug)]
pub(crate) struct GeoTiffHeader {
    pub width: u32,
    pub height: u32,
    /// The pixel-to-model transform, in the corner convention; `None` when the file has no
    /// GeoTIFF transform tags.
    pub transform: Option<GeoTransform>,
    /// Whether the file has a GeoKey directory at all.
    pub has_geo_keys: bool,
    /// The CRS the GeoKeys describe, if any.
    pub crs: Option<Crs>,
}

/// Reads the size and geo-referencing tags of the first image in the TIFF at `path`.
///
/// # Errors
/// [`GeoImageError::Io`] / [`GeoImageError::Tiff`] when the file cannot be read or decoded,
/// [`GeoImageError::Malformed`] for inconsistent GeoTIFF tags, [`GeoImageError::UnsupportedCrs`]
/// for a CRS that cannot be converted.
pub(crate) fn read_geotiff_header(path: &Path) -> Result<GeoTiffHeader, GeoImageError> {
    let file = std::fs::File::open(path).map_err(|source| GeoImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let tiff_err = |source| GeoImageError::Tiff {
        path: path.to_path_buf(),
        source,
    };
    let malformed = |message: String| GeoImageError::Malformed {
        path: path.to_path_buf(),
        message,
    };
    let mut decoder = Decoder::new(BufReader::new(file)).map_err(tiff_err)?;
    let (width, height) = decoder.dimensions().map_err(tiff_err)?;

    let mut f64_tag = |tag: Tag| -> Result<Option<Vec<f64>>, GeoImageError> {
        decoder
            .find_tag(tag)
            .map_err(tiff_err)?
            .map(|v| v.into_f64_vec())
            .transpose()
            .map_err(tiff_err)
    };
    let scale = f64_tag(Tag::ModelPixelScaleTag)?;
    let tiepoints = f64_tag(Tag::ModelTiepointTag)?;
    let matrix = f64_tag(Tag::ModelTransformationTag)?;
    let doubles = f64_tag(Tag::GeoDoubleParamsTag)?.unwrap_or_default();
    let directory = decoder
        .find_tag_unsigned_vec::<u16>(Tag::GeoKeyDirectoryTag)
        .map_err(tiff_err)?;
    let ascii = match decoder.find_tag(Tag::GeoAsciiParamsTag).map_err(tiff_err)? {
        Some(v) => v.into_string().map_err(tiff_err)?,
        None => String::new(),
    };

    let keys = match &directory {
        Some(d) => GeoKeys::parse(d, &doubles, &ascii).map_err(malformed)?,
        None => GeoKeys::default(),
    };
    let transform = model_transform(scale.as_deref(), tiepoints.as_deref(), matrix.as_deref())
        .map_err(malformed)?;
    let transform = match transform {
        Some(t) if keys.short(key::GT_RASTER_TYPE) == Some(RASTER_PIXEL_IS_POINT) => {
            Some(t.shifted_from_pixel_is_point())
        }
        other => other,
    };
    let crs = if keys.is_empty() {
        None
    } else {
        crs_from_geo_keys(&keys)?
    };
    Ok(GeoTiffHeader {
        width,
        height,
        transform,
        has_geo_keys: directory.is_some(),
        crs,
    })
}

/// The raster-to-model transform from the three GeoTIFF transform tags.
fn model_transform(
    scale: Option<&[f64]>,
    tiepoints: Option<&[f64]>,
    matrix: Option<&[f64]>,
) -> Result<Option<GeoTransform>, String> {
    if let Some(m) = matrix {
        let m: &[f64; 16] = m
            .try_into()
            .map_err(|_| format!("ModelTransformationTag has {} values, 16 expected", m.len()))?;
        return Ok(Some(GeoTransform::from_model_transformation(m)));
    }
    match (tiepoints, scale) {
        (None, None) => Ok(None),
        (Some(t), Some(s)) => {
            let &[i, j, _, x, y, _] = t
                .first_chunk::<6>()
                .ok_or("ModelTiepointTag has fewer than 6 values")?;
            let &[sx, sy, ..] = s else {
                return Err(format!(
                    "ModelPixelScaleTag has {} values, 3 expected",
                    s.len()
                ));
            };
            Ok(Some(GeoTransform::from_tiepoint_and_scale(
                [i, j],
                [x, y],
                [sx, sy],
            )))
        }
        (Some(t), None) => Err(format!(
            "{} tie points without ModelPixelScaleTag (ground control points are not supported)",
            t.len() / 6
        )),
        (None, Some(_)) => Err("ModelPixelScaleTag without ModelTiepointTag".to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transform_from_tags() {
        let t = model_transform(
            Some(&[60.0, 60.0, 0.0]),
            Some(&[0.0, 0.0, 0.0, 440720.0, 3751320.0, 0.0]),
            None,
        )
        .unwrap()
        .unwrap();
        assert_eq!(t.0, [440720.0, 60.0, 0.0, 3751320.0, 0.0, -60.0]);
        assert_eq!(model_transform(None, None, None).unwrap(), None);
    }

    #[test]
    fn inconsistent_tags_are_errors() {
        assert!(
            model_transform(None, Some(&[0.0; 12]), None)
                .unwrap_err()
                .contains("2 tie points")
        );
        assert!(model_transform(Some(&[1.0]), Some(&[0.0; 6]), None).is_err());
        assert!(model_transform(None, None, Some(&[1.0; 12])).is_err());
        assert!(model_transform(Some(&[1.0, 1.0, 0.0]), None, None).is_err());
    }
}
