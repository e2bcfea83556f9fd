//! A landmark positioned in the `enu` frame, as the WGS84 exports take it.
//!
//! Both exports ([`write_geojson`](super::write_geojson), [`write_kml`](super::write_kml)) read
//! the same landmark type, so the two files describe a map the same way.

use super::GeoRefError;

/// A landmark (a tree, a pole) in the `enu` frame, with what the exports write about it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LandmarkInEnu {
    /// The landmark's identifier in the map, if it has one.
    pub id: Option<u64>,
    /// `[east_m, north_m]` of the landmark's centre in the `enu` frame.
    pub position_in_enu_m: [f64; 2],
    /// Diameter of the trunk or pole, metres, if measured.
    pub diameter_m: Option<f64>,
}

impl LandmarkInEnu {
    /// Checks what the exports cannot write: a diameter that is NaN, infinite or negative.
    /// (The position is checked by the conversion to WGS84.)
    pub(super) fn check_diameter(&self) -> Result<(), GeoRefError> {
        match self.diameter_m {
            Some(diameter_m) if !(diameter_m.is_finite() && diameter_m >= 0.0) => {
                Err(GeoRefError::InvalidDiameter { diameter_m })
            }
            _ => Ok(()),
        }
    }
}
