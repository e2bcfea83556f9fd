//! Reading the body of `POST /api/goal` into a [`GoalRequest`].
//!
//! The body is a JSON object with either `pixel_x` and `pixel_y` (a pixel of the geo-referenced
//! image) or `lat_deg` and `lon_deg` (WGS84), all numbers. Other fields are ignored; a body with
//! both kinds of goal is refused as ambiguous.

use serde_json::Value;

use crate::GoalRequest;

/// Why a goal body could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum GoalBodyError {
    /// The body is not JSON at all.
    #[error("the goal is not valid JSON: {0}")]
    NotJson(String),
    /// The body is JSON, but not a goal.
    #[error(
        "the goal must be a JSON object {{\"pixel_x\": number, \"pixel_y\": number}} or \
         {{\"lat_deg\": number, \"lon_deg\": number}}; got {0}"
    )]
    NotAGoal(String),
    /// The body names both a pixel and a WGS84 position.
    #[error("the goal names both a pixel and a latitude/longitude: give one of them")]
    Ambiguous,
}

/// Parses `body` into a goal request.
///
/// # Errors
/// A body that is not JSON, not an object with one of the two pairs of number fields, or that
/// holds both pairs.
pub(crate) fn parse_goal_body(body: &[u8]) -> Result<GoalRequest, GoalBodyError> {
    let value: Value =
        serde_json::from_slice(body).map_err(|error| GoalBodyError::NotJson(error.to_string()))?;
    let Value::Object(fields) = &value else {
        return Err(GoalBodyError::NotAGoal(describe(&value)));
    };
    let has_pixel = fields.contains_key("pixel_x") || fields.contains_key("pixel_y");
    let has_geodetic = fields.contains_key("lat_deg") || fields.contains_key("lon_deg");
    if has_pixel && has_geodetic {
        return Err(GoalBodyError::Ambiguous);
    }
    serde_json::from_value(value.clone()).map_err(|_| GoalBodyError::NotAGoal(describe(&value)))
}

/// A short description of `value` for an error message: its fields, or its type.
fn describe(value: &Value) -> String {
    match value {
        Value::Object(fields) if fields.is_empty() => "an empty object".to_owned(),
        Value::Object(fields) => {
            let listed: Vec<String> = fields
                .iter()
                .map(|(name, field)| format!("{name}: {}", type_name(field)))
                .collect();
            format!("an object with {}", listed.join(", "))
        }
        other => type_name(other).to_owned(),
    }
}

/// The JSON type of `value`, in words.
fn type_name(value: &Value) -> &'static str {
    match value {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_pixel_goal() {
        let goal = parse_goal_body(br#"{"pixel_x": 12.5, "pixel_y": 40}"#).unwrap();
        assert_eq!(
            goal,
            GoalRequest::Pixel {
                pixel_x: 12.5,
                pixel_y: 40.0
            }
        );
    }

    #[test]
    fn test_geodetic_goal() {
        let goal = parse_goal_body(br#"{"lat_deg": 48.1, "lon_deg": 11.5}"#).unwrap();
        assert_eq!(
            goal,
            GoalRequest::Geodetic {
                lat_deg: 48.1,
                lon_deg: 11.5
            }
        );
    }

    #[test]
    fn test_not_json() {
        let error = parse_goal_body(b"pixel_x=3").unwrap_err();
        assert!(matches!(error, GoalBodyError::NotJson(_)), "{error:?}");
    }

    #[test]
    fn test_missing_field_names_what_was_given() {
        let error = parse_goal_body(br#"{"pixel_x": 3}"#).unwrap_err();
        assert_eq!(
            error,
            GoalBodyError::NotAGoal("an object with pixel_x: a number".to_owned())
        );
    }

    #[test]
    fn test_string_coordinates_are_refused() {
        let error = parse_goal_body(br#"{"pixel_x": "3", "pixel_y": 4}"#).unwrap_err();
        assert!(error.to_string().contains("pixel_x: a string"), "{error}");
    }

    #[test]
    fn test_array_is_refused() {
        let error = parse_goal_body(b"[1, 2]").unwrap_err();
        assert_eq!(error, GoalBodyError::NotAGoal("an array".to_owned()));
    }

    #[test]
    fn test_both_kinds_are_ambiguous() {
        let error = parse_goal_body(br#"{"pixel_x": 1, "pixel_y": 2, "lat_deg": 3, "lon_deg": 4}"#)
            .unwrap_err();
        assert_eq!(error, GoalBodyError::Ambiguous);
    }
}
