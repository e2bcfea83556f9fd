//! The GeoTIFF GeoKey directory (OGC GeoTIFF 1.1, §7.1): a table of keys stored in the
//! `GeoKeyDirectoryTag` SHORT array whose values live inline or in the `GeoDoubleParamsTag` /
//! `GeoAsciiParamsTag` arrays.
//!
//! The directory starts with a four-SHORT header `(version, revision, minor, key_count)`
//! followed by `key_count` entries `(key_id, tag_location, count, value_offset)`. A
//! `tag_location` of 0 means the value is `value_offset` itself; 34736 points into the
//! doubles, 34737 into the ASCII parameters (strings end with `|`), 34735 into the directory.

use std::collections::BTreeMap;

/// GeoKey ids used by this module (GeoTIFF 1.1 Annex, "GeoKey ID summary").
pub(crate) mod key {
    pub const GT_MODEL_TYPE: u16 = 1024;
    pub const GT_RASTER_TYPE: u16 = 1025;
    pub const GT_CITATION: u16 = 1026;
    pub const GEOGRAPHIC_TYPE: u16 = 2048;
    pub const GEOG_CITATION: u16 = 2049;
    pub const GEOG_GEODETIC_DATUM: u16 = 2050;
    pub const GEOG_PRIME_MERIDIAN: u16 = 2051;
    pub const GEOG_ANGULAR_UNITS: u16 = 2054;
    pub const GEOG_ELLIPSOID: u16 = 2056;
    pub const GEOG_SEMI_MAJOR_AXIS: u16 = 2057;
    pub const GEOG_SEMI_MINOR_AXIS: u16 = 2058;
    pub const GEOG_INV_FLATTENING: u16 = 2059;
    pub const GEOG_PRIME_MERIDIAN_LONG: u16 = 2061;
    pub const GEOG_TOWGS84: u16 = 2062;
    pub const PROJECTED_CS_TYPE: u16 = 3072;
    pub const PCS_CITATION: u16 = 3073;
    pub const PROJECTION: u16 = 3074;
    pub const PROJ_COORD_TRANS: u16 = 3075;
    pub const PROJ_LINEAR_UNITS: u16 = 3076;
    pub const PROJ_LINEAR_UNIT_SIZE: u16 = 3077;
    pub const PROJ_STD_PARALLEL1: u16 = 3078;
    pub const PROJ_STD_PARALLEL2: u16 = 3079;
    pub const PROJ_NAT_ORIGIN_LONG: u16 = 3080;
    pub const PROJ_NAT_ORIGIN_LAT: u16 = 3081;
    pub const PROJ_FALSE_EASTING: u16 = 3082;
    pub const PROJ_FALSE_NORTHING: u16 = 3083;
    pub const PROJ_FALSE_ORIGIN_LONG: u16 = 3084;
    pub const PROJ_FALSE_ORIGIN_LAT: u16 = 3085;
    pub const PROJ_FALSE_ORIGIN_EASTING: u16 = 3086;
    pub const PROJ_FALSE_ORIGIN_NORTHING: u16 = 3087;
    pub const PROJ_CENTER_LONG: u16 = 3088;
    pub const PROJ_CENTER_LAT: u16 = 3089;
    pub const PROJ_SCALE_AT_NAT_ORIGIN: u16 = 3092;
    pub const PROJ_SCALE_AT_CENTER: u16 = 3093;
    pub const PROJ_STRAIGHT_VERT_POLE_LONG: u16 = 3095;
}

/// Code meaning "user-defined" in every GeoKey that takes an EPSG code.
pub(crate) const USER_DEFINED: u16 = 32767;

/// The TIFF tag numbers that a key's `tag_location` may name.
const TAG_DIRECTORY: u16 = 34735;
const TAG_DOUBLES: u16 = 34736;
const TAG_ASCII: u16 = 34737;

/// One key's value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum GeoKeyValue {
    /// SHORT values (codes and counts); usually one.
    Short(Vec<u16>),
    /// DOUBLE values (angles, lengths, Helmert parameters).
    Double(Vec<f64>),
    /// An ASCII citation, without the trailing `|`.
    Ascii(String),
}

/// A parsed GeoKey directory.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct GeoKeys {
    keys: BTreeMap<u16, GeoKeyValue>,
}

impl GeoKeys {
    /// Parses the directory SHORTs with the double and ASCII parameter arrays (empty if the
    /// file has none).
    ///
    /// # Errors
    /// A message naming the key when the header or an entry points outside its array.
    pub(crate) fn parse(directory: &[u16], doubles: &[f64], ascii: &str) -> Result<Self, String> {
        let [_version, _revision, _minor, key_count, entries @ ..] = directory else {
            return Err(format!(
                "GeoKeyDirectory has {} SHORTs, fewer than its 4-SHORT header",
                directory.len()
            ));
        };
        let key_count = usize::from(*key_count);
        if entries.len() < key_count * 4 {
            return Err(format!(
                "GeoKeyDirectory announces {key_count} keys but holds only {}",
                entries.len() / 4
            ));
        }
        let mut keys = BTreeMap::new();
        for entry in entries.chunks_exact(4).take(key_count) {
            let [id, location, count, offset] = [entry[0], entry[1], entry[2], entry[3]];
            let (start, len) = (usize::from(offset), usize::from(count));
            let out_of_range =
                || format!("GeoKey {id}: values {start}..{} out of range", start + len);
            let value = match location {
                0 => GeoKeyValue::Short(vec![offset]),
                TAG_DIRECTORY => GeoKeyValue::Short(
                    directory
                        .get(start..start + len)
                        .ok_or_else(out_of_range)?
                        .to_vec(),
                ),
                TAG_DOUBLES => GeoKeyValue::Double(
                    doubles
                        .get(start..start + len)
                        .ok_or_else(out_of_range)?
                        .to_vec(),
                ),
                TAG_ASCII => {
                    let text = ascii.get(start..start + len).ok_or_else(out_of_range)?;
                    GeoKeyValue::Ascii(text.trim_end_matches(['|', '\0']).to_string())
                }
                other => return Err(format!("GeoKey {id}: unknown tag location {other}")),
            };
            keys.insert(id, value);
        }
        Ok(GeoKeys { keys })
    }

    /// Whether the directory holds no key.
    pub(crate) fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The first SHORT of key `id`, if it is a SHORT key.
    pub(crate) fn short(&self, id: u16) -> Option<u16> {
        match self.keys.get(&id)? {
            GeoKeyValue::Short(v) => v.first().copied(),
            _ => None,
        }
    }

    /// The DOUBLE values of key `id`, if it is a DOUBLE key.
    pub(crate) fn doubles(&self, id: u16) -> Option<&[f64]> {
        match self.keys.get(&id)? {
            GeoKeyValue::Double(v) => Some(v),
            _ => None,
        }
    }

    /// The first DOUBLE of key `id`.
    pub(crate) fn double(&self, id: u16) -> Option<f64> {
        self.doubles(id)?.first().copied()
    }

    /// The ASCII value of key `id`.
    pub(crate) fn ascii(&self, id: u16) -> Option<&str> {
        match self.keys.get(&id)? {
            GeoKeyValue::Ascii(s) => Some(s),
            _ => None,
        }
    }

    /// Builds a directory from `(id, value)` pairs, in the in-memory form [`GeoKeys::parse`]
    /// produces (visible for testing the CRS resolution without a file).
    #[cfg(test)]
    pub(crate) fn from_pairs(pairs: impl IntoIterator<Item = (u16, GeoKeyValue)>) -> Self {
        GeoKeys {
            keys: pairs.into_iter().collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_inline_double_and_ascii_values() {
        // byte.tif-like directory: model type, raster type, citation, PCS, ToWGS84 doubles.
        let dir = [
            1, 1, 0, 4, //
            1024, 0, 1, 1, //
            1026, 34737, 21, 0, //
            2062, 34736, 3, 0, //
            3072, 0, 1, 26711,
        ];
        let doubles = [-8.0, 160.0, 176.0];
        let ascii = "NAD27 / UTM zone 11N|";
        let keys = GeoKeys::parse(&dir, &doubles, ascii).unwrap();
        assert_eq!(keys.short(key::GT_MODEL_TYPE), Some(1));
        assert_eq!(keys.short(key::PROJECTED_CS_TYPE), Some(26711));
        assert_eq!(keys.ascii(key::GT_CITATION), Some("NAD27 / UTM zone 11N"));
        assert_eq!(keys.doubles(key::GEOG_TOWGS84), Some(&doubles[..]));
        assert_eq!(keys.short(key::GT_RASTER_TYPE), None);
    }

    #[test]
    fn rejects_a_short_directory_and_out_of_range_values() {
        assert!(GeoKeys::parse(&[1, 1, 0], &[], "").is_err());
        assert!(GeoKeys::parse(&[1, 1, 0, 2, 1024, 0, 1, 1], &[], "").is_err());
        let err = GeoKeys::parse(&[1, 1, 0, 1, 2057, 34736, 1, 5], &[1.0], "").unwrap_err();
        assert!(err.contains("2057"), "{err}");
    }
}
