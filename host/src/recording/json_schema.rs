//! JSON schemas in the form Foxglove reads them.

use schemars::JsonSchema;
use schemars::generate::SchemaSettings;

/// The JSON schema (draft 07) of `T`, serialised, with every definition inlined: Foxglove does
/// not follow `$ref`s to definitions.
pub fn json_schema_of<T: JsonSchema>() -> Vec<u8> {
    let generator = SchemaSettings::draft07()
        .with(|settings| settings.inline_subschemas = true)
        .into_generator();
    let schema = generator.into_root_schema_for::<T>();
    // A schema is a JSON value with string keys: serialising it cannot fail.
    serde_json::to_vec(&schema).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schema_is_inlined_and_names_fields() {
        let schema: serde_json::Value =
            serde_json::from_slice(&json_schema_of::<protocol::GpsFixMsg>()).unwrap();
        let text = schema.to_string();
        assert!(!text.contains("$ref"), "{text}");
        let position = &schema["properties"]["position"];
        assert!(text.contains("lat_ndeg"), "{position}");
        assert_eq!(schema["properties"]["stamp_us"]["type"], "integer");
    }
}
