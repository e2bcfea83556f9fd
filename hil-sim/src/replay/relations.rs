//! A reader for the ground-truth relations of Kümmerle et al. 2009 ("On measuring the
//! accuracy of SLAM algorithms", Autonomous Robots 27:397–407): `*.relations`, one relation
//! per line, `t1 t2 x y z roll pitch yaw`: the pose at `t2` seen from the pose at `t1`
//! (metres, radians). In the 2D sets `z`, `roll` and `pitch` are 0. The timestamps are kept
//! as text too, to pair them exactly with a log's scans.

use std::path::Path;

use super::error::LogError;
use super::fields::{Fields, open_lines, parse_lines};

/// One relation between two timestamps.
#[derive(Debug, Clone, PartialEq)]
pub struct Relation {
    /// Line number in the file, from 1.
    pub line: usize,
    /// First timestamp, seconds.
    pub t1_s: f64,
    /// First timestamp exactly as printed.
    pub t1_text: String,
    /// Second timestamp, seconds.
    pub t2_s: f64,
    /// Second timestamp exactly as printed.
    pub t2_text: String,
    /// Translation x, metres.
    pub x_m: f64,
    /// Translation y, metres.
    pub y_m: f64,
    /// Translation z, metres.
    pub z_m: f64,
    /// Roll, radians.
    pub roll_rad: f64,
    /// Pitch, radians.
    pub pitch_rad: f64,
    /// Yaw, radians.
    pub yaw_rad: f64,
}

/// Reads the relations at `path` (gzip-compressed when the name ends in `.gz`).
///
/// # Errors
/// The first malformed line, or an I/O error.
pub fn read_relations(path: impl AsRef<Path>) -> Result<Vec<Relation>, LogError> {
    let path = path.as_ref();
    parse_lines(open_lines(path)?, path, |line, text| {
        parse_relation_line(path, line, text)
    })
}

/// Reads relations from `text`; `path` names it in errors.
///
/// # Errors
/// The first malformed line.
pub fn parse_relations(text: &str, path: impl AsRef<Path>) -> Result<Vec<Relation>, LogError> {
    let path = path.as_ref();
    parse_lines(text.as_bytes(), path, |line, text| {
        parse_relation_line(path, line, text)
    })
}

fn parse_relation_line(path: &Path, line: usize, text: &str) -> Result<Relation, LogError> {
    let mut fields = Fields::new(path, line, "relation", text);
    let (t1_s, t1_text) = fields.number_with_text("t1")?;
    let (t2_s, t2_text) = fields.number_with_text("t2")?;
    let relation = Relation {
        line,
        t1_s,
        t1_text: t1_text.to_owned(),
        t2_s,
        t2_text: t2_text.to_owned(),
        x_m: fields.number("x")?,
        y_m: fields.number("y")?,
        z_m: fields.number("z")?,
        roll_rad: fields.number("roll")?,
        pitch_rad: fields.number("pitch")?,
        yaw_rad: fields.number("yaw")?,
    };
    fields.end()?;
    Ok(relation)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::CarmenLog;
    use std::collections::HashSet;

    #[test]
    fn intel_relations() {
        let Some(path) = datasets::require("benchmark/intel.relations", "intel_relations") else {
            return;
        };
        let relations = read_relations(&path).unwrap();
        assert_eq!(relations.len(), 2_984);
        let first = &relations[0];
        assert_eq!(
            (first.t1_text.as_str(), first.t2_text.as_str()),
            ("976052905.167303", "976052911.885496")
        );
        assert_eq!(
            (first.x_m, first.y_m, first.yaw_rad),
            (-0.05699, -0.12843, -1.68221)
        );
        assert!(
            relations
                .iter()
                .all(|r| r.z_m == 0.0 && r.roll_rad == 0.0 && r.pitch_rad == 0.0)
        );
        // 90 relations have both timestamps, as printed, among the scans of intel.clf; 97
        // within 1 ms.
        let Some(clf) = datasets::require("benchmark/intel.clf", "intel_relations") else {
            return;
        };
        let log = CarmenLog::read(clf).unwrap();
        let stamps: HashSet<&str> = log.lasers().map(|l| l.timestamp_text.as_str()).collect();
        let matched = relations
            .iter()
            .filter(|r| stamps.contains(r.t1_text.as_str()) && stamps.contains(r.t2_text.as_str()))
            .count();
        assert_eq!(matched, 90);
        let mut times: Vec<f64> = log.lasers().map(|l| l.timestamp_s).collect();
        times.sort_by(f64::total_cmp);
        let near = |t: f64| {
            let i = times.partition_point(|&s| s < t - 1e-3);
            times.get(i).is_some_and(|&s| (s - t).abs() <= 1e-3)
        };
        let within_1ms = relations
            .iter()
            .filter(|r| near(r.t1_s) && near(r.t2_s))
            .count();
        assert_eq!(within_1ms, 97);
    }

    #[test]
    fn malformed_relation_lines() {
        let err = parse_relations("1 2 0 0 0 0 0 0\n1 2 0 0 0 0 0\n", "x.relations").unwrap_err();
        assert_eq!((err.line(), err.field()), (Some(2), Some("yaw")));
        let err = parse_relations("1 2 0 zero 0 0 0 0\n", "x.relations").unwrap_err();
        assert_eq!(err.field(), Some("y"));
        assert!(
            err.to_string().contains("\"zero\" is not a number"),
            "{err}"
        );
    }
}
