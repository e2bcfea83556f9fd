//! The CRS of a WKT string, as found in a `.prj` file or a GDAL `.aux.xml` `<SRS>` element.
//!
//! In order:
//! 1. the root's own `AUTHORITY["EPSG","code"]` (WKT1) or `ID["EPSG",code]` (WKT2) → the EPSG
//!    table;
//! 2. a few ESRI names that stand for EPSG codes but carry no authority (ESRI writes
//!    `WGS_1984_Web_Mercator_Auxiliary_Sphere` for EPSG:3857, `WGS_1984_UTM_Zone_18N` for
//!    EPSG:32618, …);
//! 3. otherwise the WKT is converted to a PROJ.4 definition by the `proj4wkt` crate and reported
//!    as user-defined with the WKT's name.

use super::GeoImageError;
use super::crs::{Crs, wkt_name};

/// The CRS of `wkt`.
///
/// # Errors
/// [`GeoImageError::UnsupportedCrs`] when the WKT names no known EPSG code and `proj4wkt`
/// cannot convert it.
pub(crate) fn crs_from_wkt(wkt: &str) -> Result<Crs, GeoImageError> {
    let wkt = wkt.trim();
    if let Some(code) = root_epsg_code(wkt) {
        return Crs::from_epsg(code);
    }
    let name = wkt_name(wkt).unwrap_or("unnamed");
    if let Some(code) = esri_name_to_epsg(name) {
        return Crs::from_epsg(code);
    }
    let proj = proj4wkt::wkt_to_projstring(wkt)
        .map_err(|e| GeoImageError::UnsupportedCrs(format!("WKT {name:?}: {e}")))?;
    Crs::from_proj_string(None, name, &proj)
}

/// The EPSG code in the root element's own AUTHORITY/ID (depth 1), not in a nested one.
fn root_epsg_code(wkt: &str) -> Option<u16> {
    let bytes = wkt.as_bytes();
    let mut depth = 0usize;
    let mut in_quotes = false;
    let mut word_start = 0usize;
    for (i, &b) in bytes.iter().enumerate() {
        match b {
            b'"' => in_quotes = !in_quotes,
            _ if in_quotes => {}
            b'[' | b'(' => {
                let word = wkt[word_start..i].trim();
                if depth == 1 && (word == "AUTHORITY" || word == "ID") {
                    let end = wkt[i + 1..].find([']', ')'])? + i + 1;
                    return parse_authority(&wkt[i + 1..end]);
                }
                depth += 1;
                word_start = i + 1;
            }
            b']' | b')' => {
                depth = depth.saturating_sub(1);
                word_start = i + 1;
            }
            b',' => word_start = i + 1,
            _ => {}
        }
    }
    None
}

/// `"EPSG","3857"` or `"EPSG",3857` → 3857.
fn parse_authority(body: &str) -> Option<u16> {
    let (authority, code) = body.split_once(',')?;
    if !authority
        .trim()
        .trim_matches('"')
        .eq_ignore_ascii_case("EPSG")
    {
        return None;
    }
    code.split(',')
        .next()?
        .trim()
        .trim_matches('"')
        .parse()
        .ok()
}

/// EPSG codes of ESRI CRS names that carry no authority in ESRI WKT.
fn esri_name_to_epsg(name: &str) -> Option<u16> {
    match name {
        "WGS_1984_Web_Mercator_Auxiliary_Sphere" | "WGS_1984_Web_Mercator" => return Some(3857),
        "GCS_WGS_1984" => return Some(4326),
        "GCS_North_American_1983" => return Some(4269),
        "GCS_North_American_1927" => return Some(4267),
        "ETRS_1989_LAEA" => return Some(3035),
        _ => {}
    }
    let utm = |prefix: &str| -> Option<(u16, bool)> {
        let rest = name.strip_prefix(prefix)?;
        let (zone, hemisphere) = rest.split_at(rest.len().checked_sub(1)?);
        let zone: u16 = zone.parse().ok().filter(|z| (1..=60).contains(z))?;
        match hemisphere {
            "N" => Some((zone, true)),
            "S" => Some((zone, false)),
            _ => None,
        }
    };
    match (
        utm("WGS_1984_UTM_Zone_"),
        utm("NAD_1983_UTM_Zone_"),
        utm("NAD_1927_UTM_Zone_"),
    ) {
        (Some((zone, true)), _, _) => Some(32600 + zone),
        (Some((zone, false)), _, _) => Some(32700 + zone),
        (_, Some((zone, true)), _) => Some(26900 + zone),
        (_, _, Some((zone, true))) => Some(26700 + zone),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ESRI_WEB_MERCATOR: &str = r#"PROJCS["WGS_1984_Web_Mercator_Auxiliary_Sphere",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Mercator_Auxiliary_Sphere"],PARAMETER["False_Easting",0.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",0.0],PARAMETER["Standard_Parallel_1",0.0],PARAMETER["Auxiliary_Sphere_Type",0.0],UNIT["Meter",1.0]]"#;

    #[test]
    fn esri_web_mercator_is_epsg_3857() {
        let crs = crs_from_wkt(ESRI_WEB_MERCATOR).unwrap();
        assert_eq!(crs.info().name, "EPSG:3857");
    }

    #[test]
    fn root_authority_wins_over_nested_ones() {
        let wkt = crs_definitions::EPSG_26711.wkt;
        assert_eq!(root_epsg_code(wkt), Some(26711));
        // A GEOGCS alone reports its own code, not its datum's or ellipsoid's.
        assert_eq!(root_epsg_code(crs_definitions::EPSG_4326.wkt), Some(4326));
        assert_eq!(
            root_epsg_code(r#"GEOGCS["x",DATUM["d",AUTHORITY["EPSG","6326"]]]"#),
            None
        );
    }

    #[test]
    fn esri_utm_names() {
        assert_eq!(esri_name_to_epsg("WGS_1984_UTM_Zone_18N"), Some(32618));
        assert_eq!(esri_name_to_epsg("WGS_1984_UTM_Zone_33S"), Some(32733));
        assert_eq!(esri_name_to_epsg("NAD_1927_UTM_Zone_11N"), Some(26711));
        assert_eq!(esri_name_to_epsg("WGS_1984_UTM_Zone_61N"), None);
    }

    #[test]
    fn unnamed_wkt_goes_through_proj4wkt() {
        // The same Web Mercator under a name the table does not know.
        let wkt = ESRI_WEB_MERCATOR.replace("WGS_1984_Web_Mercator_Auxiliary_Sphere", "My map");
        let crs = crs_from_wkt(&wkt).unwrap();
        assert_eq!(crs.info().epsg, None);
        assert_eq!(crs.info().description, "My map");
        let reference = Crs::from_epsg(3857).unwrap();
        let got = crs.model_to_wgs84(8_882_593.552, 744_161.253).unwrap();
        let want = reference
            .model_to_wgs84(8_882_593.552, 744_161.253)
            .unwrap();
        assert!((got[0] - want[0]).abs() < 1e-9 && (got[1] - want[1]).abs() < 1e-9);
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(crs_from_wkt("not a wkt").is_err());
    }
}
