//! The CRS a GeoTIFF's GeoKeys describe (OGC GeoTIFF 1.1, §7.5–7.6 and Annex B).
//!
//! * An EPSG `ProjectedCSTypeGeoKey` or `GeographicTypeGeoKey` is looked up in the EPSG table.
//! * A user-defined (32767) projected CRS is assembled from its parts: the projection from
//!   `ProjectionGeoKey` (the EPSG UTM conversions 16001–16060 north and 16101–16160 south) or
//!   from `ProjCoordTransGeoKey` and its parameter keys (Transverse Mercator, Mercator,
//!   Lambert Conic Conformal 1SP/2SP, Lambert Azimuthal Equal Area, Albers, Polar
//!   Stereographic), the linear unit from `ProjLinearUnitsGeoKey`, and the geographic part as
//!   below.
//! * A user-defined geographic part comes from an EPSG geographic CRS code, else from an EPSG
//!   datum code, else from the ellipsoid (`GeogEllipsoidGeoKey`, or the semi-axis and inverse
//!   flattening keys), with `GeogTOWGS84GeoKey` as its Helmert to WGS84 and the prime meridian.
//!
//! With an EPSG projected or geographic CRS code, the EPSG definition is used as it is and a
//! `GeogTOWGS84GeoKey` is ignored (the NAIP sample carries `[0, 0, 0]` beside NAD83, which
//! changes nothing).
//!
//! The result is a PROJ.4 definition handed to [`Crs::from_proj_string`]; parameters are read in
//! degrees (`GeogAngularUnitsGeoKey` 9102), the only angular unit accepted.

use super::GeoImageError;
use super::crs::Crs;
use super::geo_keys::{GeoKeys, USER_DEFINED, key};

/// GeoTIFF model types (`GTModelTypeGeoKey`).
const MODEL_PROJECTED: u16 = 1;
const MODEL_GEOGRAPHIC: u16 = 2;
const MODEL_GEOCENTRIC: u16 = 3;

/// EPSG angular unit codes accepted for geographic coordinates and projection parameters.
const ANGULAR_DEGREE: u16 = 9102;
const ANGULAR_DEGREE_SUPPLIER: u16 = 9122;

/// The CRS of `keys`, or `None` when the keys name no CRS at all (no model type, no CRS code).
///
/// # Errors
/// [`GeoImageError::UnsupportedCrs`] naming the key that cannot be handled.
pub(crate) fn crs_from_geo_keys(keys: &GeoKeys) -> Result<Option<Crs>, GeoImageError> {
    let pcs = keys.short(key::PROJECTED_CS_TYPE);
    let gcs = keys.short(key::GEOGRAPHIC_TYPE);
    let model = keys.short(key::GT_MODEL_TYPE).or(match (pcs, gcs) {
        (Some(_), _) => Some(MODEL_PROJECTED),
        (None, Some(_)) => Some(MODEL_GEOGRAPHIC),
        (None, None) => None,
    });
    match model {
        None => Ok(None),
        Some(MODEL_PROJECTED) => projected(keys).map(Some),
        Some(MODEL_GEOGRAPHIC) => geographic(keys).map(Some),
        Some(MODEL_GEOCENTRIC) => Err(unsupported("geocentric model type (GTModelType 3)")),
        Some(other) => Err(unsupported(&format!("GTModelTypeGeoKey {other}"))),
    }
}

fn unsupported(what: &str) -> GeoImageError {
    GeoImageError::UnsupportedCrs(what.to_string())
}

/// The citation to show for a user-defined CRS.
fn citation(keys: &GeoKeys, first: u16, fallback: &str) -> String {
    keys.ascii(first)
        .or(keys.ascii(key::GT_CITATION))
        .filter(|s| !s.trim().is_empty())
        .unwrap_or(fallback)
        .to_string()
}

fn projected(keys: &GeoKeys) -> Result<Crs, GeoImageError> {
    match keys.short(key::PROJECTED_CS_TYPE) {
        Some(code) if code != USER_DEFINED => return Crs::from_epsg(code),
        _ => {}
    }
    check_angular_units(keys)?;
    let projection = projection_params(keys)?;
    let units = linear_units(keys)?;
    let geog = geographic_params(keys)?;
    let description = citation(keys, key::PCS_CITATION, "user-defined projected CRS");
    Crs::from_proj_string(
        None,
        &description,
        &format!("{projection} {units} {geog} +no_defs"),
    )
}

fn geographic(keys: &GeoKeys) -> Result<Crs, GeoImageError> {
    match keys.short(key::GEOGRAPHIC_TYPE) {
        Some(code) if code != USER_DEFINED => return Crs::from_epsg(code),
        _ => {}
    }
    check_angular_units(keys)?;
    let geog = geographic_params(keys)?;
    let description = citation(keys, key::GEOG_CITATION, "user-defined geographic CRS");
    Crs::from_proj_string(
        None,
        &description,
        &format!("+proj=longlat {geog} +no_defs"),
    )
}

fn check_angular_units(keys: &GeoKeys) -> Result<(), GeoImageError> {
    match keys.short(key::GEOG_ANGULAR_UNITS) {
        None | Some(ANGULAR_DEGREE | ANGULAR_DEGREE_SUPPLIER) => Ok(()),
        Some(other) => Err(unsupported(&format!(
            "GeogAngularUnitsGeoKey {other} (only degrees, 9102, are supported)"
        ))),
    }
}

/// `+units=…` or `+to_meter=…` from `ProjLinearUnitsGeoKey` (metres when absent).
fn linear_units(keys: &GeoKeys) -> Result<String, GeoImageError> {
    match keys.short(key::PROJ_LINEAR_UNITS) {
        None | Some(9001) => Ok("+units=m".into()),
        Some(9002) => Ok("+units=ft".into()),
        Some(9003) => Ok("+units=us-ft".into()),
        Some(USER_DEFINED) => match keys.double(key::PROJ_LINEAR_UNIT_SIZE) {
            Some(size) if size > 0.0 => Ok(format!("+to_meter={size}")),
            _ => Err(unsupported(
                "user-defined linear unit without ProjLinearUnitSizeGeoKey",
            )),
        },
        Some(other) => Err(unsupported(&format!("ProjLinearUnitsGeoKey {other}"))),
    }
}

/// The projection part of a user-defined projected CRS.
fn projection_params(keys: &GeoKeys) -> Result<String, GeoImageError> {
    match keys.short(key::PROJECTION) {
        Some(code @ 16001..=16060) => return Ok(format!("+proj=utm +zone={}", code - 16000)),
        Some(code @ 16101..=16160) => {
            return Ok(format!("+proj=utm +zone={} +south", code - 16100));
        }
        Some(USER_DEFINED) | None => {}
        Some(other) => {
            return Err(unsupported(&format!(
                "ProjectionGeoKey {other} (only the UTM conversions 16001-16160 are known)"
            )));
        }
    }
    let Some(method) = keys.short(key::PROJ_COORD_TRANS) else {
        return Err(unsupported(
            "user-defined projected CRS without ProjectionGeoKey or ProjCoordTransGeoKey",
        ));
    };
    // The first key present among `ids`, else 0 (GeoTIFF writers use aliases for origins).
    let p = |ids: &[u16]| ids.iter().find_map(|id| keys.double(*id)).unwrap_or(0.0);
    let scale = |ids: &[u16]| ids.iter().find_map(|id| keys.double(*id)).unwrap_or(1.0);
    let fe = p(&[key::PROJ_FALSE_EASTING, key::PROJ_FALSE_ORIGIN_EASTING]);
    let fn_ = p(&[key::PROJ_FALSE_NORTHING, key::PROJ_FALSE_ORIGIN_NORTHING]);
    let lon0 = p(&[
        key::PROJ_NAT_ORIGIN_LONG,
        key::PROJ_FALSE_ORIGIN_LONG,
        key::PROJ_CENTER_LONG,
    ]);
    let lat0 = p(&[
        key::PROJ_NAT_ORIGIN_LAT,
        key::PROJ_FALSE_ORIGIN_LAT,
        key::PROJ_CENTER_LAT,
    ]);
    let k0 = scale(&[key::PROJ_SCALE_AT_NAT_ORIGIN, key::PROJ_SCALE_AT_CENTER]);
    let sp1 = p(&[key::PROJ_STD_PARALLEL1]);
    let sp2 = p(&[key::PROJ_STD_PARALLEL2]);
    let xy0 = format!("+x_0={fe} +y_0={fn_}");
    Ok(match method {
        // CT_TransverseMercator
        1 => format!("+proj=tmerc +lat_0={lat0} +lon_0={lon0} +k={k0} {xy0}"),
        // CT_Mercator: 1SP with a scale, or 2SP with a standard parallel.
        7 if keys.double(key::PROJ_STD_PARALLEL1).is_some() => {
            format!("+proj=merc +lat_ts={sp1} +lon_0={lon0} {xy0}")
        }
        7 => format!("+proj=merc +lon_0={lon0} +k={k0} {xy0}"),
        // CT_LambertConfConic_2SP
        8 => format!("+proj=lcc +lat_1={sp1} +lat_2={sp2} +lat_0={lat0} +lon_0={lon0} {xy0}"),
        // CT_LambertConfConic_1SP (GeoTIFF's CT_LambertConfConic_Helmert)
        9 => format!("+proj=lcc +lat_1={lat0} +lat_0={lat0} +lon_0={lon0} +k_0={k0} {xy0}"),
        // CT_LambertAzimEqualArea
        10 => format!("+proj=laea +lat_0={lat0} +lon_0={lon0} {xy0}"),
        // CT_AlbersEqualArea
        11 => format!("+proj=aea +lat_1={sp1} +lat_2={sp2} +lat_0={lat0} +lon_0={lon0} {xy0}"),
        // CT_PolarStereographic: the latitude key is the latitude of true scale.
        15 => {
            let pole = if lat0 < 0.0 { -90 } else { 90 };
            let lon = p(&[key::PROJ_STRAIGHT_VERT_POLE_LONG, key::PROJ_NAT_ORIGIN_LONG]);
            format!("+proj=stere +lat_0={pole} +lat_ts={lat0} +lon_0={lon} +k={k0} {xy0}")
        }
        other => {
            return Err(unsupported(&format!("ProjCoordTransGeoKey {other}")));
        }
    })
}

/// The ellipsoid, datum shift and prime meridian of the CRS's geographic part.
fn geographic_params(keys: &GeoKeys) -> Result<String, GeoImageError> {
    let towgs84 = keys.doubles(key::GEOG_TOWGS84);
    if let Some(code) = keys
        .short(key::GEOGRAPHIC_TYPE)
        .filter(|c| *c != USER_DEFINED)
    {
        let params = Crs::epsg_geographic_params(code).ok_or_else(|| {
            unsupported(&format!(
                "GeographicTypeGeoKey {code} is not an EPSG geographic CRS"
            ))
        })?;
        return Ok(params);
    }
    if let Some(datum) = keys
        .short(key::GEOG_GEODETIC_DATUM)
        .filter(|c| *c != USER_DEFINED)
    {
        // EPSG numbers most geographic CRSs 2000 below their datum (datum 6326 → CRS 4326);
        // the guess is accepted only when that CRS's definition names the datum.
        let gcs = datum
            .checked_sub(2000)
            .filter(|gcs| Crs::epsg_has_datum(*gcs, datum));
        if let Some(params) = gcs.and_then(Crs::epsg_geographic_params)
            && towgs84.is_none()
        {
            return Ok(params);
        }
    }
    let mut params = vec![ellipsoid_params(keys)?];
    if let Some(t) = towgs84 {
        if t.len() != 3 && t.len() != 7 {
            return Err(unsupported(&format!(
                "GeogTOWGS84GeoKey has {} values (3 or 7 expected)",
                t.len()
            )));
        }
        let list: Vec<String> = t.iter().map(f64::to_string).collect();
        params.push(format!("+towgs84={}", list.join(",")));
    }
    params.push(prime_meridian(keys)?);
    Ok(params.join(" "))
}

fn ellipsoid_params(keys: &GeoKeys) -> Result<String, GeoImageError> {
    let named = match keys.short(key::GEOG_ELLIPSOID) {
        Some(7001) => Some("airy"),
        Some(7002) => Some("mod_airy"),
        Some(7004) => Some("bessel"),
        Some(7008) => Some("clrk66"),
        Some(7011) => Some("clrk80ign"),
        Some(7012) => Some("clrk80"),
        Some(7019) => Some("GRS80"),
        Some(7022) => Some("intl"),
        Some(7024) => Some("krass"),
        Some(7030) => Some("WGS84"),
        Some(7043) => Some("WGS72"),
        _ => None,
    };
    if let Some(name) = named {
        return Ok(format!("+ellps={name}"));
    }
    let a = keys.double(key::GEOG_SEMI_MAJOR_AXIS);
    match (
        a,
        keys.double(key::GEOG_INV_FLATTENING),
        keys.double(key::GEOG_SEMI_MINOR_AXIS),
    ) {
        (Some(a), Some(rf), _) if rf > 0.0 => Ok(format!("+a={a} +rf={rf}")),
        (Some(a), _, Some(b)) => Ok(format!("+a={a} +b={b}")),
        (Some(a), Some(_), None) => Ok(format!("+a={a} +b={a}")),
        _ => Err(unsupported(&match keys.short(key::GEOG_ELLIPSOID) {
            Some(code) => format!("GeogEllipsoidGeoKey {code} without semi-axis keys"),
            None => "user-defined geographic CRS without an ellipsoid".to_string(),
        })),
    }
}

fn prime_meridian(keys: &GeoKeys) -> Result<String, GeoImageError> {
    let lon_deg = match (
        keys.short(key::GEOG_PRIME_MERIDIAN),
        keys.double(key::GEOG_PRIME_MERIDIAN_LONG),
    ) {
        (_, Some(lon)) => lon,
        (None | Some(8901), None) => 0.0,
        // Paris, 2°20'14.025"E.
        (Some(8903), None) => 2.337_229_166_666_667,
        (Some(other), None) => {
            return Err(unsupported(&format!("GeogPrimeMeridianGeoKey {other}")));
        }
    };
    Ok(if lon_deg == 0.0 {
        String::new()
    } else {
        format!("+pm={lon_deg}")
    })
}

#[cfg(test)]
mod tests {
    use super::super::geo_keys::GeoKeyValue::{Ascii, Double, Short};
    use super::*;

    fn s(v: u16) -> super::super::geo_keys::GeoKeyValue {
        Short(vec![v])
    }

    #[test]
    fn user_defined_utm_equals_the_epsg_zone() {
        // rgb-byte-tenth.tif: PCS 32767 with Projection 16018 on the WGS 84 ellipsoid.
        let keys = GeoKeys::from_pairs([
            (key::GT_MODEL_TYPE, s(1)),
            (key::PROJECTED_CS_TYPE, s(32767)),
            (key::PROJECTION, s(16018)),
            (key::GEOGRAPHIC_TYPE, s(32767)),
            (key::GEOG_GEODETIC_DATUM, s(32767)),
            (key::GEOG_ELLIPSOID, s(7030)),
            (key::PROJ_LINEAR_UNITS, s(9001)),
            (
                key::GT_CITATION,
                Ascii("UTM Zone 18, Northern Hemisphere".into()),
            ),
        ]);
        let crs = crs_from_geo_keys(&keys).unwrap().unwrap();
        assert_eq!(crs.info().epsg, None);
        assert_eq!(crs.info().description, "UTM Zone 18, Northern Hemisphere");
        let reference = Crs::from_epsg(32618).unwrap();
        let got = crs.model_to_wgs84(220_650.0, 2_719_200.0).unwrap();
        let want = reference.model_to_wgs84(220_650.0, 2_719_200.0).unwrap();
        assert!((got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12);
    }

    #[test]
    fn user_defined_transverse_mercator_equals_utm() {
        let keys = GeoKeys::from_pairs([
            (key::GT_MODEL_TYPE, s(1)),
            (key::PROJECTED_CS_TYPE, s(32767)),
            (key::PROJ_COORD_TRANS, s(1)),
            (key::PROJ_NAT_ORIGIN_LONG, Double(vec![-75.0])),
            (key::PROJ_NAT_ORIGIN_LAT, Double(vec![0.0])),
            (key::PROJ_SCALE_AT_NAT_ORIGIN, Double(vec![0.9996])),
            (key::PROJ_FALSE_EASTING, Double(vec![500_000.0])),
            (key::PROJ_FALSE_NORTHING, Double(vec![0.0])),
            (key::GEOGRAPHIC_TYPE, s(4326)),
        ]);
        let crs = crs_from_geo_keys(&keys).unwrap().unwrap();
        let reference = Crs::from_epsg(32618).unwrap();
        let got = crs.model_to_wgs84(339_315.0, 2_611_485.0).unwrap();
        let want = reference.model_to_wgs84(339_315.0, 2_611_485.0).unwrap();
        assert!((got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12);
    }

    #[test]
    fn towgs84_key_moves_a_bessel_geographic_crs() {
        // GeogToWGS84GeoKey5.tif's keys.
        let keys = GeoKeys::from_pairs([
            (key::GT_MODEL_TYPE, s(2)),
            (key::GEOGRAPHIC_TYPE, s(32767)),
            (key::GEOG_GEODETIC_DATUM, s(32767)),
            (key::GEOG_ANGULAR_UNITS, s(9102)),
            (key::GEOG_ELLIPSOID, s(7004)),
            (
                key::GEOG_TOWGS84,
                Double(vec![598.1, 73.7, 418.2, 0.202, 0.045, -2.455, 6.7]),
            ),
        ]);
        let crs = crs_from_geo_keys(&keys).unwrap().unwrap();
        assert!(
            crs.info().datum_shift.starts_with("Helmert"),
            "{:?}",
            crs.info()
        );
        let [lon, lat] = crs.model_to_wgs84(9.0, 52.0).unwrap();
        // The shift is about 100 m: far more than 1e-4°, far less than 1e-2°.
        assert!(
            (lon - 9.0).abs() > 1e-4 && (lon - 9.0).abs() < 1e-2,
            "{lon}"
        );
        assert!(
            (lat - 52.0).abs() > 1e-4 && (lat - 52.0).abs() < 1e-2,
            "{lat}"
        );
    }

    #[test]
    fn no_crs_keys_means_no_crs_and_odd_keys_are_errors() {
        let keys = GeoKeys::from_pairs([(key::GT_RASTER_TYPE, s(1))]);
        assert!(crs_from_geo_keys(&keys).unwrap().is_none());
        let geocentric = GeoKeys::from_pairs([(key::GT_MODEL_TYPE, s(3))]);
        assert!(crs_from_geo_keys(&geocentric).is_err());
        let radians = GeoKeys::from_pairs([
            (key::GT_MODEL_TYPE, s(2)),
            (key::GEOGRAPHIC_TYPE, s(32767)),
            (key::GEOG_ELLIPSOID, s(7030)),
            (key::GEOG_ANGULAR_UNITS, s(9101)),
        ]);
        assert!(crs_from_geo_keys(&radians).is_err());
    }

    #[test]
    fn datum_code_selects_its_geographic_crs() {
        // Datum 6267 (NAD27) → EPSG:4267, which then gets the NAD27 Helmert.
        let keys = GeoKeys::from_pairs([
            (key::GT_MODEL_TYPE, s(2)),
            (key::GEOGRAPHIC_TYPE, s(32767)),
            (key::GEOG_GEODETIC_DATUM, s(6267)),
        ]);
        let crs = crs_from_geo_keys(&keys).unwrap().unwrap();
        assert!(
            crs.info().datum_shift.contains("EPSG:1173"),
            "{:?}",
            crs.info()
        );
    }
}
