//! A reader for CARMEN text logs (`.clf`, `.log`, and their gzip `.gz`): the `FLASER`,
//! `ROBOTLASER1` and `ODOM` messages. Other messages (`PARAM`, `NEFF`, `RLASER`, …) are
//! counted by type and skipped; blank lines and `#` comments are skipped.
//!
//! Formats (one message per line, fields separated by white space):
//!
//! ```text
//! FLASER num_readings range[num_readings] x y theta odom_x odom_y odom_theta timestamp [hostname logger_timestamp]
//! ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy
//!     remission_mode num_readings range[num_readings] num_remissions remission[num_remissions]
//!     laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv forward_safety_dist
//!     side_safety_dist turn_axis timestamp [hostname logger_timestamp]
//! ODOM x y theta tv rv accel timestamp [hostname logger_timestamp]
//! ```
//!
//! Units: metres, radians, m/s, rad/s, seconds. The timestamp kept is the first one (the IPC
//! time of the message), both as a number and as the exact text of the log, because `f64`
//! printing would not reproduce it (e.g. `976052890.244111`).
//!
//! `FLASER` records no field of view. Beam `i` lies at `−90° + i · res` from the robot's
//! forward axis (counter-clockwise positive), with `res` = 180° / n for an even beam count `n`
//! and 180° / (n − 1) for an odd one: 1° for 180 and 181 beams, 0.5° for 360 and 361 (the
//! convention the GMapping-corrected logs were written with; see `shared/datasets/SOURCES.md`).
//!
//! In the GMapping-corrected logs the `FLASER` pose fields hold the corrected pose in both
//! places; in `benchmark/*.clf` they hold raw odometry (or zeros). The reader keeps what the
//! log says and does not interpret it.

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::io::BufRead;
use std::path::{Path, PathBuf};

use super::error::{FieldProblem, LogError};
use super::fields::{Fields, is_blank_or_comment, open_lines};

/// A planar pose as a log prints it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoggedPose {
    /// x, metres.
    pub x_m: f64,
    /// y, metres.
    pub y_m: f64,
    /// Heading, radians counter-clockwise from +x.
    pub theta_rad: f64,
}

/// Which message a laser record came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LaserMessage {
    /// `FLASER` (front laser, old format: no geometry).
    Flaser,
    /// `ROBOTLASER1` (geometry, laser pose and robot pose).
    RobotLaser1,
}

/// One laser scan of a CARMEN log.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserRecord {
    /// The message it came from.
    pub message: LaserMessage,
    /// Line number in the log, from 1.
    pub line: usize,
    /// The timestamp, seconds.
    pub timestamp_s: f64,
    /// The timestamp exactly as the log prints it.
    pub timestamp_text: String,
    /// One range per beam, metres, as logged (a log's "no return" value included).
    pub ranges_m: Vec<f64>,
    /// Bearing of beam 0 from the forward axis, radians, counter-clockwise positive.
    pub start_angle_rad: f64,
    /// Angle from one beam to the next, radians.
    pub resolution_rad: f64,
    /// Field of view, radians (`ROBOTLASER1` as logged; π for `FLASER`).
    pub fov_rad: f64,
    /// Maximum range of the laser, metres (`ROBOTLASER1` only).
    pub max_range_m: Option<f64>,
    /// The robot pose: `x y theta` of `FLASER`, `robot_x robot_y robot_theta` of
    /// `ROBOTLASER1`.
    pub robot_pose: LoggedPose,
    /// `odom_x odom_y odom_theta` of `FLASER`.
    pub odom_pose: Option<LoggedPose>,
    /// `laser_x laser_y laser_theta` of `ROBOTLASER1`.
    pub laser_pose: Option<LoggedPose>,
    /// Remission values of `ROBOTLASER1` (empty otherwise).
    pub remissions: Vec<f64>,
}

impl LaserRecord {
    /// Bearing of beam `index` from the forward axis, radians.
    pub fn beam_angle_rad(&self, index: usize) -> f64 {
        self.start_angle_rad + index as f64 * self.resolution_rad
    }

    /// Every beam as (bearing in radians, range in metres).
    pub fn beams(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.ranges_m
            .iter()
            .enumerate()
            .map(|(i, &range_m)| (self.beam_angle_rad(i), range_m))
    }
}

/// One `ODOM` message.
#[derive(Debug, Clone, PartialEq)]
pub struct OdomRecord {
    /// Line number in the log, from 1.
    pub line: usize,
    /// The timestamp, seconds.
    pub timestamp_s: f64,
    /// The timestamp exactly as the log prints it.
    pub timestamp_text: String,
    /// The odometry pose.
    pub pose: LoggedPose,
    /// Translational velocity, m/s.
    pub tv_mps: f64,
    /// Rotational velocity, rad/s.
    pub rv_radps: f64,
    /// Acceleration, m/s².
    pub accel_mps2: f64,
}

/// A message the reader understands.
#[derive(Debug, Clone, PartialEq)]
pub enum CarmenRecord {
    /// `FLASER` or `ROBOTLASER1`.
    Laser(LaserRecord),
    /// `ODOM`.
    Odom(OdomRecord),
}

/// What a reader has seen so far.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CarmenCounts {
    /// Lines read.
    pub lines: usize,
    /// `FLASER` messages read.
    pub flaser: usize,
    /// `ROBOTLASER1` messages read.
    pub robotlaser1: usize,
    /// `ODOM` messages read.
    pub odom: usize,
    /// `#` comment lines.
    pub comments: usize,
    /// Blank lines.
    pub blank: usize,
    /// Lines of other messages, by message name.
    pub skipped: BTreeMap<String, usize>,
    /// Lines that failed to parse (the reader went on after them).
    pub errors: usize,
}

/// The beam spacing `FLASER` implies for `num_readings` beams over 180° (see the
/// [module documentation](self)), radians.
pub fn flaser_resolution_rad(num_readings: usize) -> f64 {
    let span = if num_readings % 2 == 1 {
        num_readings - 1
    } else {
        num_readings
    };
    if span == 0 {
        PI / 180.0
    } else {
        PI / span as f64
    }
}

/// Reads a CARMEN log message by message. Each item is one understood message or the error
/// of one line; after an error the reader goes on with the next line.
pub struct CarmenReader<R> {
    reader: R,
    path: PathBuf,
    text: String,
    counts: CarmenCounts,
    failed_io: bool,
}

impl<R> std::fmt::Debug for CarmenReader<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CarmenReader")
            .field("path", &self.path)
            .field("counts", &self.counts)
            .finish_non_exhaustive()
    }
}

impl CarmenReader<Box<dyn BufRead + Send>> {
    /// Opens the log at `path` (gzip-compressed when the name ends in `.gz`).
    ///
    /// # Errors
    /// [`LogError::Io`] when the file cannot be opened.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, LogError> {
        let path = path.as_ref();
        Ok(CarmenReader::new(open_lines(path)?, path))
    }
}

impl<R: BufRead> CarmenReader<R> {
    /// A reader of the text `reader` yields; `path` names it in errors.
    pub fn new(reader: R, path: impl Into<PathBuf>) -> Self {
        CarmenReader {
            reader,
            path: path.into(),
            text: String::new(),
            counts: CarmenCounts::default(),
            failed_io: false,
        }
    }

    /// What was read so far.
    pub fn counts(&self) -> &CarmenCounts {
        &self.counts
    }
}

impl<R: BufRead> Iterator for CarmenReader<R> {
    type Item = Result<CarmenRecord, LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if self.failed_io {
                return None;
            }
            self.text.clear();
            match self.reader.read_line(&mut self.text) {
                Ok(0) => return None,
                Ok(_) => {}
                Err(e) => {
                    self.failed_io = true;
                    return Some(Err(LogError::io(&self.path, e)));
                }
            }
            self.counts.lines += 1;
            let line = self.counts.lines;
            if is_blank_or_comment(&self.text) {
                if self.text.trim().is_empty() {
                    self.counts.blank += 1;
                } else {
                    self.counts.comments += 1;
                }
                continue;
            }
            let mut fields = Fields::new(&self.path, line, "CARMEN", &self.text);
            let Ok(name) = fields.text("message") else {
                continue;
            };
            let result = match name {
                "FLASER" => parse_flaser(Fields::new(&self.path, line, name, &self.text), line),
                "ROBOTLASER1" => {
                    parse_robotlaser1(Fields::new(&self.path, line, name, &self.text), line)
                }
                "ODOM" => parse_odom(Fields::new(&self.path, line, name, &self.text), line),
                other => {
                    *self.counts.skipped.entry(other.to_owned()).or_default() += 1;
                    continue;
                }
            };
            match &result {
                Ok(CarmenRecord::Laser(l)) if l.message == LaserMessage::Flaser => {
                    self.counts.flaser += 1
                }
                Ok(CarmenRecord::Laser(_)) => self.counts.robotlaser1 += 1,
                Ok(CarmenRecord::Odom(_)) => self.counts.odom += 1,
                Err(_) => self.counts.errors += 1,
            }
            return Some(result);
        }
    }
}

/// A whole CARMEN log in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct CarmenLog {
    /// The file it was read from.
    pub path: PathBuf,
    /// The understood messages, in log order.
    pub records: Vec<CarmenRecord>,
    /// What the reader saw.
    pub counts: CarmenCounts,
}

impl CarmenLog {
    /// Reads the whole log at `path` (gzip-compressed when the name ends in `.gz`).
    ///
    /// # Errors
    /// The first malformed line, or an I/O error.
    pub fn read(path: impl AsRef<Path>) -> Result<CarmenLog, LogError> {
        let path = path.as_ref();
        CarmenLog::from_reader(CarmenReader::open(path)?)
    }

    /// Reads a log from `text`; `path` names it in errors.
    ///
    /// # Errors
    /// The first malformed line.
    pub fn parse(text: &str, path: impl Into<PathBuf>) -> Result<CarmenLog, LogError> {
        CarmenLog::from_reader(CarmenReader::new(text.as_bytes(), path))
    }

    fn from_reader<R: BufRead>(mut reader: CarmenReader<R>) -> Result<CarmenLog, LogError> {
        let records = reader.by_ref().collect::<Result<Vec<_>, _>>()?;
        Ok(CarmenLog {
            path: reader.path,
            records,
            counts: reader.counts,
        })
    }

    /// The laser records, in log order.
    pub fn lasers(&self) -> impl Iterator<Item = &LaserRecord> + '_ {
        self.records.iter().filter_map(|r| match r {
            CarmenRecord::Laser(laser) => Some(laser),
            CarmenRecord::Odom(_) => None,
        })
    }

    /// The odometry records, in log order.
    pub fn odometry(&self) -> impl Iterator<Item = &OdomRecord> + '_ {
        self.records.iter().filter_map(|r| match r {
            CarmenRecord::Odom(odom) => Some(odom),
            CarmenRecord::Laser(_) => None,
        })
    }
}

/// At most this many values are reserved up front, whatever count a line claims.
const MAX_PREALLOCATED: usize = 4_096;

/// `count` numbers named `field[i]`.
fn numbers(fields: &mut Fields<'_>, field: &str, count: usize) -> Result<Vec<f64>, LogError> {
    let mut values = Vec::with_capacity(count.min(MAX_PREALLOCATED));
    for i in 0..count {
        values.push(fields.indexed_number(field, i)?);
    }
    Ok(values)
}

/// Three numbers named `{prefix}x`, `{prefix}y`, `{prefix}theta`.
fn pose(fields: &mut Fields<'_>, names: [&str; 3]) -> Result<LoggedPose, LogError> {
    Ok(LoggedPose {
        x_m: fields.number(names[0])?,
        y_m: fields.number(names[1])?,
        theta_rad: fields.number(names[2])?,
    })
}

/// The timestamp, then the optional hostname and logger timestamp, then the end of the line.
fn timestamp(fields: &mut Fields<'_>) -> Result<(f64, String), LogError> {
    let (timestamp_s, text) = fields.number_with_text("timestamp")?;
    if fields.optional_text().is_some() {
        fields.number("logger_timestamp")?;
    }
    fields.end()?;
    Ok((timestamp_s, text.to_owned()))
}

fn parse_flaser(mut fields: Fields<'_>, line: usize) -> Result<CarmenRecord, LogError> {
    fields.text("message")?;
    let count = fields.count("num_readings")?;
    let ranges_m = numbers(&mut fields, "range", count)?;
    let robot_pose = pose(&mut fields, ["x", "y", "theta"])?;
    let odom_pose = pose(&mut fields, ["odom_x", "odom_y", "odom_theta"])?;
    let (timestamp_s, timestamp_text) = timestamp(&mut fields)?;
    Ok(CarmenRecord::Laser(LaserRecord {
        message: LaserMessage::Flaser,
        line,
        timestamp_s,
        timestamp_text,
        ranges_m,
        start_angle_rad: -PI / 2.0,
        resolution_rad: flaser_resolution_rad(count),
        fov_rad: PI,
        max_range_m: None,
        robot_pose,
        odom_pose: Some(odom_pose),
        laser_pose: None,
        remissions: Vec::new(),
    }))
}

fn parse_robotlaser1(mut fields: Fields<'_>, line: usize) -> Result<CarmenRecord, LogError> {
    fields.text("message")?;
    fields.number("laser_type")?;
    let start_angle_rad = fields.number("start_angle")?;
    let fov_rad = fields.number("field_of_view")?;
    let resolution_rad = fields.number("angular_resolution")?;
    let max_range_m = fields.number("maximum_range")?;
    fields.number("accuracy")?;
    fields.number("remission_mode")?;
    let count = fields.count("num_readings")?;
    let ranges_m = numbers(&mut fields, "range", count)?;
    let remission_count = fields.count("num_remissions")?;
    let remissions = numbers(&mut fields, "remission", remission_count)?;
    let laser_pose = pose(&mut fields, ["laser_x", "laser_y", "laser_theta"])?;
    let robot_pose = pose(&mut fields, ["robot_x", "robot_y", "robot_theta"])?;
    for name in [
        "tv",
        "rv",
        "forward_safety_dist",
        "side_safety_dist",
        "turn_axis",
    ] {
        fields.number(name)?;
    }
    let (timestamp_s, timestamp_text) = timestamp(&mut fields)?;
    if count > 1 && resolution_rad == 0.0 {
        return Err(fields.error(
            "angular_resolution",
            FieldProblem::Invalid("zero with more than one beam".into()),
        ));
    }
    Ok(CarmenRecord::Laser(LaserRecord {
        message: LaserMessage::RobotLaser1,
        line,
        timestamp_s,
        timestamp_text,
        ranges_m,
        start_angle_rad,
        resolution_rad,
        fov_rad,
        max_range_m: Some(max_range_m),
        robot_pose,
        odom_pose: None,
        laser_pose: Some(laser_pose),
        remissions,
    }))
}

fn parse_odom(mut fields: Fields<'_>, line: usize) -> Result<CarmenRecord, LogError> {
    fields.text("message")?;
    let pose = pose(&mut fields, ["x", "y", "theta"])?;
    let tv_mps = fields.number("tv")?;
    let rv_radps = fields.number("rv")?;
    let accel_mps2 = fields.number("accel")?;
    let (timestamp_s, timestamp_text) = timestamp(&mut fields)?;
    Ok(CarmenRecord::Odom(OdomRecord {
        line,
        timestamp_s,
        timestamp_text,
        pose,
        tv_mps,
        rv_radps,
        accel_mps2,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log(name: &str, test: &str) -> Option<CarmenLog> {
        let path = datasets::require(name, test)?;
        Some(CarmenLog::read(&path).unwrap())
    }

    #[test]
    fn intel_clf() {
        let Some(log) = log("benchmark/intel.clf", "intel_clf") else {
            return;
        };
        assert_eq!(log.counts.flaser, 910);
        assert_eq!((log.counts.odom, log.counts.robotlaser1), (0, 0));
        assert_eq!(log.counts.comments, 1);
        let first = log.lasers().next().unwrap();
        assert_eq!(first.ranges_m.len(), 180);
        assert_eq!(first.timestamp_text, "976052890.244111");
        assert_eq!(first.timestamp_s, 976052890.244111);
        assert_eq!((first.ranges_m[0], first.ranges_m[179]), (1.09, 1.23));
        assert_eq!(
            first.robot_pose,
            LoggedPose {
                x_m: 0.698,
                y_m: -0.015,
                theta_rad: -0.463373
            }
        );
        assert_eq!(first.odom_pose, Some(first.robot_pose));
        assert!((first.beam_angle_rad(0) + PI / 2.0).abs() < 1e-12);
        assert!((first.beam_angle_rad(179) - 89f64.to_radians()).abs() < 1e-12);
        // 81.83 m is Intel's "no return".
        let max = log
            .lasers()
            .flat_map(|l| l.ranges_m.iter().copied())
            .fold(0.0, f64::max);
        assert_eq!(max, 81.83);
    }

    #[test]
    fn csail_and_aces_clf() {
        if let Some(log) = log("benchmark/csail.clf", "csail_and_aces_clf") {
            assert_eq!(log.counts.flaser, 406);
            let first = log.lasers().next().unwrap();
            assert_eq!(first.ranges_m.len(), 361);
            assert_eq!(first.timestamp_text, "1134864642.914187");
            assert!((first.resolution_rad - 0.5f64.to_radians()).abs() < 1e-15);
            assert!((first.beam_angle_rad(360) - PI / 2.0).abs() < 1e-12);
        }
        if let Some(log) = log("benchmark/aces.clf", "csail_and_aces_clf") {
            assert_eq!(log.counts.flaser, 440);
            assert!(log.lasers().all(|l| l.ranges_m.len() == 180));
            assert!(log.lasers().all(|l| l.robot_pose == LoggedPose::default()));
        }
    }

    #[test]
    fn intel_corrected_gz() {
        let Some(log) = log(
            "radish_corrected_carmen/intel-corrected.log.gz",
            "intel_corrected_gz",
        ) else {
            return;
        };
        let c = &log.counts;
        assert_eq!((c.lines, c.flaser, c.odom), (16_365, 910, 14_541));
        assert_eq!(c.skipped.get("NEFF"), Some(&910));
        assert_eq!(c.skipped.get("PARAM"), Some(&2));
        assert_eq!(c.comments, 2);
        let first = log.lasers().next().unwrap();
        assert_eq!(first.timestamp_text, "32.9068");
        assert_eq!(first.ranges_m.len(), 180);
        let odom = log.odometry().nth(2).unwrap();
        assert_eq!(odom.timestamp_text, "0.204947");
        assert_eq!(odom.line, 7);
    }

    #[test]
    fn robotlaser1_and_odom() {
        let text = "# a comment\n\
            ROBOTLASER1 0 -1.6 3.2 0.0174533 81.9 0.01 0 3 1.5 2.5 81.9 0 \
            0.1 0.2 0.3 1.0 2.0 3.0 0.5 0.1 0.0 0.0 0.0 1234.567890123 host 1234.6\n\
            ODOM 1 2 0.5 0.3 -0.1 0 17.25 host 17.3\n\
            PARAM x 1\n\n";
        let log = CarmenLog::parse(text, "mem.log").unwrap();
        assert_eq!((log.counts.robotlaser1, log.counts.odom), (1, 1));
        assert_eq!((log.counts.comments, log.counts.blank), (1, 1));
        let laser = log.lasers().next().unwrap();
        assert_eq!(laser.message, LaserMessage::RobotLaser1);
        assert_eq!(laser.ranges_m, [1.5, 2.5, 81.9]);
        assert_eq!(laser.max_range_m, Some(81.9));
        assert_eq!(laser.timestamp_text, "1234.567890123");
        assert_eq!(
            laser.laser_pose,
            Some(LoggedPose {
                x_m: 0.1,
                y_m: 0.2,
                theta_rad: 0.3
            })
        );
        assert_eq!(laser.robot_pose.y_m, 2.0);
        assert!((laser.beam_angle_rad(2) - (-1.6 + 2.0 * 0.0174533)).abs() < 1e-12);
        let odom = log.odometry().next().unwrap();
        assert_eq!(
            (odom.tv_mps, odom.rv_radps, odom.accel_mps2),
            (0.3, -0.1, 0.0)
        );
        assert_eq!(odom.line, 3);
    }

    #[test]
    fn malformed_lines_name_line_and_field() {
        let check = |text: &str, line: usize, field: &str| {
            let err = CarmenLog::parse(text, "bad.clf").unwrap_err();
            assert_eq!(err.line(), Some(line), "{err}");
            assert_eq!(err.field(), Some(field), "{err}");
            assert!(
                err.to_string().starts_with(&format!("bad.clf:{line}:")),
                "{err}"
            );
        };
        let good = "FLASER 2 1 2 0 0 0 0 0 0 5.5 h 5.5\n";
        check(
            &format!("{good}FLASER 2 1 x 0 0 0 0 0 0 5.5\n"),
            2,
            "range[1]",
        );
        check("FLASER 3 1 2\n", 1, "range[2]");
        check("FLASER two 1 2\n", 1, "num_readings");
        check("FLASER 2 1 2 0 0 0 0 0 0\n", 1, "timestamp");
        check("FLASER 2 1 2 0 0 0 0 0 0 nan\n", 1, "timestamp");
        check("FLASER 2 1 2 0 0 0 0 0 0 5 h 5 extra\n", 1, "end of line");
        check(
            "FLASER 2 1 2 0 0 0 0 0 0 5 h later\n",
            1,
            "logger_timestamp",
        );
        check("ODOM 1 2 3 4 5\n", 1, "accel");
        check("\n# c\nODOM 1 2 3 4 5 6 inf\n", 3, "timestamp");
        check(
            "ROBOTLASER1 0 -1.5 3.1 0 80 0 0 2 1 1 0 0 0 0 0 0 0 0 0 0 0 0 9 h 9\n",
            1,
            "angular_resolution",
        );
        check(
            "ROBOTLASER1 0 -1.5 3.1 0.1 80 0 0 1 1 4 1\n",
            1,
            "remission[1]",
        );
        // A huge count fails on the first missing value instead of allocating.
        check("FLASER 99999999999 1\n", 1, "range[1]");
        // The iterator goes on after a bad line.
        let text = "ODOM 1\nODOM 1 2 3 4 5 6 7\n";
        let mut reader = CarmenReader::new(text.as_bytes(), "x");
        assert!(reader.next().unwrap().is_err());
        assert!(reader.next().unwrap().is_ok());
        assert!(reader.next().is_none());
        assert_eq!((reader.counts().errors, reader.counts().odom), (1, 1));
    }

    #[test]
    fn flaser_geometry() {
        for (n, res_deg) in [(180, 1.0), (181, 1.0), (360, 0.5), (361, 0.5)] {
            assert!((flaser_resolution_rad(n) - f64::to_radians(res_deg)).abs() < 1e-15);
        }
        assert!(flaser_resolution_rad(0) > 0.0 && flaser_resolution_rad(1) > 0.0);
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let err = CarmenLog::read("/no/such/file.clf").unwrap_err();
        assert!(matches!(err, LogError::Io { .. }));
        assert!(err.to_string().contains("/no/such/file.clf"));
    }
}
