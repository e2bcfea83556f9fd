//! The trajectory and landmarks as a KML 2.2 document in WGS84, written with the georust `kml`
//! crate.
//!
//! Layout: `<kml xmlns="http://www.opengis.net/kml/2.2"><Document>` holding
//!
//! * a `Placemark` named `trajectory` with a `LineString` (clamped to the ground, tessellated),
//!   or a `Point` for a one-pose trajectory (a `LineString` needs two coordinates), and no
//!   placemark for an empty one;
//! * one `Placemark` per landmark, named `landmark <id>` (or `landmark`), with a `Point` and,
//!   when known, `ExtendedData` entries `id` and `diameter_m`.
//!
//! Coordinates are `lon,lat` in degrees without altitude, converted from the `enu` frame by
//! [`LocalFrame::to_lon_lat_deg`] and written with the shortest text that reads back to the same
//! `f64`.

use std::collections::HashMap;
use std::io::Write;

use kml::types::{AltitudeMode, Coord, Element, Geometry, LineString, Placemark, Point};
use kml::{Kml, KmlDocument, KmlVersion, KmlWriter};

use super::{GeoRefError, LandmarkInEnu, LocalFrame};

/// Namespace of KML 2.2 (OGC 07-147r2).
const KML_22_NAMESPACE: &str = "http://www.opengis.net/kml/2.2";

/// Builds the KML document of `trajectory_in_enu_m` (`[east_m, north_m]` per pose, in order)
/// and `landmarks`, converted to WGS84 through `frame`.
///
/// # Errors
///
/// [`GeoRefError::NonFinite`] for a NaN or infinite position, [`GeoRefError::InvalidDiameter`]
/// for a NaN, infinite or negative landmark diameter.
pub fn kml_document(
    frame: &LocalFrame,
    trajectory_in_enu_m: &[[f64; 2]],
    landmarks: &[LandmarkInEnu],
) -> Result<Kml, GeoRefError> {
    let mut placemarks = Vec::with_capacity(landmarks.len() + 1);
    let trajectory_coords = trajectory_in_enu_m
        .iter()
        .map(|&point_in_enu_m| lon_lat_coord(frame, point_in_enu_m))
        .collect::<Result<Vec<_>, _>>()?;
    let trajectory_geometry = match trajectory_coords.as_slice() {
        [] => None,
        [single] => Some(Geometry::Point(ground_point(*single))),
        _ => Some(Geometry::LineString(LineString {
            coords: trajectory_coords,
            tessellate: true,
            altitude_mode: AltitudeMode::ClampToGround,
            ..LineString::default()
        })),
    };
    if let Some(geometry) = trajectory_geometry {
        placemarks.push(Kml::Placemark(Placemark {
            name: Some("trajectory".to_owned()),
            geometry: Some(geometry),
            ..Placemark::default()
        }));
    }
    for landmark in landmarks {
        landmark.check_diameter()?;
        let coord = lon_lat_coord(frame, landmark.position_in_enu_m)?;
        let name = match landmark.id {
            Some(id) => format!("landmark {id}"),
            None => "landmark".to_owned(),
        };
        let mut data = Vec::new();
        if let Some(id) = landmark.id {
            data.push(data_element("id", id.to_string()));
        }
        if let Some(diameter_m) = landmark.diameter_m {
            data.push(data_element("diameter_m", diameter_m.to_string()));
        }
        let children = if data.is_empty() {
            Vec::new()
        } else {
            vec![Element {
                name: "ExtendedData".to_owned(),
                children: data,
                ..Element::default()
            }]
        };
        placemarks.push(Kml::Placemark(Placemark {
            name: Some(name),
            geometry: Some(Geometry::Point(ground_point(coord))),
            children,
            ..Placemark::default()
        }));
    }
    Ok(Kml::KmlDocument(KmlDocument {
        version: KmlVersion::V22,
        attrs: HashMap::from([("xmlns".to_owned(), KML_22_NAMESPACE.to_owned())]),
        elements: vec![Kml::Document {
            attrs: HashMap::new(),
            elements: placemarks,
        }],
    }))
}

/// Writes `trajectory_in_enu_m` and `landmarks` to `w` as a KML document in WGS84 (see the
/// module documentation for the layout), then flushes `w`.
///
/// # Errors
///
/// As [`kml_document`], plus [`GeoRefError::Io`] / [`GeoRefError::Kml`] when writing to `w`
/// fails. Nothing is written if the input is rejected.
pub fn write_kml<W: Write>(
    mut w: W,
    frame: &LocalFrame,
    trajectory_in_enu_m: &[[f64; 2]],
    landmarks: &[LandmarkInEnu],
) -> Result<(), GeoRefError> {
    let document = kml_document(frame, trajectory_in_enu_m, landmarks)?;
    w.write_all(b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n")?;
    KmlWriter::<_, f64>::from_writer(&mut w).write(&document)?;
    w.write_all(b"\n")?;
    w.flush()?;
    Ok(())
}

/// The KML coordinate (`lon,lat`) of a planar ENU point.
fn lon_lat_coord(frame: &LocalFrame, point_in_enu_m: [f64; 2]) -> Result<Coord, GeoRefError> {
    let [lon_deg, lat_deg] = frame.to_lon_lat_deg(point_in_enu_m)?;
    Ok(Coord::new(lon_deg, lat_deg, None))
}

/// A point on the ground at `coord`.
fn ground_point(coord: Coord) -> Point {
    Point {
        coord,
        altitude_mode: AltitudeMode::ClampToGround,
        ..Point::default()
    }
}

/// `<Data name="…"><value>…</value></Data>` of `ExtendedData`.
fn data_element(name: &str, value: String) -> Element {
    Element {
        name: "Data".to_owned(),
        attrs: HashMap::from([("name".to_owned(), name.to_owned())]),
        children: vec![Element {
            name: "value".to_owned(),
            content: Some(value),
            ..Element::default()
        }],
        ..Element::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kml::KmlReader;

    fn frame() -> LocalFrame {
        LocalFrame::new(-33.9, 151.2, 20.0).unwrap()
    }

    fn trajectory() -> Vec<[f64; 2]> {
        (0..40)
            .map(|i| {
                let a = f64::from(i) * 0.15;
                [250.0 * a.cos(), 180.0 * a.sin()]
            })
            .collect()
    }

    fn landmarks() -> Vec<LandmarkInEnu> {
        vec![
            LandmarkInEnu {
                id: Some(3),
                position_in_enu_m: [10.0, 20.0],
                diameter_m: Some(0.3),
            },
            LandmarkInEnu {
                id: None,
                position_in_enu_m: [-800.0, 1200.0],
                diameter_m: None,
            },
        ]
    }

    /// The placemarks of a parsed `<kml><Document>…`.
    fn placemarks(kml: Kml) -> Vec<Placemark> {
        let Kml::KmlDocument(document) = kml else {
            panic!("not a KML document: {kml:?}");
        };
        assert_eq!(document.version, KmlVersion::V22);
        document
            .elements
            .into_iter()
            .flat_map(|element| match element {
                Kml::Document { elements, .. } => elements,
                other => panic!("expected a Document: {other:?}"),
            })
            .map(|element| match element {
                Kml::Placemark(placemark) => placemark,
                other => panic!("expected a Placemark: {other:?}"),
            })
            .collect()
    }

    fn assert_coord_close(coord: &Coord, expected_lon_lat_deg: [f64; 2]) {
        assert!(
            (coord.x - expected_lon_lat_deg[0]).abs() < 1e-7,
            "{coord:?}"
        );
        assert!(
            (coord.y - expected_lon_lat_deg[1]).abs() < 1e-7,
            "{coord:?}"
        );
        assert_eq!(coord.z, None);
    }

    /// `(name, value)` of each `Data` under the placemark's `ExtendedData`.
    fn extended_data(placemark: &Placemark) -> Vec<(String, String)> {
        placemark
            .children
            .iter()
            .filter(|child| child.name == "ExtendedData")
            .flat_map(|extended| extended.children.iter())
            .map(|data| {
                let value = data
                    .children
                    .iter()
                    .find(|child| child.name == "value")
                    .and_then(|value| value.content.clone())
                    .unwrap_or_default();
                (data.attrs["name"].clone(), value)
            })
            .collect()
    }

    #[test]
    fn test_round_trip_through_kml() {
        let mut bytes = Vec::new();
        write_kml(&mut bytes, &frame(), &trajectory(), &landmarks()).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        assert!(text.starts_with("<?xml"));
        let kml = KmlReader::<_, f64>::from_string(&text).read().unwrap();
        let placemarks = placemarks(kml);
        assert_eq!(placemarks.len(), 3);

        assert_eq!(placemarks[0].name.as_deref(), Some("trajectory"));
        let Some(Geometry::LineString(line)) = &placemarks[0].geometry else {
            panic!("trajectory is not a LineString: {:?}", placemarks[0]);
        };
        assert_eq!(line.coords.len(), trajectory().len());
        for (coord, point_in_enu_m) in line.coords.iter().zip(trajectory()) {
            assert_coord_close(coord, frame().to_lon_lat_deg(point_in_enu_m).unwrap());
        }

        for (placemark, landmark) in placemarks[1..].iter().zip(landmarks()) {
            let Some(Geometry::Point(point)) = &placemark.geometry else {
                panic!("landmark is not a Point: {placemark:?}");
            };
            assert_coord_close(
                &point.coord,
                frame().to_lon_lat_deg(landmark.position_in_enu_m).unwrap(),
            );
            let data = extended_data(placemark);
            let value = |key: &str| {
                data.iter()
                    .find(|(name, _)| name == key)
                    .map(|(_, value)| value.clone())
            };
            assert_eq!(value("id"), landmark.id.map(|id| id.to_string()));
            assert_eq!(
                value("diameter_m").map(|text| text.parse::<f64>().unwrap()),
                landmark.diameter_m
            );
        }
        assert_eq!(placemarks[1].name.as_deref(), Some("landmark 3"));
    }

    #[test]
    fn test_short_trajectories() {
        let single = placemarks(kml_document(&frame(), &[[5.0, 5.0]], &[]).unwrap());
        assert!(matches!(single[0].geometry, Some(Geometry::Point(_))));
        assert!(placemarks(kml_document(&frame(), &[], &[]).unwrap()).is_empty());
    }

    #[test]
    fn test_rejects_bad_input_and_writes_nothing() {
        let mut bytes = Vec::new();
        let result = write_kml(&mut bytes, &frame(), &[[f64::INFINITY, 0.0]], &[]);
        assert!(matches!(result, Err(GeoRefError::NonFinite(_))));
        let bad_landmark = LandmarkInEnu {
            id: None,
            position_in_enu_m: [0.0, 0.0],
            diameter_m: Some(f64::NAN),
        };
        let result = write_kml(&mut bytes, &frame(), &[], &[bad_landmark]);
        assert!(matches!(result, Err(GeoRefError::InvalidDiameter { .. })));
        assert!(bytes.is_empty());
    }
}
