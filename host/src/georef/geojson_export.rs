//! The trajectory and landmarks as a GeoJSON FeatureCollection in WGS84 (RFC 7946), written with
//! the georust `geojson` crate.
//!
//! Layout of the collection:
//!
//! * the trajectory as one `LineString` feature with properties `{"kind": "trajectory"}`, or a
//!   `Point` feature for a one-pose trajectory (a `LineString` needs two positions, RFC 7946
//!   §3.1.4), and no feature for an empty one;
//! * each landmark as a `Point` feature with properties `{"kind": "landmark", "id": …,
//!   "diameter_m": …}` (`null` when unknown) and, when it has one, the feature `id`.
//!
//! Positions are `[lon_deg, lat_deg]` without altitude (RFC 7946 §3.1.1), converted from the
//! `enu` frame by [`LocalFrame::to_lon_lat_deg`]. Numbers are written with the shortest text
//! that reads back to the same `f64`, so parsing returns the converted values exactly.

use std::io::Write;

use geojson::{Feature, FeatureCollection, Geometry, JsonObject, JsonValue, feature::Id};

use super::{GeoRefError, LandmarkInEnu, LocalFrame};

/// Builds the FeatureCollection of `trajectory_in_enu_m` (`[east_m, north_m]` per pose, in
/// order) and `landmarks`, converted to WGS84 through `frame`.
///
/// # Errors
///
/// [`GeoRefError::NonFinite`] for a NaN or infinite position, [`GeoRefError::InvalidDiameter`]
/// for a NaN, infinite or negative landmark diameter.
pub fn feature_collection(
    frame: &LocalFrame,
    trajectory_in_enu_m: &[[f64; 2]],
    landmarks: &[LandmarkInEnu],
) -> Result<FeatureCollection, GeoRefError> {
    let mut features = Vec::with_capacity(landmarks.len() + 1);
    let trajectory_lon_lat_deg = trajectory_in_enu_m
        .iter()
        .map(|&point_in_enu_m| frame.to_lon_lat_deg(point_in_enu_m))
        .collect::<Result<Vec<_>, _>>()?;
    let trajectory_geometry = match trajectory_lon_lat_deg.as_slice() {
        [] => None,
        [single] => Some(Geometry::new_point(*single)),
        several => Some(Geometry::new_line_string(several.iter().copied())),
    };
    if let Some(geometry) = trajectory_geometry {
        let mut properties = JsonObject::new();
        properties.insert("kind".to_owned(), JsonValue::from("trajectory"));
        features.push(Feature {
            geometry: Some(geometry),
            properties: Some(properties),
            ..Feature::default()
        });
    }
    for landmark in landmarks {
        landmark.check_diameter()?;
        let lon_lat_deg = frame.to_lon_lat_deg(landmark.position_in_enu_m)?;
        let mut properties = JsonObject::new();
        properties.insert("kind".to_owned(), JsonValue::from("landmark"));
        properties.insert(
            "id".to_owned(),
            landmark.id.map_or(JsonValue::Null, JsonValue::from),
        );
        properties.insert(
            "diameter_m".to_owned(),
            landmark.diameter_m.map_or(JsonValue::Null, JsonValue::from),
        );
        features.push(Feature {
            geometry: Some(Geometry::new_point(lon_lat_deg)),
            id: landmark.id.map(|id| Id::Number(id.into())),
            properties: Some(properties),
            ..Feature::default()
        });
    }
    Ok(FeatureCollection::new(features))
}

/// Writes `trajectory_in_enu_m` and `landmarks` to `w` as a GeoJSON FeatureCollection in WGS84
/// (see the module documentation for the layout), then flushes `w`.
///
/// # Errors
///
/// As [`feature_collection`], plus [`GeoRefError::GeoJson`] / [`GeoRefError::Io`] when writing
/// to `w` fails. Nothing is written if the input is rejected.
pub fn write_geojson<W: Write>(
    mut w: W,
    frame: &LocalFrame,
    trajectory_in_enu_m: &[[f64; 2]],
    landmarks: &[LandmarkInEnu],
) -> Result<(), GeoRefError> {
    let collection = feature_collection(frame, trajectory_in_enu_m, landmarks)?;
    serde_json::to_writer(&mut w, &collection)?;
    w.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use geojson::{GeoJson, GeometryValue};

    fn frame() -> LocalFrame {
        LocalFrame::new(47.3, 8.5, 400.0).unwrap()
    }

    fn trajectory() -> Vec<[f64; 2]> {
        (0..50)
            .map(|i| {
                let s = f64::from(i) * 20.0;
                [s, 300.0 * (s / 400.0).sin()]
            })
            .collect()
    }

    fn landmarks() -> Vec<LandmarkInEnu> {
        vec![
            LandmarkInEnu {
                id: Some(7),
                position_in_enu_m: [120.0, -35.5],
                diameter_m: Some(0.42),
            },
            LandmarkInEnu {
                id: None,
                position_in_enu_m: [-2500.0, 4000.0],
                diameter_m: None,
            },
        ]
    }

    fn parse(bytes: &[u8]) -> FeatureCollection {
        let text = std::str::from_utf8(bytes).unwrap();
        match text.parse::<GeoJson>().unwrap() {
            GeoJson::FeatureCollection(collection) => collection,
            other => panic!("not a FeatureCollection: {other:?}"),
        }
    }

    fn assert_lon_lat_close(position: &[f64], expected_lon_lat_deg: [f64; 2]) {
        assert_eq!(position.len(), 2);
        assert!(
            (position[0] - expected_lon_lat_deg[0]).abs() < 1e-7,
            "{position:?}"
        );
        assert!(
            (position[1] - expected_lon_lat_deg[1]).abs() < 1e-7,
            "{position:?}"
        );
    }

    #[test]
    fn test_round_trip_through_geojson() {
        let mut bytes = Vec::new();
        write_geojson(&mut bytes, &frame(), &trajectory(), &landmarks()).unwrap();
        let collection = parse(&bytes);
        assert_eq!(collection.features.len(), 3);

        let line = &collection.features[0];
        assert_eq!(line.property("kind"), Some(&JsonValue::from("trajectory")));
        let Some(GeometryValue::LineString { coordinates }) =
            line.geometry.as_ref().map(|g| &g.value)
        else {
            panic!("trajectory is not a LineString: {line:?}");
        };
        assert_eq!(coordinates.len(), trajectory().len());
        let mut worst_m: f64 = 0.0;
        for (position, point_in_enu_m) in coordinates.iter().zip(trajectory()) {
            assert_lon_lat_close(
                position.as_slice(),
                frame().to_lon_lat_deg(point_in_enu_m).unwrap(),
            );
            // Back to the ENU frame: the 2D export loses only the curvature drop.
            let [east_m, north_m, _] = frame().to_enu_m(position[1], position[0], 400.0).unwrap();
            worst_m = worst_m.max((east_m - point_in_enu_m[0]).hypot(north_m - point_in_enu_m[1]));
        }
        assert!(worst_m < 1e-4, "{worst_m} m");

        for (feature, landmark) in collection.features[1..].iter().zip(landmarks()) {
            assert_eq!(feature.property("kind"), Some(&JsonValue::from("landmark")));
            let Some(GeometryValue::Point { coordinates }) =
                feature.geometry.as_ref().map(|g| &g.value)
            else {
                panic!("landmark is not a Point: {feature:?}");
            };
            assert_lon_lat_close(
                coordinates.as_slice(),
                frame().to_lon_lat_deg(landmark.position_in_enu_m).unwrap(),
            );
            assert_eq!(
                feature.property("id").and_then(JsonValue::as_u64),
                landmark.id
            );
            assert_eq!(
                feature.property("diameter_m").and_then(JsonValue::as_f64),
                landmark.diameter_m
            );
            assert_eq!(feature.id, landmark.id.map(|id| Id::Number(id.into())));
        }
    }

    #[test]
    fn test_short_trajectories() {
        let collection = feature_collection(&frame(), &[], &[]).unwrap();
        assert!(collection.features.is_empty());
        let collection = feature_collection(&frame(), &[[10.0, 20.0]], &[]).unwrap();
        assert!(matches!(
            collection.features[0].geometry.as_ref().map(|g| &g.value),
            Some(GeometryValue::Point { .. })
        ));
    }

    #[test]
    fn test_rejects_bad_input_and_writes_nothing() {
        let mut bytes = Vec::new();
        let result = write_geojson(&mut bytes, &frame(), &[[0.0, f64::NAN]], &[]);
        assert!(matches!(result, Err(GeoRefError::NonFinite(_))));
        let bad_landmark = LandmarkInEnu {
            id: Some(1),
            position_in_enu_m: [0.0, 0.0],
            diameter_m: Some(-0.1),
        };
        let result = write_geojson(&mut bytes, &frame(), &[], &[bad_landmark]);
        assert!(matches!(result, Err(GeoRefError::InvalidDiameter { .. })));
        assert!(bytes.is_empty());
    }
}
