//! A geo-referenced image: its size, pixel-to-model transform and CRS, with conversions
//! between pixel coordinates and WGS84.
//!
//! Pixel coordinates `(col, row)` are continuous: `(0, 0)` is the outer top-left corner of the
//! top-left pixel, `(width, height)` the outer bottom-right corner, and `(c + 0.5, r + 0.5)`
//! the centre of pixel `(c, r)`. WGS84 positions are `[lon_deg, lat_deg]`.
//!
//! Where the geo-referencing comes from:
//! * `.tif` / `.tiff`: the GeoTIFF tags and GeoKeys (see [`super::geotiff`]); a TIFF without
//!   them may use a world file (`.tfw`, `.tifw`, `.wld`) and a `.prj` / `.aux.xml` sidecar.
//! * `.png`, `.jpg` / `.jpeg`: a world file (see [`super::world_file`]), else a
//!   `<GeoTransform>` in `image.ext.aux.xml`; the CRS from `image.prj` (WKT) or the `<SRS>` of
//!   `image.ext.aux.xml`.
//!
//! An image mapped to a model space without a CRS (a GeoTIFF with a transformation but no
//! GeoKeys, a world file without `.prj`) opens: its model coordinates are available, its
//! WGS84 ones are not ([`GeoImageError::NoCrs`]).

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::GeoImageError;
use super::aux_xml::{aux_xml_path, read_aux_xml};
use super::crs::{Crs, CrsInfo};
use super::geo_transform::GeoTransform;
use super::geotiff::read_geotiff_header;
use super::rgba::{jpeg_dimensions, jpeg_to_rgba8, png_dimensions, png_to_rgba8, tiff_to_rgba8};
use super::wkt_crs::crs_from_wkt;
use super::world_file::{find_world_file, read_world_file};

/// The container format of an image file, from its extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    /// TIFF / GeoTIFF.
    Tiff,
    /// PNG.
    Png,
    /// JPEG.
    Jpeg,
}

impl ImageFormat {
    /// The format of `path` by its extension (case-insensitive), if supported.
    pub fn from_path(path: &Path) -> Option<Self> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "tif" | "tiff" => Some(ImageFormat::Tiff),
            "png" => Some(ImageFormat::Png),
            "jpg" | "jpeg" => Some(ImageFormat::Jpeg),
            _ => None,
        }
    }
}

/// A geo-referenced image (see the module docs).
#[derive(Debug, Clone)]
pub struct GeoImage {
    path: PathBuf,
    format: ImageFormat,
    width: u32,
    height: u32,
    transform: GeoTransform,
    crs: Option<Crs>,
}

/// Positions of the four outer corners and the centre of an image.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Corners {
    /// Pixel coordinates (0, 0).
    pub upper_left: [f64; 2],
    /// Pixel coordinates (width, 0).
    pub upper_right: [f64; 2],
    /// Pixel coordinates (width, height).
    pub lower_right: [f64; 2],
    /// Pixel coordinates (0, height).
    pub lower_left: [f64; 2],
    /// Pixel coordinates (width / 2, height / 2).
    pub center: [f64; 2],
}

/// Summary of a [`GeoImage`], as printed by `robot-host georef-info`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GeoImageInfo {
    /// The CRS, or `null` when the image has none.
    pub crs: Option<CrsInfo>,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Corners as `[lon_deg, lat_deg]` in WGS84, or `null` when they cannot be computed (no
    /// CRS, or a corner outside the projection's domain; `note` says which).
    pub corners_wgs84: Option<Corners>,
    /// Corners in the image's model space (the CRS's coordinates, e.g. easting/northing).
    pub corners_model: Corners,
    /// The pixel-to-model transform in GDAL geotransform order.
    pub geo_transform: [f64; 6],
    /// Why `corners_wgs84` is missing, when it is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl GeoImage {
    /// Opens the image at `path` and reads its geo-referencing (not its pixels).
    ///
    /// # Errors
    /// [`GeoImageError::UnsupportedFormat`] for another extension; [`GeoImageError::Io`],
    /// [`GeoImageError::Tiff`], [`GeoImageError::Png`], [`GeoImageError::Jpeg`] when the file or
    /// a sidecar cannot be read; [`GeoImageError::NotGeoreferenced`] when there is no
    /// pixel-to-model transform; [`GeoImageError::Malformed`] or
    /// [`GeoImageError::UnsupportedCrs`] for georeferencing that cannot be used.
    pub fn open(path: &Path) -> Result<GeoImage, GeoImageError> {
        let format =
            ImageFormat::from_path(path).ok_or_else(|| GeoImageError::UnsupportedFormat {
                path: path.to_path_buf(),
            })?;
        if !path.is_file() {
            let source = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
            return Err(GeoImageError::Io {
                path: path.to_path_buf(),
                source,
            });
        }
        let (width, height, tiff_transform, tiff_crs, has_geo_keys) = match format {
            ImageFormat::Tiff => {
                let h = read_geotiff_header(path)?;
                (h.width, h.height, h.transform, h.crs, h.has_geo_keys)
            }
            ImageFormat::Png => {
                let (w, h) = png_dimensions(path)?;
                (w, h, None, None, false)
            }
            ImageFormat::Jpeg => {
                let (w, h) = jpeg_dimensions(path)?;
                (w, h, None, None, false)
            }
        };
        // The PAM sidecar is read only when the file itself lacks something.
        let needs_sidecar = tiff_transform.is_none() || (tiff_crs.is_none() && !has_geo_keys);
        let aux_path = aux_xml_path(path);
        let aux = if needs_sidecar && aux_path.is_file() {
            Some(read_aux_xml(&aux_path)?)
        } else {
            None
        };
        let transform = match tiff_transform {
            Some(t) => t,
            None => match find_world_file(path) {
                Some(world) => read_world_file(&world)?,
                None => aux.as_ref().and_then(|a| a.geo_transform).ok_or_else(|| {
                    GeoImageError::NotGeoreferenced {
                        path: path.to_path_buf(),
                        what: match format {
                            ImageFormat::Tiff => "no GeoTIFF ModelTiepoint/ModelPixelScale or \
                                                  ModelTransformation tags, no world file"
                                .into(),
                            _ => "no world file (.pgw/.pngw/.jgw/.wld) and no GeoTransform in \
                                  .aux.xml"
                                .into(),
                        },
                    }
                })?,
            },
        };
        let crs = match tiff_crs {
            Some(crs) => Some(crs),
            None if has_geo_keys => None,
            None => sidecar_crs(path, aux.as_ref().and_then(|a| a.srs_wkt.as_deref()))?,
        };
        Ok(GeoImage {
            path: path.to_path_buf(),
            format,
            width,
            height,
            transform,
            crs,
        })
    }

    /// The file this image was opened from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The container format.
    pub fn format(&self) -> ImageFormat {
        self.format
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The CRS, or `None` for an image mapped to a model space without a CRS (such an image
    /// has model coordinates but no WGS84 ones).
    pub fn crs(&self) -> Option<&CrsInfo> {
        self.crs.as_ref().map(Crs::info)
    }

    /// The pixel-to-model transform (corner convention, GDAL order).
    pub fn geo_transform(&self) -> GeoTransform {
        self.transform
    }

    /// Model (CRS) coordinates of pixel coordinates `(col, row)`.
    pub fn pixel_to_model(&self, col: f64, row: f64) -> [f64; 2] {
        self.transform.apply(col, row)
    }

    /// WGS84 `[lon_deg, lat_deg]` of pixel coordinates `(col, row)`, with `(0, 0)` the outer
    /// top-left corner of the top-left pixel and `(width, height)` the outer bottom-right
    /// corner.
    ///
    /// # Errors
    /// [`GeoImageError::NoCrs`] without a CRS; [`GeoImageError::Projection`] when the point is
    /// outside the projection's domain.
    pub fn pixel_to_wgs84(&self, col: f64, row: f64) -> Result<[f64; 2], GeoImageError> {
        let crs = self.crs.as_ref().ok_or(GeoImageError::NoCrs)?;
        let [x, y] = self.transform.apply(col, row);
        crs.model_to_wgs84(x, y)
    }

    /// Pixel coordinates `[col, row]` of WGS84 `(lon_deg, lat_deg)` (see
    /// [`GeoImage::pixel_to_wgs84`] for the convention). The result may lie outside the image.
    ///
    /// # Errors
    /// [`GeoImageError::NoCrs`], [`GeoImageError::Projection`], or
    /// [`GeoImageError::SingularTransform`] for a degenerate transform.
    pub fn wgs84_to_pixel(&self, lon_deg: f64, lat_deg: f64) -> Result<[f64; 2], GeoImageError> {
        let crs = self.crs.as_ref().ok_or(GeoImageError::NoCrs)?;
        let [x, y] = crs.wgs84_to_model(lon_deg, lat_deg)?;
        self.transform.invert(x, y)
    }

    /// Size, CRS and corners, for display or JSON.
    pub fn info(&self) -> GeoImageInfo {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let corners = |f: &dyn Fn(f64, f64) -> Result<[f64; 2], GeoImageError>| {
            Ok::<_, GeoImageError>(Corners {
                upper_left: f(0.0, 0.0)?,
                upper_right: f(w, 0.0)?,
                lower_right: f(w, h)?,
                lower_left: f(0.0, h)?,
                center: f(w / 2.0, h / 2.0)?,
            })
        };
        let corners_model = Corners {
            upper_left: self.pixel_to_model(0.0, 0.0),
            upper_right: self.pixel_to_model(w, 0.0),
            lower_right: self.pixel_to_model(w, h),
            lower_left: self.pixel_to_model(0.0, h),
            center: self.pixel_to_model(w / 2.0, h / 2.0),
        };
        let (corners_wgs84, note) = match corners(&|c, r| self.pixel_to_wgs84(c, r)) {
            Ok(c) => (Some(c), None),
            Err(GeoImageError::NoCrs) => (
                None,
                Some(
                    "no coordinate reference system: WGS84 corners are unavailable; \
                     corners_model are in the file's unnamed model space"
                        .to_string(),
                ),
            ),
            Err(e) => (None, Some(e.to_string())),
        };
        GeoImageInfo {
            crs: self.crs().cloned(),
            width: self.width,
            height: self.height,
            corners_wgs84,
            corners_model,
            geo_transform: self.transform.0,
            note,
        }
    }

    /// Decodes the pixels as RGBA8, row-major, `width × height × 4` bytes (see
    /// [`super::rgba`] for the conversion of grey, palette, WhiteIsZero, 16-bit and planar
    /// TIFFs).
    ///
    /// # Errors
    /// The decoder's error, [`GeoImageError::UnsupportedPixels`] for a layout that cannot be
    /// shown, [`GeoImageError::Malformed`] if the decoded size differs from the header's.
    pub fn to_rgba8(&self) -> Result<Vec<u8>, GeoImageError> {
        let path = self.path.as_path();
        let image = match self.format {
            ImageFormat::Tiff => {
                let bytes = std::fs::read(path).map_err(|source| GeoImageError::Io {
                    path: path.to_path_buf(),
                    source,
                })?;
                tiff_to_rgba8(path, bytes)?
            }
            ImageFormat::Png => png_to_rgba8(path)?,
            ImageFormat::Jpeg => jpeg_to_rgba8(path)?,
        };
        let expected = self.width as usize * self.height as usize * 4;
        if (image.width, image.height) != (self.width, self.height)
            || image.pixels.len() != expected
        {
            return Err(GeoImageError::Malformed {
                path: path.to_path_buf(),
                message: format!(
                    "decoded {}×{} ({} bytes), header says {}×{}",
                    image.width,
                    image.height,
                    image.pixels.len(),
                    self.width,
                    self.height
                ),
            });
        }
        Ok(image.pixels)
    }

    /// The image as an RGBA PNG, for a web page to show.
    ///
    /// # Errors
    /// As [`Self::to_rgba8`]; [`GeoImageError::Malformed`] if the PNG cannot be encoded.
    pub fn to_png(&self) -> Result<Vec<u8>, GeoImageError> {
        let rgba = self.to_rgba8()?;
        let mut out = Vec::new();
        let encode = |out: &mut Vec<u8>| -> Result<(), png::EncodingError> {
            let mut encoder = png::Encoder::new(out, self.width, self.height);
            encoder.set_color(png::ColorType::Rgba);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header()?;
            writer.write_image_data(&rgba)?;
            writer.finish()
        };
        encode(&mut out).map_err(|e| GeoImageError::Malformed {
            path: self.path.clone(),
            message: format!("cannot encode as PNG: {e}"),
        })?;
        Ok(out)
    }
}

/// The CRS from `image`'s `.prj` (WKT) or the `.aux.xml` `<SRS>` WKT already read.
fn sidecar_crs(image: &Path, aux_srs: Option<&str>) -> Result<Option<Crs>, GeoImageError> {
    let prj = image.with_extension("prj");
    if prj.is_file() {
        let wkt = std::fs::read_to_string(&prj).map_err(|source| GeoImageError::Io {
            path: prj.clone(),
            source,
        })?;
        return crs_from_wkt(&wkt).map(Some);
    }
    aux_srs
        .filter(|s| !s.is_empty())
        .map(crs_from_wkt)
        .transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh temporary directory for one test.
    fn temp_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("geoimage-{test}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    const ESRI_UTM_18N: &str = r#"PROJCS["WGS_1984_UTM_Zone_18N",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",500000.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-75.0],PARAMETER["Scale_Factor",0.9996],PARAMETER["Latitude_Of_Origin",0.0],UNIT["Meter",1.0]]"#;

    #[test]
    fn jpeg_with_world_file_and_prj() {
        let dir = temp_dir("jpeg");
        let jpg = dir.join("map.jpg");
        let (w, h) = (16u16, 8u16);
        let rgb: Vec<u8> = (0..u32::from(w) * u32::from(h))
            .flat_map(|_| [200, 30, 30])
            .collect();
        let encoder = jpeg_encoder::Encoder::new_file(&jpg, 95).unwrap();
        encoder
            .encode(&rgb, w, h, jpeg_encoder::ColorType::Rgb)
            .unwrap();
        // 10 m pixels; the world file gives the centre of the top-left pixel.
        std::fs::write(dir.join("map.jgw"), "10\n0\n0\n-10\n500005\n4000095\n").unwrap();
        std::fs::write(dir.join("map.prj"), ESRI_UTM_18N).unwrap();

        let image = GeoImage::open(&jpg).unwrap();
        assert_eq!(image.format(), ImageFormat::Jpeg);
        assert_eq!((image.width(), image.height()), (16, 8));
        assert_eq!(image.crs().map(|c| c.name.as_str()), Some("EPSG:32618"));
        let info = image.info();
        assert_eq!(info.corners_model.upper_left, [500_000.0, 4_000_100.0]);
        assert_eq!(info.corners_model.lower_right, [500_160.0, 4_000_020.0]);
        // Easting 500000 is zone 18's central meridian.
        let [lon, _] = image.pixel_to_wgs84(0.0, 0.0).unwrap();
        assert!((lon + 75.0).abs() < 1e-12, "{lon}");
        let rgba = image.to_rgba8().unwrap();
        assert_eq!(rgba.len(), 16 * 8 * 4);
        let p = &rgba[(3 * 16 + 5) * 4..][..4];
        assert!(p[0].abs_diff(200) <= 3 && p[1].abs_diff(30) <= 3 && p[2].abs_diff(30) <= 3);
        assert_eq!(p[3], 255);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn plain_tiff_uses_tfw_and_aux_xml_srs() {
        use tiff::encoder::{TiffEncoder, colortype};
        let dir = temp_dir("tfw");
        let tif = dir.join("plain.tif");
        let grey: Vec<u8> = (0..12).map(|v| v * 20).collect();
        let file = std::fs::File::create(&tif).unwrap();
        let mut encoder = TiffEncoder::new(std::io::BufWriter::new(file)).unwrap();
        encoder
            .write_image::<colortype::Gray8>(4, 3, &grey)
            .unwrap();
        drop(encoder);
        std::fs::write(
            dir.join("plain.tfw"),
            "0.5\r\n0\r\n0\r\n-0.5\r\n10.25\r\n49.75\r\n",
        )
        .unwrap();
        let srs = crs_definitions::EPSG_4326.wkt.replace('"', "&quot;");
        let aux = format!("<PAMDataset><SRS>{srs}</SRS></PAMDataset>");
        std::fs::write(dir.join("plain.tif.aux.xml"), aux).unwrap();

        let image = GeoImage::open(&tif).unwrap();
        assert_eq!(image.crs().map(|c| c.name.as_str()), Some("EPSG:4326"));
        let close =
            |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12;
        assert!(close(image.pixel_to_wgs84(0.0, 0.0).unwrap(), [10.0, 50.0]));
        assert!(close(image.pixel_to_wgs84(4.0, 3.0).unwrap(), [12.0, 48.5]));
        assert!(close(image.wgs84_to_pixel(11.0, 49.0).unwrap(), [2.0, 2.0]));
        let rgba = image.to_rgba8().unwrap();
        assert_eq!(&rgba[4 * 5..4 * 6], &[100, 100, 100, 255]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn world_file_without_crs_has_model_but_no_wgs84_coordinates() {
        let dir = temp_dir("nocrs");
        let png = dir.join("scan.png");
        let file = std::fs::File::create(&png).unwrap();
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), 2, 2);
        encoder.set_color(png::ColorType::Grayscale);
        encoder
            .write_header()
            .unwrap()
            .write_image_data(&[0, 1, 2, 3])
            .unwrap();
        std::fs::write(dir.join("scan.wld"), "1\n0\n0\n-1\n0.5\n9.5\n").unwrap();

        let image = GeoImage::open(&png).unwrap();
        assert!(image.crs().is_none());
        assert_eq!(image.pixel_to_model(2.0, 2.0), [2.0, 8.0]);
        assert!(matches!(
            image.pixel_to_wgs84(0.0, 0.0),
            Err(GeoImageError::NoCrs)
        ));
        let info = image.info();
        assert!(info.corners_wgs84.is_none() && info.note.is_some());

        std::fs::remove_file(dir.join("scan.wld")).unwrap();
        let err = GeoImage::open(&png).unwrap_err();
        assert!(
            matches!(err, GeoImageError::NotGeoreferenced { .. }),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unsupported_extension_and_missing_file_are_errors() {
        let err = GeoImage::open(Path::new("map.bmp")).unwrap_err();
        assert!(matches!(err, GeoImageError::UnsupportedFormat { .. }));
        let err = GeoImage::open(Path::new("/nonexistent/map.tif")).unwrap_err();
        assert!(matches!(err, GeoImageError::Io { .. }));
    }
}
