//! GDAL PAM sidecar files (`image.png.aux.xml`): the `<SRS>` WKT and, when present, the
//! `<GeoTransform>` (six comma-separated numbers in GDAL geotransform order) of the
//! `<PAMDataset>` root. Everything else in the file (metadata, statistics) is ignored.

use std::path::{Path, PathBuf};

use quick_xml::Reader;
use quick_xml::events::Event;

use super::GeoImageError;
use super::geo_transform::GeoTransform;

/// What a PAM sidecar says about geo-referencing.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct AuxXml {
    /// The `<SRS>` text (a WKT), entities resolved.
    pub srs_wkt: Option<String>,
    /// The `<GeoTransform>`, if present.
    pub geo_transform: Option<GeoTransform>,
}

/// `image` with `.aux.xml` appended (GDAL's naming: `map.png` → `map.png.aux.xml`).
pub(crate) fn aux_xml_path(image: &Path) -> PathBuf {
    let mut name = image.as_os_str().to_owned();
    name.push(".aux.xml");
    PathBuf::from(name)
}

/// Reads and parses the PAM file at `path`.
///
/// # Errors
/// [`GeoImageError::Io`] if unreadable, [`GeoImageError::Malformed`] if not well-formed XML or
/// the GeoTransform is not six numbers.
pub(crate) fn read_aux_xml(path: &Path) -> Result<AuxXml, GeoImageError> {
    let text = std::fs::read_to_string(path).map_err(|source| GeoImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_aux_xml(&text).map_err(|message| GeoImageError::Malformed {
        path: path.to_path_buf(),
        message,
    })
}

/// Parses PAM XML text (see the module docs).
pub(crate) fn parse_aux_xml(text: &str) -> Result<AuxXml, String> {
    let mut reader = Reader::from_str(text);
    // Element names from the root down to the current element.
    let mut path: Vec<String> = Vec::new();
    let mut srs = None::<String>;
    let mut geo_transform = None::<String>;
    loop {
        let event = reader
            .read_event()
            .map_err(|e| format!("XML error at byte {}: {e}", reader.buffer_position()))?;
        // The text sink for the element we are in, if it is one we want.
        let in_wanted = |path: &[String]| match path {
            [root, leaf] if root == "PAMDataset" && leaf == "SRS" => Some(0),
            [root, leaf] if root == "PAMDataset" && leaf == "GeoTransform" => Some(1),
            _ => None,
        };
        let mut push_text = |path: &[String], s: &str| match in_wanted(path) {
            Some(0) => srs.get_or_insert_with(String::new).push_str(s),
            Some(_) => geo_transform.get_or_insert_with(String::new).push_str(s),
            None => {}
        };
        match event {
            Event::Start(e) => {
                path.push(String::from_utf8_lossy(e.local_name().as_ref()).into_owned());
            }
            Event::End(_) => {
                path.pop();
            }
            Event::Text(t) => {
                let s = t.decode().map_err(|e| format!("XML text: {e}"))?;
                push_text(&path, &s);
            }
            Event::CData(t) => {
                let s = t.decode().map_err(|e| format!("XML CDATA: {e}"))?;
                push_text(&path, &s);
            }
            Event::GeneralRef(r) => {
                let resolved = match r.resolve_char_ref().map_err(|e| e.to_string())? {
                    Some(c) => c.to_string(),
                    None => {
                        let name = r.decode().map_err(|e| format!("XML entity: {e}"))?;
                        quick_xml::escape::resolve_predefined_entity(&name)
                            .ok_or_else(|| format!("unknown XML entity &{name};"))?
                            .to_string()
                    }
                };
                push_text(&path, &resolved);
            }
            Event::Eof => break,
            _ => {}
        }
    }
    let geo_transform = match geo_transform {
        None => None,
        Some(text) => {
            let values: Vec<f64> = text
                .split(',')
                .map(|v| v.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("GeoTransform {:?} is not six numbers", text.trim()))?;
            let six: [f64; 6] = values
                .try_into()
                .map_err(|_| format!("GeoTransform {:?} is not six numbers", text.trim()))?;
            Some(GeoTransform(six))
        }
    };
    Ok(AuxXml {
        srs_wkt: srs.map(|s| s.trim().to_string()),
        geo_transform,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_srs_with_entities_and_geotransform() {
        let xml = r#"<PAMDataset>
  <SRS dataAxisToSRSAxisMapping="1,2">GEOGCS[&quot;WGS 84&quot;,AUTHORITY["EPSG","4326"]]</SRS>
  <GeoTransform>  1.0e+01,  2.0,  0.0,  5.0e+01,  0.0, -2.0</GeoTransform>
  <Metadata><MDI key="x">y</MDI></Metadata>
</PAMDataset>"#;
        let aux = parse_aux_xml(xml).unwrap();
        assert_eq!(
            aux.srs_wkt.as_deref(),
            Some(r#"GEOGCS["WGS 84",AUTHORITY["EPSG","4326"]]"#)
        );
        assert_eq!(
            aux.geo_transform,
            Some(GeoTransform([10.0, 2.0, 0.0, 50.0, 0.0, -2.0]))
        );
    }

    #[test]
    fn nested_srs_elsewhere_is_ignored_and_bad_input_is_an_error() {
        let xml = "<PAMDataset><PAMRasterBand><SRS>x</SRS></PAMRasterBand></PAMDataset>";
        assert_eq!(parse_aux_xml(xml).unwrap(), AuxXml::default());
        assert!(
            parse_aux_xml("<PAMDataset><GeoTransform>1,2</GeoTransform></PAMDataset>").is_err()
        );
        assert!(parse_aux_xml("<PAMDataset><SRS>x</PAMDataset>").is_err());
    }
}
