//! ESRI world files: six numbers, one per line, mapping pixels to model coordinates.
//!
//! Line order is `A` (x size of a pixel), `D` (rotation), `B` (rotation), `E` (y size, usually
//! negative), `C`, `F`; `(C, F)` is the **centre** of the top-left pixel, so the outer corner is
//! half a pixel from it (see [`GeoTransform::from_world_file`]). Lines may end in LF or CRLF.
//!
//! The world file of `name.ext` is looked up as GDAL does: `name.<first and last letter of
//! ext>w` (`.pgw`, `.jgw`, `.tfw`), then `name.<ext>w` (`.pngw`, `.jpgw`), then `name.wld`, each
//! in lower then upper case.

use std::path::{Path, PathBuf};

use super::GeoImageError;
use super::geo_transform::GeoTransform;

/// The world file beside `image`, if there is one.
pub(crate) fn find_world_file(image: &Path) -> Option<PathBuf> {
    let ext = image.extension()?.to_str()?.to_ascii_lowercase();
    let mut chars = ext.chars();
    let (first, last) = (chars.next()?, ext.chars().last()?);
    let candidates = [
        format!("{first}{last}w"),
        format!("{ext}w"),
        "wld".to_string(),
    ];
    candidates
        .iter()
        .flat_map(|c| [c.clone(), c.to_ascii_uppercase()])
        .map(|c| image.with_extension(c))
        .find(|p| p.is_file())
}

/// Reads the world file at `path`.
///
/// # Errors
/// [`GeoImageError::Io`] if it cannot be read, [`GeoImageError::Malformed`] naming the line
/// when it has fewer than six numbers or a line is not a finite number.
pub(crate) fn read_world_file(path: &Path) -> Result<GeoTransform, GeoImageError> {
    let text = std::fs::read_to_string(path).map_err(|source| GeoImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_world_file(&text).map_err(|message| GeoImageError::Malformed {
        path: path.to_path_buf(),
        message,
    })
}

/// Parses world-file text (see the module docs); the error says which line is wrong.
pub(crate) fn parse_world_file(text: &str) -> Result<GeoTransform, String> {
    let mut values = [0.0; 6];
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    for value in &mut values {
        let Some((n, line)) = lines.next() else {
            return Err("world file has fewer than 6 numbers".to_string());
        };
        *value = line
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                format!(
                    "world file line {}: {:?} is not a number",
                    n + 1,
                    line.trim()
                )
            })?;
    }
    Ok(GeoTransform::from_world_file(values))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crlf_and_lf_give_the_same_transform() {
        let lf = "2.0\n0\n0\n-2.0\n101.0\n199.0\n";
        let crlf = lf.replace('\n', "\r\n");
        let a = parse_world_file(lf).unwrap();
        assert_eq!(a, parse_world_file(&crlf).unwrap());
        assert_eq!(a.apply(0.0, 0.0), [100.0, 200.0]);
    }

    #[test]
    fn short_or_garbled_files_are_errors() {
        assert!(
            parse_world_file("1\n0\n0\n-1\n5\n")
                .unwrap_err()
                .contains("fewer than 6")
        );
        let err = parse_world_file("1\n0\nx\n-1\n5\n6\n").unwrap_err();
        assert!(err.contains("line 3"), "{err}");
    }

    #[test]
    fn finds_pgw_beside_png() {
        let dir = std::env::temp_dir().join(format!("geoimage-wf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("map.png");
        assert_eq!(find_world_file(&png), None);
        std::fs::write(dir.join("map.wld"), "1\n0\n0\n-1\n0\n0\n").unwrap();
        assert_eq!(find_world_file(&png), Some(dir.join("map.wld")));
        std::fs::write(dir.join("map.pgw"), "1\n0\n0\n-1\n0\n0\n").unwrap();
        assert_eq!(find_world_file(&png), Some(dir.join("map.pgw")));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
