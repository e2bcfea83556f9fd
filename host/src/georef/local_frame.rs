//! The `enu` frame: a local east-north-up frame tangent to the WGS84 ellipsoid at a datum, and the
//! conversions between it and geodetic (`wgs84`) coordinates.
//!
//! Axes: x east, y north, z up along the ellipsoid normal at the datum; metres; origin at the
//! datum. Conversions go through Earth-centred Earth-fixed coordinates with the `map_3d` crate
//! (`geodetic2enu` / `enu2geodetic` on [`map_3d::Ellipsoid::WGS84`]); a round trip over 10 km
//! returns to within nanometres.
//!
//! Heights are ellipsoidal (above the WGS84 ellipsoid), not above mean sea level: an NMEA
//! altitude needs the geoid separation added first (`GpsMeasurement` does so).
//!
//! The frame is a plane tangent at the datum, not the curved ground: a point 1 km away with
//! `up_m = 0` lies about 8 cm above the ellipsoid, and 10 km away about 8 m. The horizontal
//! coordinates stay exact; only `up_m` carries the curvature.
//!
//! Contract: every method checks its input (finite values, |latitude| ≤ 90°, |longitude| ≤ 180°)
//! and its result, and returns a [`GeoRefError`] instead of a NaN; nothing panics.

use map_3d::Ellipsoid;
use serde::{Deserialize, Serialize};

use super::GeoRefError;

/// An east-north-up frame at a datum on WGS84: the `enu` frame of the architecture.
///
/// Built with [`LocalFrame::new`], which validates the datum; deserialising validates it too.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DatumFields", into = "DatumFields")]
pub struct LocalFrame {
    datum_lat_deg: f64,
    datum_lon_deg: f64,
    datum_alt_m: f64,
}

/// The serialised form of a [`LocalFrame`]: its datum, checked on the way in.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct DatumFields {
    datum_lat_deg: f64,
    datum_lon_deg: f64,
    datum_alt_m: f64,
}

impl TryFrom<DatumFields> for LocalFrame {
    type Error = GeoRefError;

    fn try_from(fields: DatumFields) -> Result<Self, GeoRefError> {
        LocalFrame::new(
            fields.datum_lat_deg,
            fields.datum_lon_deg,
            fields.datum_alt_m,
        )
    }
}

impl From<LocalFrame> for DatumFields {
    fn from(frame: LocalFrame) -> Self {
        DatumFields {
            datum_lat_deg: frame.datum_lat_deg,
            datum_lon_deg: frame.datum_lon_deg,
            datum_alt_m: frame.datum_alt_m,
        }
    }
}

impl LocalFrame {
    /// Builds the ENU frame whose origin is the datum (`lat_deg`, `lon_deg`, `alt_m`), with the
    /// height `alt_m` above the WGS84 ellipsoid.
    ///
    /// # Errors
    ///
    /// [`GeoRefError::InvalidLatitude`] / [`GeoRefError::InvalidLongitude`] for a NaN or
    /// out-of-range angle, [`GeoRefError::NonFinite`] for a NaN or infinite altitude.
    pub fn new(lat_deg: f64, lon_deg: f64, alt_m: f64) -> Result<Self, GeoRefError> {
        check_geodetic(lat_deg, lon_deg, alt_m)?;
        Ok(LocalFrame {
            datum_lat_deg: lat_deg,
            datum_lon_deg: lon_deg,
            datum_alt_m: alt_m,
        })
    }

    /// Latitude of the datum, degrees.
    pub fn datum_lat_deg(&self) -> f64 {
        self.datum_lat_deg
    }

    /// Longitude of the datum, degrees.
    pub fn datum_lon_deg(&self) -> f64 {
        self.datum_lon_deg
    }

    /// Height of the datum above the WGS84 ellipsoid, metres.
    pub fn datum_alt_m(&self) -> f64 {
        self.datum_alt_m
    }

    /// Converts the geodetic point (`lat_deg`, `lon_deg`, `alt_m` above the ellipsoid) into
    /// `[east_m, north_m, up_m]` in this frame.
    ///
    /// # Errors
    ///
    /// [`GeoRefError::InvalidLatitude`] / [`GeoRefError::InvalidLongitude`] for a NaN or
    /// out-of-range angle, [`GeoRefError::NonFinite`] for a NaN or infinite altitude or a
    /// non-finite result.
    pub fn to_enu_m(
        &self,
        lat_deg: f64,
        lon_deg: f64,
        alt_m: f64,
    ) -> Result<[f64; 3], GeoRefError> {
        check_geodetic(lat_deg, lon_deg, alt_m)?;
        let (east_m, north_m, up_m) = map_3d::geodetic2enu(
            lat_deg.to_radians(),
            lon_deg.to_radians(),
            alt_m,
            self.datum_lat_deg.to_radians(),
            self.datum_lon_deg.to_radians(),
            self.datum_alt_m,
            Ellipsoid::WGS84,
        );
        if !(east_m.is_finite() && north_m.is_finite() && up_m.is_finite()) {
            return Err(GeoRefError::NonFinite("the ENU position"));
        }
        Ok([east_m, north_m, up_m])
    }

    /// Converts the point (`east_m`, `north_m`, `up_m`) of this frame into geodetic
    /// `(lat_deg, lon_deg, alt_m)`, with the height above the WGS84 ellipsoid and the longitude
    /// in (-180°, 180°].
    ///
    /// # Errors
    ///
    /// [`GeoRefError::NonFinite`] for a NaN or infinite coordinate, or for a point so far from
    /// the datum (near the centre of the Earth) that no geodetic position results.
    pub fn to_geodetic(
        &self,
        east_m: f64,
        north_m: f64,
        up_m: f64,
    ) -> Result<(f64, f64, f64), GeoRefError> {
        if !(east_m.is_finite() && north_m.is_finite() && up_m.is_finite()) {
            return Err(GeoRefError::NonFinite("an ENU coordinate"));
        }
        let (lat_rad, lon_rad, alt_m) = map_3d::enu2geodetic(
            east_m,
            north_m,
            up_m,
            self.datum_lat_deg.to_radians(),
            self.datum_lon_deg.to_radians(),
            self.datum_alt_m,
            Ellipsoid::WGS84,
        );
        if !(lat_rad.is_finite() && lon_rad.is_finite() && alt_m.is_finite()) {
            return Err(GeoRefError::NonFinite("the geodetic position"));
        }
        Ok((lat_rad.to_degrees(), lon_rad.to_degrees(), alt_m))
    }

    /// Converts the planar point `point_in_enu_m = [east_m, north_m]` (taken at `up_m = 0`) into
    /// `[lon_deg, lat_deg]`, longitude first as GeoJSON and KML write them.
    ///
    /// A point on the ground `d` metres from the datum lies about `d² / 12.7e6` m below the
    /// tangent plane; reading it at `up_m = 0` shifts it horizontally by about `d³ / 8.1e13` m:
    /// 12 µm at 1 km, 1.2 cm at 10 km.
    ///
    /// # Errors
    ///
    /// As [`LocalFrame::to_geodetic`].
    pub fn to_lon_lat_deg(&self, point_in_enu_m: [f64; 2]) -> Result<[f64; 2], GeoRefError> {
        let (lat_deg, lon_deg, _) = self.to_geodetic(point_in_enu_m[0], point_in_enu_m[1], 0.0)?;
        Ok([lon_deg, lat_deg])
    }
}

/// Checks a geodetic position: finite values, |`lat_deg`| ≤ 90, |`lon_deg`| ≤ 180.
pub(super) fn check_geodetic(lat_deg: f64, lon_deg: f64, alt_m: f64) -> Result<(), GeoRefError> {
    // `contains` is false for NaN, so NaN and infinities fail here too.
    if !(-90.0..=90.0).contains(&lat_deg) {
        return Err(GeoRefError::InvalidLatitude { lat_deg });
    }
    if !(-180.0..=180.0).contains(&lon_deg) {
        return Err(GeoRefError::InvalidLongitude { lon_deg });
    }
    if !alt_m.is_finite() {
        return Err(GeoRefError::NonFinite("an altitude"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// WGS84 semi-major axis and flattening, for the independent meridian-arc check.
    const WGS84_A_M: f64 = 6_378_137.0;
    const WGS84_F: f64 = 1.0 / 298.257_223_563;

    /// Meridional radius of curvature at `lat_deg` on WGS84, metres.
    fn meridian_radius_m(lat_deg: f64) -> f64 {
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let s = lat_deg.to_radians().sin();
        WGS84_A_M * (1.0 - e2) / (1.0 - e2 * s * s).powf(1.5)
    }

    #[test]
    fn test_round_trip_over_10_km() {
        let datums = [
            (47.3, 8.5, 400.0),
            (-33.9, 151.2, 20.0),
            (0.0, 0.0, 0.0),
            (78.2, 15.6, -10.0),
            (10.0, 179.99, 5.0),
        ];
        let mut worst_m: f64 = 0.0;
        for (lat_deg, lon_deg, alt_m) in datums {
            let frame = LocalFrame::new(lat_deg, lon_deg, alt_m).unwrap();
            for i in 0..400 {
                let bearing_rad = f64::from(i) * 0.7;
                let range_m = f64::from(i % 101) * 100.0;
                let up_m = f64::from(i % 7 - 3) * 30.0;
                let east_m = range_m * bearing_rad.cos();
                let north_m = range_m * bearing_rad.sin();
                let (lat, lon, alt) = frame.to_geodetic(east_m, north_m, up_m).unwrap();
                let [e, n, u] = frame.to_enu_m(lat, lon, alt).unwrap();
                let error_m =
                    ((e - east_m).powi(2) + (n - north_m).powi(2) + (u - up_m).powi(2)).sqrt();
                worst_m = worst_m.max(error_m);
            }
        }
        assert!(worst_m < 1e-6, "round trip error {worst_m} m");
    }

    #[test]
    fn test_one_arc_minute_of_latitude() {
        for lat_deg in [0.0, 47.3, -60.0] {
            let frame = LocalFrame::new(lat_deg, 8.5, 0.0).unwrap();
            let [east_m, north_m, _] = frame.to_enu_m(lat_deg + 1.0 / 60.0, 8.5, 0.0).unwrap();
            // The meridian arc of one arc-minute, taken at its middle latitude.
            let arc_m = meridian_radius_m(lat_deg + 0.5 / 60.0) * (1.0 / 60.0f64).to_radians();
            assert!(east_m.abs() < 1e-6, "east {east_m} m");
            assert!((north_m - arc_m).abs() < 1e-3, "{north_m} m vs {arc_m} m");
            // About one nautical mile: 1842.9 m at the equator, 1861.6 m at the poles.
            assert!((north_m - 1852.0).abs() < 10.0, "{north_m} m");
        }
    }

    #[test]
    fn test_datum_maps_to_origin() {
        let frame = LocalFrame::new(47.3, 8.5, 400.0).unwrap();
        let [e, n, u] = frame.to_enu_m(47.3, 8.5, 400.0).unwrap();
        assert!(e.abs() < 1e-9 && n.abs() < 1e-9 && u.abs() < 1e-9);
        let (lat, lon, alt) = frame.to_geodetic(0.0, 0.0, 0.0).unwrap();
        assert!((lat - 47.3).abs() < 1e-12 && (lon - 8.5).abs() < 1e-12);
        assert!((alt - 400.0).abs() < 1e-6);
    }

    #[test]
    fn test_rejects_invalid_input() {
        assert!(matches!(
            LocalFrame::new(f64::NAN, 0.0, 0.0),
            Err(GeoRefError::InvalidLatitude { .. })
        ));
        assert!(matches!(
            LocalFrame::new(90.5, 0.0, 0.0),
            Err(GeoRefError::InvalidLatitude { .. })
        ));
        assert!(matches!(
            LocalFrame::new(0.0, 181.0, 0.0),
            Err(GeoRefError::InvalidLongitude { .. })
        ));
        assert!(matches!(
            LocalFrame::new(0.0, 0.0, f64::INFINITY),
            Err(GeoRefError::NonFinite(_))
        ));
        let frame = LocalFrame::new(47.3, 8.5, 400.0).unwrap();
        assert!(matches!(
            frame.to_enu_m(-91.0, 8.5, 0.0),
            Err(GeoRefError::InvalidLatitude { .. })
        ));
        assert!(matches!(
            frame.to_enu_m(47.0, f64::NEG_INFINITY, 0.0),
            Err(GeoRefError::InvalidLongitude { .. })
        ));
        assert!(matches!(
            frame.to_geodetic(f64::NAN, 0.0, 0.0),
            Err(GeoRefError::NonFinite(_))
        ));
        // The centre of the Earth has no geodetic position.
        let equator = LocalFrame::new(0.0, 0.0, 0.0).unwrap();
        assert!(matches!(
            equator.to_geodetic(0.0, 0.0, -WGS84_A_M),
            Err(GeoRefError::NonFinite(_))
        ));
    }

    #[test]
    fn test_serde_validates_datum() {
        let frame = LocalFrame::new(47.3, 8.5, 400.0).unwrap();
        let text = serde_json::to_string(&frame).unwrap();
        let back: LocalFrame = serde_json::from_str(&text).unwrap();
        assert_eq!(back, frame);
        let bad = r#"{"datum_lat_deg":95.0,"datum_lon_deg":0.0,"datum_alt_m":0.0}"#;
        assert!(serde_json::from_str::<LocalFrame>(bad).is_err());
    }
}
