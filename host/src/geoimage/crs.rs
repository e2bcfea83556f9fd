//! A coordinate reference system and its conversion to and from WGS84 longitude/latitude.
//!
//! Definitions are PROJ.4 strings: for an EPSG code they come from the `crs-definitions`
//! crate (a table of EPSG definitions), for user-defined GeoTIFF keys and WKT they are built
//! by [`super::geo_keys_crs`] and [`super::wkt_crs`]. The projection and datum maths is the
//! `proj4rs` crate's (a Rust port of PROJ.4, checked by its authors against PROJ).
//!
//! Datum shifts follow PROJ.4's rule: the CRS is taken to WGS84 through its `+towgs84`
//! Helmert parameters (3 or 7, position-vector convention, as in GeoTIFF's
//! `GeogTOWGS84GeoKey` and WKT's `TOWGS84`). Two cases are handled here on purpose:
//!
//! * **NAD27** (`+datum=NAD27`): PROJ.4 shifts it with the NADCON grids (`conus`, …), which are
//!   not available here; `proj4rs` then silently applies no shift, an error of about 80 m in
//!   California. The definition is rewritten to the published EPSG:1173 Helmert, see
//!   [`NAD27_TO_WGS84_TOWGS84`].
//! * **NAD83, ETRS89** and other datums defined with `+towgs84=0,0,0` are treated as identical to
//!   WGS84, as PROJ does without a time-dependent transformation: they differ from WGS84
//!   (G1762) by about 1–2 m, which this module ignores.
//!
//! A datum without any known relation to WGS84 (a user-defined datum on a named ellipsoid) is
//! used as if it were WGS84, which is PROJ's "ballpark" behaviour; [`CrsInfo::datum_shift`]
//! says so.

use proj4rs::proj::Proj;
use serde::Serialize;

use super::GeoImageError;

/// `+towgs84` parameters of EPSG:1173, "NAD27 to WGS 84 (4)": a geocentric translation of
/// (−8, 160, 176) m published for the contiguous United States, with a stated accuracy of 10 m.
///
/// Used for NAD27 because the NADCON grids PROJ would use are not available. GDAL 3.6 with PROJ
/// 9.1 and no grids picks the regional EPSG:1175 (−8, 159, 175; 7 m, CONUS west of the
/// Mississippi) for `byte.tif` in southern California: the two differ there by about 1.4 m
/// (measured in the dataset tests), well inside either one's stated accuracy. The NADCON grid
/// result is within a few metres of both in that area.
pub const NAD27_TO_WGS84_TOWGS84: &str = "-8,160,176";

/// What an image's coordinate reference system is, as reported by
/// [`GeoImage::crs`](super::GeoImage::crs) and in the `info()` JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrsInfo {
    /// `"EPSG:26711"` when the CRS is an EPSG code, `"user-defined"` otherwise.
    pub name: String,
    /// The EPSG code, when there is one.
    pub epsg: Option<u16>,
    /// Human-readable name, e.g. `"NAD27 / UTM zone 11N"` (from the EPSG definition, or the
    /// file's citation for a user-defined CRS).
    pub description: String,
    /// Whether model coordinates are longitude/latitude in degrees (else projected, metres or
    /// the CRS's linear unit).
    pub geographic: bool,
    /// The PROJ.4 definition actually used, after the datum handling of the module docs.
    pub proj_string: String,
    /// How coordinates reach WGS84: `"none: …"`, a Helmert with its parameters, or the
    /// assumption made when no relation to WGS84 is known.
    pub datum_shift: String,
}

/// A CRS ready to convert coordinates to and from WGS84.
#[derive(Debug, Clone)]
pub(crate) struct Crs {
    info: CrsInfo,
    proj: Proj,
    wgs84: Proj,
}

/// PROJ.4 definition of WGS84 longitude/latitude, the target of every conversion.
const WGS84_LONGLAT: &str = "+proj=longlat +datum=WGS84 +no_defs";

impl Crs {
    /// The CRS of an EPSG code, from the `crs-definitions` table. EPSG:3857 uses the table's
    /// `+proj=webmerc` variant (PROJ's own definition) rather than the proj4js-style
    /// `+proj=merc +nadgrids=@null` one; both give the same numbers for WGS84.
    ///
    /// # Errors
    /// [`GeoImageError::UnsupportedCrs`] when the code is not in the table or its definition
    /// is not usable (a missing grid without a Helmert fallback, a projection `proj4rs` lacks).
    pub(crate) fn from_epsg(code: u16) -> Result<Self, GeoImageError> {
        let def = if code == 3857 {
            crs_definitions::EPSG_3857_WEBMERC
        } else {
            crs_definitions::from_code(code).ok_or_else(|| {
                GeoImageError::UnsupportedCrs(format!("EPSG:{code} is not in the EPSG table"))
            })?
        };
        Self::from_proj_string(
            Some(code),
            wkt_name(def.wkt).unwrap_or("unnamed"),
            def.proj4,
        )
    }

    /// The PROJ.4 definition of EPSG geographic CRS `code` without its `+proj=longlat` and
    /// `+no_defs`, i.e. the ellipsoid and datum part, to combine with a projection.
    pub(crate) fn epsg_geographic_params(code: u16) -> Option<String> {
        let def = crs_definitions::from_code(code)?;
        let tokens: Vec<&str> = def.proj4.split_whitespace().collect();
        if !tokens.contains(&"+proj=longlat") {
            return None;
        }
        Some(
            tokens
                .into_iter()
                .filter(|t| *t != "+proj=longlat" && *t != "+no_defs")
                .collect::<Vec<_>>()
                .join(" "),
        )
    }

    /// Whether the WKT of EPSG CRS `code` names datum `datum_code` (used to check a datum
    /// code → geographic CRS guess).
    pub(crate) fn epsg_has_datum(code: u16, datum_code: u16) -> bool {
        crs_definitions::from_code(code).is_some_and(|def| {
            def.wkt
                .contains(&format!("AUTHORITY[\"EPSG\",\"{datum_code}\"]]"))
        })
    }

    /// A CRS from a PROJ.4 definition; `epsg` and `description` are reported as given.
    ///
    /// # Errors
    /// [`GeoImageError::UnsupportedCrs`] when the definition needs a grid file and gives no
    /// Helmert fallback, or `proj4rs` rejects it.
    pub(crate) fn from_proj_string(
        epsg: Option<u16>,
        description: &str,
        proj_string: &str,
    ) -> Result<Self, GeoImageError> {
        let (proj_string, datum_shift) = resolve_datum(proj_string)?;
        let unsupported = |e: proj4rs::errors::Error| {
            GeoImageError::UnsupportedCrs(format!("{proj_string}: {e}"))
        };
        let proj = Proj::from_proj_string(&proj_string).map_err(unsupported)?;
        let wgs84 = Proj::from_proj_string(WGS84_LONGLAT).map_err(unsupported)?;
        let info = CrsInfo {
            name: epsg.map_or_else(|| "user-defined".to_string(), |c| format!("EPSG:{c}")),
            epsg,
            description: description.to_string(),
            geographic: proj.is_latlong(),
            proj_string,
            datum_shift,
        };
        Ok(Crs { info, proj, wgs84 })
    }

    /// What the CRS is.
    pub(crate) fn info(&self) -> &CrsInfo {
        &self.info
    }

    /// Length of the CRS's linear unit in metres (1 for metric projected CRSs).
    pub(crate) fn linear_unit_m(&self) -> f64 {
        self.proj.to_meter()
    }

    /// WGS84 `[lon_deg, lat_deg]` of model coordinates `(x, y)` in this CRS (degrees when the
    /// CRS is geographic).
    pub(crate) fn model_to_wgs84(&self, x: f64, y: f64) -> Result<[f64; 2], GeoImageError> {
        let mut p = if self.info.geographic {
            (x.to_radians(), y.to_radians(), 0.0)
        } else {
            (x, y, 0.0)
        };
        proj4rs::transform::transform(&self.proj, &self.wgs84, &mut p).map_err(|e| {
            GeoImageError::Projection {
                x,
                y,
                message: e.to_string(),
            }
        })?;
        finite([p.0.to_degrees(), p.1.to_degrees()], x, y)
    }

    /// Model coordinates `[x, y]` in this CRS of WGS84 `(lon_deg, lat_deg)`.
    pub(crate) fn wgs84_to_model(
        &self,
        lon_deg: f64,
        lat_deg: f64,
    ) -> Result<[f64; 2], GeoImageError> {
        let mut p = (lon_deg.to_radians(), lat_deg.to_radians(), 0.0);
        proj4rs::transform::transform(&self.wgs84, &self.proj, &mut p).map_err(|e| {
            GeoImageError::Projection {
                x: lon_deg,
                y: lat_deg,
                message: e.to_string(),
            }
        })?;
        if self.info.geographic {
            finite([p.0.to_degrees(), p.1.to_degrees()], lon_deg, lat_deg)
        } else {
            finite([p.0, p.1], lon_deg, lat_deg)
        }
    }
}

/// Rejects a NaN or infinite conversion result (points outside a projection's domain).
fn finite(v: [f64; 2], x: f64, y: f64) -> Result<[f64; 2], GeoImageError> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(v)
    } else {
        Err(GeoImageError::Projection {
            x,
            y,
            message: "result is not finite".into(),
        })
    }
}

/// The first quoted string of a WKT, i.e. the CRS name of `PROJCS["name", …]`.
pub(crate) fn wkt_name(wkt: &str) -> Option<&str> {
    let start = wkt.find('"')? + 1;
    let len = wkt[start..].find('"')?;
    Some(&wkt[start..start + len])
}

/// Applies the datum rules of the module docs to a PROJ.4 definition; returns the definition
/// to use and a description of the shift to WGS84.
fn resolve_datum(proj_string: &str) -> Result<(String, String), GeoImageError> {
    let mut tokens: Vec<String> = proj_string.split_whitespace().map(str::to_string).collect();
    let value = |tokens: &[String], key: &str| {
        let prefix = format!("+{key}=");
        tokens
            .iter()
            .find_map(|t| t.strip_prefix(&prefix).map(str::to_string))
    };
    let datum = value(&tokens, "datum");
    let towgs84 = value(&tokens, "towgs84");
    let nadgrids = value(&tokens, "nadgrids");
    let ellps = value(&tokens, "ellps");

    if datum
        .as_deref()
        .is_some_and(|d| d.eq_ignore_ascii_case("NAD27"))
    {
        tokens.retain(|t| !t.starts_with("+datum=") && !t.starts_with("+nadgrids="));
        tokens.push("+ellps=clrk66".into());
        tokens.push(format!("+towgs84={NAD27_TO_WGS84_TOWGS84}"));
        let shift = format!(
            "Helmert +towgs84={NAD27_TO_WGS84_TOWGS84} (EPSG:1173 NAD27 to WGS 84 (4), CONUS, \
             about 10 m; NADCON grids not available)"
        );
        return Ok((tokens.join(" "), shift));
    }
    if let Some(grids) = nadgrids.as_deref().filter(|g| *g != "@null") {
        let Some(params) = &towgs84 else {
            return Err(GeoImageError::UnsupportedCrs(format!(
                "{proj_string}: needs the datum grid {grids}, which is not available"
            )));
        };
        tokens.retain(|t| !t.starts_with("+nadgrids="));
        let shift = format!("Helmert +towgs84={params} (grid {grids} not available)");
        return Ok((tokens.join(" "), shift));
    }
    let shift = if nadgrids.is_some() {
        "none: the CRS is defined directly on WGS 84 (+nadgrids=@null)".to_string()
    } else if let Some(params) = towgs84 {
        if params
            .split(',')
            .all(|p| p.trim().parse::<f64>().is_ok_and(|v| v == 0.0))
        {
            "none: +towgs84=0,0,0, the datum is WGS 84 or taken as identical to it (NAD83 and \
             ETRS89 differ from WGS 84 by about 1-2 m)"
                .to_string()
        } else {
            format!("Helmert +towgs84={params}")
        }
    } else if let Some(d) = datum {
        match d.to_ascii_uppercase().as_str() {
            "WGS84" => "none: WGS 84".to_string(),
            "NAD83" => "none: NAD83 is taken as identical to WGS 84 (they differ by about 1-2 m)"
                .to_string(),
            _ => format!("proj4rs's built-in shift for +datum={d}"),
        }
    } else if ellps
        .as_deref()
        .is_some_and(|e| e == "WGS84" || e == "GRS80")
    {
        "none: unnamed datum on the WGS 84 / GRS 1980 ellipsoid, taken as WGS 84".to_string()
    } else {
        "unknown: no relation to WGS 84 is given; coordinates are used as if on WGS 84 \
         (errors up to hundreds of metres)"
            .to_string()
    };
    Ok((tokens.join(" "), shift))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 2], b: [f64; 2], tol: f64) -> bool {
        (a[0] - b[0]).abs() < tol && (a[1] - b[1]).abs() < tol
    }

    #[test]
    fn utm_round_trip_and_known_point() {
        let crs = Crs::from_epsg(32618).unwrap();
        assert_eq!(crs.info().name, "EPSG:32618");
        assert_eq!(crs.info().description, "WGS 84 / UTM zone 18N");
        // Central meridian of zone 18 at the equator: easting 500000, northing 0.
        assert!(close(
            crs.model_to_wgs84(500_000.0, 0.0).unwrap(),
            [-75.0, 0.0],
            1e-9
        ));
        let xy = crs.wgs84_to_model(-77.5, 24.5).unwrap();
        assert!(close(
            crs.model_to_wgs84(xy[0], xy[1]).unwrap(),
            [-77.5, 24.5],
            1e-9
        ));
    }

    #[test]
    fn nad27_gets_a_helmert_shift_not_silently_none() {
        let crs = Crs::from_epsg(26711).unwrap();
        assert!(
            crs.info().proj_string.contains("+towgs84=-8,160,176"),
            "{:?}",
            crs.info()
        );
        assert!(crs.info().datum_shift.contains("EPSG:1173"));
        // Without the shift the longitude would be -117.64117 (NAD27 itself), 80 m east.
        let [lon, _] = crs.model_to_wgs84(440_720.0, 3_751_320.0).unwrap();
        assert!((lon - -117.64205).abs() < 2e-5, "{lon}");
    }

    #[test]
    fn geographic_crs_uses_degrees() {
        let crs = Crs::from_epsg(4326).unwrap();
        assert!(crs.info().geographic);
        assert!(close(
            crs.model_to_wgs84(12.5, -33.0).unwrap(),
            [12.5, -33.0],
            1e-12
        ));
        assert!(close(
            crs.wgs84_to_model(12.5, -33.0).unwrap(),
            [12.5, -33.0],
            1e-12
        ));
    }

    #[test]
    fn web_mercator_matches_the_spherical_formula() {
        let crs = Crs::from_epsg(3857).unwrap();
        let r = 6_378_137.0_f64;
        let (lon, lat) = (-78.9586500_f64, 25.5334746_f64);
        let y = r
            * (std::f64::consts::FRAC_PI_4 + lat.to_radians() / 2.0)
                .tan()
                .ln();
        let xy = crs.wgs84_to_model(lon, lat).unwrap();
        assert!(close(xy, [r * lon.to_radians(), y], 1e-6), "{xy:?}");
    }

    #[test]
    fn a_required_missing_grid_is_an_error() {
        let err = Crs::from_proj_string(None, "x", "+proj=longlat +ellps=intl +nadgrids=foo.gsb");
        assert!(matches!(err, Err(GeoImageError::UnsupportedCrs(_))));
    }

    #[test]
    fn unknown_code_is_an_error() {
        assert!(matches!(
            Crs::from_epsg(1),
            Err(GeoImageError::UnsupportedCrs(_))
        ));
    }
}
