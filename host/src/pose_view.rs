//! The robot's pose estimate as the outputs show it: the live view, the recording and the
//! web API.

use serde::{Deserialize, Serialize};

/// The robot's current pose estimate, in the map frame and, once the map is geo-referenced,
/// in WGS84.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseView {
    /// Position in the map frame, metres.
    pub x_m: f64,
    /// Position in the map frame, metres.
    pub y_m: f64,
    /// Heading in the map frame, radians.
    pub theta_rad: f64,
    /// Latitude, degrees (WGS84), when the map is geo-referenced.
    pub lat_deg: Option<f64>,
    /// Longitude, degrees (WGS84), when the map is geo-referenced.
    pub lon_deg: Option<f64>,
    /// Covariance of (x, y) in the map frame, m²: `[xx, xy, yy]`.
    pub position_cov_m2: [f64; 3],
    /// Host time of the estimate, seconds.
    pub time_s: f64,
}
