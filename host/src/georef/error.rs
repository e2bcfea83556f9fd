//! Why geo-referencing rejected an input or could not produce a result.
//!
//! One error type for the whole module boundary: coordinate conversions, GPS measurements, the
//! map-to-ENU alignment and the WGS84 exports all return [`GeoRefError`].

/// Why a geo-referencing operation failed.
#[derive(Debug, thiserror::Error)]
pub enum GeoRefError {
    /// A latitude is NaN, infinite or outside [-90°, 90°].
    #[error("latitude {lat_deg}° is not in [-90°, 90°]")]
    InvalidLatitude {
        /// The rejected latitude, degrees.
        lat_deg: f64,
    },
    /// A longitude is NaN, infinite or outside [-180°, 180°].
    #[error("longitude {lon_deg}° is not in [-180°, 180°]")]
    InvalidLongitude {
        /// The rejected longitude, degrees.
        lon_deg: f64,
    },
    /// A value that must be finite (an altitude, an ENU coordinate, a map point, a conversion
    /// result) is NaN or infinite; the text names it.
    #[error("{0} is not finite")]
    NonFinite(&'static str),
    /// The GPS report has no position, or its quality says there is no fix.
    #[error("the GPS report carries no valid fix")]
    NoFix,
    /// The GPS report carries neither GST error statistics nor an HDOP, and no HDOP is assumed
    /// for such reports (see `GpsMeasurementOptions::assumed_hdop`).
    #[error("the GPS report carries neither GST sigmas nor HDOP")]
    NoAccuracy,
    /// A standard deviation is not finite and strictly positive.
    #[error("standard deviation {sigma_m} m is not finite and positive")]
    InvalidSigma {
        /// The rejected standard deviation, metres.
        sigma_m: f64,
    },
    /// The covariance of the alignment pair at `index` is not finite, symmetric and positive
    /// definite.
    #[error("the covariance of alignment pair {index} is not symmetric positive definite")]
    InvalidCovariance {
        /// Index of the pair in the input slice.
        index: usize,
    },
    /// The alignment got fewer than the two pairs a rotation and translation need.
    #[error("{count} alignment pairs given, at least 2 are needed")]
    TooFewPairs {
        /// How many pairs were given.
        count: usize,
    },
    /// The map points of the alignment all coincide (or the normal equations are singular), so
    /// the rotation is not determined.
    #[error("the map points are coincident: the rotation is not determined")]
    DegenerateGeometry,
    /// A landmark diameter is NaN, infinite or negative.
    #[error("landmark diameter {diameter_m} m is not finite and non-negative")]
    InvalidDiameter {
        /// The rejected diameter, metres.
        diameter_m: f64,
    },
    /// An option is out of range; the text names it.
    #[error("invalid geo-referencing option: {0}")]
    InvalidOptions(&'static str),
    /// Writing the bytes to the output failed.
    #[error("writing the export failed: {0}")]
    Io(#[from] std::io::Error),
    /// Serialising the GeoJSON document failed.
    #[error("writing GeoJSON failed: {0}")]
    GeoJson(#[from] serde_json::Error),
    /// Writing the KML document failed.
    #[error("writing KML failed: {0}")]
    Kml(#[from] kml::Error),
}
