//! Geo-referencing: GPS fixes in a local metric frame, map-to-GPS alignment, WGS84 exports.
//!
//! Three frames meet here: `map` (the global SLAM frame, from either SLAM method), `enu` (a
//! local east-north-up frame at a GPS datum, metres) and `wgs84` (latitude, longitude and
//! ellipsoidal height). The flow is GPS fix → `enu` measurement; (map point, measurement) pairs
//! → `enu_from_map`; map content carried into `enu` → WGS84 files.
//!
//! * [`LocalFrame`]: the `enu` frame at a datum; `wgs84` ↔ `enu` through the `map_3d` crate.
//! * [`GpsMeasurement`] with [`GpsMeasurementOptions`]: a board GPS report (or a plain
//!   latitude/longitude) as a 2D position in `enu` with a 2×2 covariance from GST statistics or
//!   HDOP; [`CovarianceSource`] says which.
//! * [`RigidAlignment2d`] from [`AlignmentPair`]s with [`RigidAlignmentOptions`]: the weighted
//!   least-squares `enu_from_map` (closed-form Procrustes start, Gauss-Newton refinement) with
//!   its 3×3 covariance and residual.
//! * [`write_geojson`] / [`feature_collection`] and [`write_kml`] / [`kml_document`]: a
//!   trajectory and [`LandmarkInEnu`]s as GeoJSON (RFC 7946) and KML 2.2 in WGS84.
//! * [`GeoReferencer`]: downstream of a SLAM method (the grid method's), a trajectory and the fixes give
//!   `enu_from_map` ([`MapAlignment`]) with its covariance, receiver jumps set aside.
//! * [`GeoRefError`]: every failure of the module, one enum.

mod error;
mod geo_referencer;
mod geojson_export;
mod gps_measurement;
mod kml_export;
mod landmark_in_enu;
mod local_frame;
mod rigid_alignment;
mod similarity_alignment;

pub use error::GeoRefError;
pub use geo_referencer::{GeoReferencer, GeoReferencerOptions, MapAlignment};
pub use geojson_export::{feature_collection, write_geojson};
pub use gps_measurement::{CovarianceSource, GpsMeasurement, GpsMeasurementOptions};
pub use kml_export::{kml_document, write_kml};
pub use landmark_in_enu::LandmarkInEnu;
pub use local_frame::LocalFrame;
pub use rigid_alignment::{AlignmentPair, RigidAlignment2d, RigidAlignmentOptions};
pub use similarity_alignment::{MapFrameChange, SimilarityAlignment2d, SimilarityFit2d};
