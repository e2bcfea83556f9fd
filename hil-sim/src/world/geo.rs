//! Local east/north/up metres around a datum to WGS-84 latitude/longitude/altitude.
//!
//! A local tangent-plane approximation: the ellipsoid is replaced near the datum by the
//! plane touching it there, with the meridian and prime-vertical radii of curvature of
//! WGS-84 at the datum latitude (`M` and `N`):
//!
//! ```text
//! lat = lat0 + north / M            lon = lon0 + east / (N · cos lat0)
//! ```
//!
//! Over a few hundred metres the error is far below a GNSS receiver's noise (it grows with
//! the square of the distance: about 1 mm at 1 km). [`GeoDatum::to_local_m`] is the exact
//! inverse of [`GeoDatum::to_geodetic`], so tests can compare in metres.

/// WGS-84 semi-major axis, metres.
const WGS84_A_M: f64 = 6_378_137.0;
/// WGS-84 first eccentricity squared.
const WGS84_E2: f64 = 6.694_379_990_14e-3;

/// The origin of the local east/north/up frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeoDatum {
    /// Latitude, degrees north.
    pub lat_deg: f64,
    /// Longitude, degrees east.
    pub lon_deg: f64,
    /// Altitude above mean sea level, metres.
    pub alt_m: f64,
}

impl Default for GeoDatum {
    /// A field near Munich, 520 m above sea level.
    fn default() -> Self {
        GeoDatum {
            lat_deg: 48.117_3,
            lon_deg: 11.516_7,
            alt_m: 520.0,
        }
    }
}

impl GeoDatum {
    /// Meridian radius of curvature `M` and prime-vertical radius `N` at the datum, metres.
    fn radii_m(&self) -> (f64, f64) {
        let sin_lat = self.lat_deg.to_radians().sin();
        let w2 = 1.0 - WGS84_E2 * sin_lat * sin_lat;
        let n = WGS84_A_M / w2.sqrt();
        let m = WGS84_A_M * (1.0 - WGS84_E2) / (w2 * w2.sqrt());
        (m, n)
    }

    /// Latitude and longitude (degrees) and altitude (metres) of the point `east_m`,
    /// `north_m`, `up_m` from the datum.
    pub fn to_geodetic(&self, east_m: f64, north_m: f64, up_m: f64) -> (f64, f64, f64) {
        let (m, n) = self.radii_m();
        let cos_lat = self.lat_deg.to_radians().cos();
        let lat_deg = self.lat_deg + (north_m / m).to_degrees();
        let lon_deg = self.lon_deg + (east_m / (n * cos_lat)).to_degrees();
        (lat_deg, lon_deg, self.alt_m + up_m)
    }

    /// East and north metres from the datum of `lat_deg`, `lon_deg` (inverse of
    /// [`Self::to_geodetic`]).
    pub fn to_local_m(&self, lat_deg: f64, lon_deg: f64) -> (f64, f64) {
        let (m, n) = self.radii_m();
        let cos_lat = self.lat_deg.to_radians().cos();
        let north_m = (lat_deg - self.lat_deg).to_radians() * m;
        let east_m = (lon_deg - self.lon_deg).to_radians() * n * cos_lat;
        (east_m, north_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_scale() {
        let datum = GeoDatum::default();
        let (lat, lon, alt) = datum.to_geodetic(100.0, -250.0, 3.0);
        let (east, north) = datum.to_local_m(lat, lon);
        assert!((east - 100.0).abs() < 1e-6 && (north + 250.0).abs() < 1e-6);
        assert!((alt - 523.0).abs() < 1e-12);
        // One arc-minute of latitude is about 1 852 m.
        let (lat, _, _) = datum.to_geodetic(0.0, 1852.0, 0.0);
        assert!(((lat - datum.lat_deg) * 60.0 - 1.0).abs() < 0.01);
    }
}
