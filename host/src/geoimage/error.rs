//! Why a geo-referenced image could not be opened, decoded, converted or written.

use std::path::PathBuf;

/// Why a [`GeoImage`](super::GeoImage) operation failed. Every variant that concerns a file
/// names it.
#[derive(Debug, thiserror::Error)]
pub enum GeoImageError {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// The file's extension is not one of the supported image formats.
    #[error("{}: unsupported image type (expected .tif, .tiff, .png, .jpg or .jpeg)", path.display())]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
    },
    /// The TIFF decoder or encoder rejected the file or the data.
    #[error("{}: TIFF: {source}", path.display())]
    Tiff {
        /// The file.
        path: PathBuf,
        /// The `tiff` crate's error.
        source: tiff::TiffError,
    },
    /// The PNG decoder rejected the file.
    #[error("{}: PNG: {source}", path.display())]
    Png {
        /// The file.
        path: PathBuf,
        /// The `png` crate's error.
        source: png::DecodingError,
    },
    /// The JPEG decoder rejected the file.
    #[error("{}: JPEG: {message}", path.display())]
    Jpeg {
        /// The file.
        path: PathBuf,
        /// The decoder's message.
        message: String,
    },
    /// The file is well-formed but breaks a rule of its format (a GeoKey directory that is cut
    /// short, a world file without six numbers, a sample layout that cannot be displayed); the
    /// text says which.
    #[error("{}: {message}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The pixels are valid but cannot be shown as RGBA (a sample format or photometric
    /// interpretation this module does not convert); the text says which.
    #[error("{}: cannot convert pixels to RGBA: {message}", path.display())]
    UnsupportedPixels {
        /// The file.
        path: PathBuf,
        /// What is not supported.
        message: String,
    },
    /// The image carries no pixel-to-model mapping: no GeoTIFF tie point, pixel scale or
    /// transformation, and no world file beside it.
    #[error("{}: not geo-referenced ({what})", path.display())]
    NotGeoreferenced {
        /// The file.
        path: PathBuf,
        /// What was looked for.
        what: String,
    },
    /// The image's coordinate reference system is not one this module can convert to WGS84.
    #[error("unsupported coordinate reference system: {0}")]
    UnsupportedCrs(String),
    /// The image is mapped to a model space whose coordinate reference system is not given, so
    /// WGS84 coordinates cannot be computed.
    #[error("the image has no coordinate reference system: WGS84 coordinates are unavailable")]
    NoCrs,
    /// The projection library failed on a point (outside the projection's domain, or a
    /// datum shift that could not be applied).
    #[error("projection of ({x}, {y}) failed: {message}")]
    Projection {
        /// First input coordinate (easting, or longitude in degrees).
        x: f64,
        /// Second input coordinate (northing, or latitude in degrees).
        y: f64,
        /// The library's message.
        message: String,
    },
    /// The pixel-to-model mapping cannot be inverted (zero pixel size).
    #[error("the pixel-to-model transform is singular and cannot be inverted")]
    SingularTransform,
    /// A value given to the writer is not usable; the text says which.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}
