//! A reader for reference trajectories, `*.reference.tsv`: one pose per line,
//! `timestamp x y theta` (seconds, metres, metres, radians), `#` comments allowed. In
//! `shared/datasets/benchmark/` these are the GMapping-corrected poses of the scans of the
//! matching `.clf`, with the same timestamp text, so poses and scans pair by timestamp text.

use std::path::Path;

use super::carmen::LoggedPose;
use super::error::LogError;
use super::fields::{Fields, open_lines, parse_lines};

/// One reference pose.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferencePose {
    /// Line number in the file, from 1.
    pub line: usize,
    /// The timestamp, seconds.
    pub timestamp_s: f64,
    /// The timestamp exactly as the file prints it.
    pub timestamp_text: String,
    /// The pose.
    pub pose: LoggedPose,
}

/// Reads the reference trajectory at `path` (gzip-compressed when the name ends in `.gz`).
///
/// # Errors
/// The first malformed line, or an I/O error.
pub fn read_reference(path: impl AsRef<Path>) -> Result<Vec<ReferencePose>, LogError> {
    let path = path.as_ref();
    parse_lines(open_lines(path)?, path, |line, text| {
        parse_reference_line(path, line, text)
    })
}

/// Reads a reference trajectory from `text`; `path` names it in errors.
///
/// # Errors
/// The first malformed line.
pub fn parse_reference(text: &str, path: impl AsRef<Path>) -> Result<Vec<ReferencePose>, LogError> {
    let path = path.as_ref();
    parse_lines(text.as_bytes(), path, |line, text| {
        parse_reference_line(path, line, text)
    })
}

fn parse_reference_line(path: &Path, line: usize, text: &str) -> Result<ReferencePose, LogError> {
    let mut fields = Fields::new(path, line, "reference pose", text);
    let (timestamp_s, timestamp_text) = fields.number_with_text("timestamp")?;
    let pose = LoggedPose {
        x_m: fields.number("x")?,
        y_m: fields.number("y")?,
        theta_rad: fields.number("theta")?,
    };
    fields.end()?;
    Ok(ReferencePose {
        line,
        timestamp_s,
        timestamp_text: timestamp_text.to_owned(),
        pose,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::CarmenLog;

    #[test]
    fn intel_reference_pairs_with_the_scans() {
        let Some(path) = datasets::require(
            "benchmark/intel.reference.tsv",
            "intel_reference_pairs_with_the_scans",
        ) else {
            return;
        };
        let poses = read_reference(&path).unwrap();
        assert_eq!(poses.len(), 910);
        assert_eq!(poses[0].timestamp_text, "976052890.244111");
        assert_eq!(poses[0].line, 2);
        assert_eq!(poses[1].pose.theta_rad, -0.938803);
        let Some(clf) = datasets::require(
            "benchmark/intel.clf",
            "intel_reference_pairs_with_the_scans",
        ) else {
            return;
        };
        let log = CarmenLog::read(clf).unwrap();
        assert!(
            log.lasers()
                .zip(&poses)
                .all(|(scan, pose)| scan.timestamp_text == pose.timestamp_text)
        );
    }

    #[test]
    fn malformed_reference_lines() {
        let err = parse_reference("# t x y theta\n1.5 1 2\n", "r.tsv").unwrap_err();
        assert_eq!((err.line(), err.field()), (Some(2), Some("theta")));
        let err = parse_reference("1.5 1 2 3 4\n", "r.tsv").unwrap_err();
        assert_eq!(err.field(), Some("end of line"));
        let err = parse_reference("t 1 2 3\n", "r.tsv").unwrap_err();
        assert_eq!(err.field(), Some("timestamp"));
        assert!(
            err.to_string().starts_with("r.tsv:1: reference pose"),
            "{err}"
        );
    }
}
