//! Geo-referenced images: GeoTIFF and PNG/JPEG with world files, converted to WGS84.
//!
//! [`GeoImage::open`] reads an image's size, its pixel-to-model transform and its coordinate
//! reference system; [`GeoImage::pixel_to_wgs84`] and [`GeoImage::wgs84_to_pixel`] convert
//! between pixels and WGS84 longitude/latitude, [`GeoImage::to_rgba8`] decodes the pixels for
//! display, and [`write_geotiff_rgb8`] writes a projected GeoTIFF (the simulator's aerial
//! image).
//!
//! Sources: OGC GeoTIFF 1.1 (19-008r4) for tags, GeoKeys and raster types; the ESRI world
//! file convention; GDAL's PAM `.aux.xml` for sidecar CRSs. Maintained crates do the work:
//! `tiff` decodes and encodes TIFF, `png` and `zune-jpeg` the other formats, `crs-definitions`
//! maps EPSG codes to PROJ.4 definitions, `proj4wkt` converts WKT, and `proj4rs` does the
//! projections and datum shifts (see [`CrsInfo`] and the `crs` module for the datum rules,
//! including the NAD27 Helmert used because NADCON grids are not available).
//!
//! * [`GeoImage`], [`GeoImageInfo`], [`Corners`], [`ImageFormat`]: an opened image.
//! * [`CrsInfo`]: what its CRS is and how it reaches WGS84.
//! * [`GeoTransform`]: the pixel → model affine map (GDAL geotransform order, corner
//!   convention).
//! * [`write_geotiff_rgb8`] with [`ProjectedGeoref`]: the writer.
//! * [`GeoImageError`]: every failure, one enum.

mod aux_xml;
mod crs;
mod error;
mod geo_image;
mod geo_keys;
mod geo_keys_crs;
mod geo_transform;
mod geotiff;
mod geotiff_writer;
mod rgba;
mod wkt_crs;
mod world_file;

pub use crs::{CrsInfo, NAD27_TO_WGS84_TOWGS84};
pub use error::GeoImageError;
pub use geo_image::{Corners, GeoImage, GeoImageInfo, ImageFormat};
pub use geo_transform::GeoTransform;
pub use geotiff_writer::{
    GeographicGeoref, ProjectedGeoref, write_geotiff_geographic_rgb8, write_geotiff_rgb8,
};
