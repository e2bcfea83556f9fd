//! Writing an RGB8 image as a GeoTIFF in a projected EPSG CRS, e.g. the simulator's aerial
//! image of a world in a WGS84 UTM zone.
//!
//! The file is a Deflate-compressed, striped, chunky RGB TIFF (written by the `tiff` crate)
//! with `ModelPixelScaleTag` (square pixels), a `ModelTiepointTag` tying raster (0, 0) (the
//! outer top-left corner) to the given easting/northing, and a GeoKey directory version 1.1.0
//! with `GTModelType` = projected, `GTRasterType` = PixelIsArea, `GTCitation`,
//! `ProjectedCSType` = the EPSG code and `ProjLinearUnits` = metre, which GDAL and
//! [`GeoImage::open`](super::GeoImage::open) read back.

use std::io::BufWriter;
use std::path::Path;

use tiff::encoder::compression::DeflateLevel;
use tiff::encoder::{Compression, TiffEncoder, colortype};
use tiff::tags::Tag;

use super::GeoImageError;
use super::crs::{Crs, wkt_name};

/// Where a north-up image with square pixels lies in a projected CRS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProjectedGeoref {
    /// EPSG code of a projected CRS in metres, e.g. 32618 for WGS 84 / UTM zone 18N.
    pub epsg: u16,
    /// Easting and northing, metres, of the **outer** upper-left corner of the upper-left
    /// pixel.
    pub upper_left_m: [f64; 2],
    /// Side of a (square) pixel, metres.
    pub pixel_size_m: f64,
}

/// Writes `rgb` (`width × height` pixels, row-major, 3 bytes each) to `path` as a GeoTIFF
/// geo-referenced by `georef`.
///
/// # Errors
/// [`GeoImageError::InvalidArgument`] when the buffer length does not match, a size is zero,
/// the pixel size or corner is not finite and positive, or the EPSG code is not a projected
/// CRS in metres from the EPSG table; [`GeoImageError::Io`] / [`GeoImageError::Tiff`] when
/// writing fails.
pub fn write_geotiff_rgb8(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[u8],
    georef: &ProjectedGeoref,
) -> Result<(), GeoImageError> {
    let invalid = |m: String| GeoImageError::InvalidArgument(m);
    check_rgb_buffer(width, height, rgb)?;
    if !(georef.pixel_size_m.is_finite() && georef.pixel_size_m > 0.0) {
        return Err(invalid(format!(
            "pixel size {} m is not positive",
            georef.pixel_size_m
        )));
    }
    if !georef.upper_left_m.iter().all(|v| v.is_finite()) {
        return Err(invalid(format!(
            "upper-left corner {:?} is not finite",
            georef.upper_left_m
        )));
    }
    let crs = Crs::from_epsg(georef.epsg).map_err(|e| invalid(e.to_string()))?;
    if crs.info().geographic || crs.linear_unit_m() != 1.0 {
        return Err(invalid(format!(
            "EPSG:{} is not a projected CRS in metres",
            georef.epsg
        )));
    }
    let citation = crs_definitions::from_code(georef.epsg)
        .and_then(|def| wkt_name(def.wkt))
        .unwrap_or("unnamed");
    let ascii = format!("{citation}|");
    let ascii_len = u16::try_from(ascii.len()).map_err(|_| invalid("citation too long".into()))?;
    #[rustfmt::skip]
    let directory: [u16; 24] = [
        1, 1, 0, 5, // version 1.1.0, 5 keys, sorted by id
        1024, 0, 1, 1, // GTModelTypeGeoKey = projected
        1025, 0, 1, 1, // GTRasterTypeGeoKey = PixelIsArea
        1026, 34737, ascii_len, 0, // GTCitationGeoKey in GeoAsciiParams
        3072, 0, 1, georef.epsg, // ProjectedCSTypeGeoKey
        3076, 0, 1, 9001, // ProjLinearUnitsGeoKey = metre
    ];
    let [e, n] = georef.upper_left_m;
    let s = georef.pixel_size_m;
    write_tiff(path, width, height, rgb, [s, s], [e, n], &directory, &ascii)
}

/// Where a north-up image lies in WGS 84 latitude and longitude (EPSG:4326).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeographicGeoref {
    /// Longitude and latitude, degrees, of the **outer** upper-left corner of the upper-left
    /// pixel.
    pub upper_left_lon_lat_deg: [f64; 2],
    /// Width and height of a pixel in longitude and latitude, degrees (they may differ, so
    /// that a pixel is square in metres at some latitude).
    pub pixel_size_deg: [f64; 2],
}

/// Writes `rgb` (`width × height` pixels, row-major, 3 bytes each) to `path` as a GeoTIFF in
/// WGS 84 latitude/longitude (EPSG:4326) geo-referenced by `georef`.
///
/// # Errors
/// [`GeoImageError::InvalidArgument`] when the buffer length does not match, a size is zero,
/// a pixel size is not finite and positive or the corner is not a longitude and latitude;
/// [`GeoImageError::Io`] / [`GeoImageError::Tiff`] when writing fails.
pub fn write_geotiff_geographic_rgb8(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[u8],
    georef: &GeographicGeoref,
) -> Result<(), GeoImageError> {
    let invalid = |m: String| GeoImageError::InvalidArgument(m);
    check_rgb_buffer(width, height, rgb)?;
    if !georef
        .pixel_size_deg
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
    {
        return Err(invalid(format!(
            "pixel size {:?}° is not positive",
            georef.pixel_size_deg
        )));
    }
    let [lon, lat] = georef.upper_left_lon_lat_deg;
    if !(lon.is_finite() && lat.is_finite() && lon.abs() <= 180.0 && lat.abs() <= 90.0) {
        return Err(invalid(format!(
            "upper-left corner {:?} is not a longitude and latitude",
            georef.upper_left_lon_lat_deg
        )));
    }
    let ascii = "WGS 84|";
    #[rustfmt::skip]
    let directory: [u16; 24] = [
        1, 1, 0, 5, // version 1.1.0, 5 keys, sorted by id
        1024, 0, 1, 2, // GTModelTypeGeoKey = geographic
        1025, 0, 1, 1, // GTRasterTypeGeoKey = PixelIsArea
        2048, 0, 1, 4326, // GeographicTypeGeoKey = WGS 84
        2049, 34737, 7, 0, // GeogCitationGeoKey in GeoAsciiParams
        2054, 0, 1, 9102, // GeogAngularUnitsGeoKey = degree
    ];
    write_tiff(
        path,
        width,
        height,
        rgb,
        georef.pixel_size_deg,
        [lon, lat],
        &directory,
        ascii,
    )
}

/// Checks that `rgb` holds `width × height` RGB pixels, and that there are some.
fn check_rgb_buffer(width: u32, height: u32, rgb: &[u8]) -> Result<(), GeoImageError> {
    let invalid = |m: String| GeoImageError::InvalidArgument(m);
    if width == 0 || height == 0 {
        return Err(invalid(format!("image size {width}×{height} is empty")));
    }
    let expected = width as usize * height as usize * 3;
    if rgb.len() != expected {
        return Err(invalid(format!(
            "RGB buffer has {} bytes, {width}×{height}×3 = {expected} expected",
            rgb.len()
        )));
    }
    Ok(())
}

/// Writes the image with its pixel scale, the tie point of raster (0, 0) and the GeoKeys.
#[allow(clippy::too_many_arguments)]
fn write_tiff(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[u8],
    pixel_scale: [f64; 2],
    upper_left: [f64; 2],
    directory: &[u16],
    ascii: &str,
) -> Result<(), GeoImageError> {
    let [e, n] = upper_left;
    let io_err = |source| GeoImageError::Io {
        path: path.to_path_buf(),
        source,
    };
    let tiff_err = |source| GeoImageError::Tiff {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::create(path).map_err(io_err)?;
    let mut encoder = TiffEncoder::new(BufWriter::new(file))
        .map_err(tiff_err)?
        .with_compression(Compression::Deflate(DeflateLevel::Balanced));
    let mut image = encoder
        .new_image::<colortype::RGB8>(width, height)
        .map_err(tiff_err)?;
    let dir = image.encoder();
    dir.write_tag(
        Tag::ModelPixelScaleTag,
        &[pixel_scale[0], pixel_scale[1], 0.0][..],
    )
    .map_err(tiff_err)?;
    dir.write_tag(Tag::ModelTiepointTag, &[0.0, 0.0, 0.0, e, n, 0.0][..])
        .map_err(tiff_err)?;
    dir.write_tag(Tag::GeoKeyDirectoryTag, directory)
        .map_err(tiff_err)?;
    dir.write_tag(Tag::GeoAsciiParamsTag, ascii)
        .map_err(tiff_err)?;
    image.write_data(rgb).map_err(tiff_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn georef() -> ProjectedGeoref {
        ProjectedGeoref {
            epsg: 32618,
            upper_left_m: [300_000.0, 4_500_000.0],
            pixel_size_m: 0.5,
        }
    }

    #[test]
    fn round_trip_through_geo_image() {
        use super::super::{Corners, GeoImage};
        let dir = std::env::temp_dir().join(format!("geoimage-writer-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("aerial.tif");
        let (w, h) = (7u32, 5u32);
        let rgb: Vec<u8> = (0..w * h * 3).map(|i| (i * 7 % 251) as u8).collect();
        let g = ProjectedGeoref {
            epsg: 32633,
            upper_left_m: [500_000.0, 5_000_000.0],
            pixel_size_m: 2.0,
        };
        write_geotiff_rgb8(&path, w, h, &rgb, &g).unwrap();

        let image = GeoImage::open(&path).unwrap();
        assert_eq!((image.width(), image.height()), (w, h));
        assert_eq!(
            image.crs().map(|c| c.description.as_str()),
            Some("WGS 84 / UTM zone 33N")
        );
        let info = image.info();
        assert_eq!(
            info.corners_model,
            Corners {
                upper_left: [500_000.0, 5_000_000.0],
                upper_right: [500_014.0, 5_000_000.0],
                lower_right: [500_014.0, 4_999_990.0],
                lower_left: [500_000.0, 4_999_990.0],
                center: [500_007.0, 4_999_995.0],
            }
        );
        // The west edge is zone 33's central meridian, 15°E; corners agree with the CRS.
        let crs = Crs::from_epsg(32633).unwrap();
        let wgs = info.corners_wgs84.unwrap();
        assert!((wgs.upper_left[0] - 15.0).abs() < 1e-12);
        for (got, model) in [
            (wgs.upper_left, info.corners_model.upper_left),
            (wgs.lower_right, info.corners_model.lower_right),
        ] {
            assert_eq!(got, crs.model_to_wgs84(model[0], model[1]).unwrap());
        }
        let rgba = image.to_rgba8().unwrap();
        let back: Vec<u8> = rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        assert_eq!(back, rgb);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn geographic_round_trip() {
        use super::super::GeoImage;
        let dir = std::env::temp_dir().join(format!("geoimage-geographic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("aerial.tif");
        let (w, h) = (40u32, 20u32);
        let rgb = vec![90u8; (w * h * 3) as usize];
        let georef = GeographicGeoref {
            upper_left_lon_lat_deg: [11.5, 48.12],
            pixel_size_deg: [1e-5, 2e-5],
        };
        write_geotiff_geographic_rgb8(&path, w, h, &rgb, &georef).unwrap();
        let image = GeoImage::open(&path).unwrap();
        assert_eq!(image.crs().and_then(|c| c.epsg), Some(4326));
        let [lon, lat] = image.pixel_to_wgs84(40.0, 20.0).unwrap();
        assert!((lon - 11.5004).abs() < 1e-12 && (lat - 48.1196).abs() < 1e-12);
        let [col, row] = image.wgs84_to_pixel(11.5001, 48.1198).unwrap();
        assert!((col - 10.0).abs() < 1e-6 && (row - 10.0).abs() < 1e-6);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn rejects_bad_arguments() {
        let path = std::env::temp_dir().join("geoimage-writer-never-written.tif");
        let bad = |w, h, rgb: &[u8], g: ProjectedGeoref| {
            matches!(
                write_geotiff_rgb8(&path, w, h, rgb, &g),
                Err(GeoImageError::InvalidArgument(_))
            )
        };
        assert!(bad(2, 2, &[0; 11], georef()));
        assert!(bad(0, 2, &[], georef()));
        assert!(bad(
            2,
            2,
            &[0; 12],
            ProjectedGeoref {
                pixel_size_m: 0.0,
                ..georef()
            }
        ));
        assert!(bad(
            2,
            2,
            &[0; 12],
            ProjectedGeoref {
                upper_left_m: [f64::NAN, 0.0],
                ..georef()
            }
        ));
        assert!(bad(
            2,
            2,
            &[0; 12],
            ProjectedGeoref {
                epsg: 4326,
                ..georef()
            }
        ));
        assert!(bad(
            2,
            2,
            &[0; 12],
            ProjectedGeoref {
                epsg: 1,
                ..georef()
            }
        ));
        assert!(!path.exists());
    }
}
