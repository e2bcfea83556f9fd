//! A reader for the ASCII export of the Victoria Park dataset (ACFR, Sydney; E. Nebot and
//! J. Guivant): `shared/datasets/victoria_park/rfs_slam_ascii/`.
//!
//! * `inputs.dat`: `t speed steer` (s, m/s, rad): dead reckoning, the speed measured at the
//!   rear-left wheel (see [`CarGeometry::centre_speed_mps`]).
//! * `gps.dat`: `t x y` (s, m, m): GPS positions already converted to local metres. The unit
//!   was failing at times: expect jumps and gaps.
//! * `measurements.dat`: `t range bearing diameter` (s, m, rad, m): trees detected in each
//!   laser scan, several lines per scan time. The detector reports the range to the trunk's
//!   centre (the distance to its nearest surface plus half its diameter) and the bearing in
//!   the laser frame, 0 to π counter-clockwise with π/2 straight ahead. The reader groups
//!   consecutive lines with the same time into one [`TreeScan`]; scans without a detection
//!   are not in the file.
//!
//! The three files share one clock. The raw laser scans (`LASER.txt` / `aa3_lsr2.mat`, 361
//! ranges at 0.5° in cm) are not in the dataset folder; [`tree_scans`](mod@super::tree_scans) rebuilds
//! approximate scans from the detections.

use std::path::Path;

use super::error::{FieldProblem, LogError};
use super::fields::{Fields, open_lines, parse_lines};

/// The car's geometry from `acfr_original_mat/info.txt` (the drawing it refers to is not in
/// the dataset; the meanings below are those of the vehicle model the dataset is used with).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarGeometry {
    /// `a`: from the rear axle forward to the laser, metres.
    pub a_m: f64,
    /// `b`: from the car's centre line sideways to the laser, metres.
    pub b_m: f64,
    /// `H`: from the centre of the rear axle to the rear-left wheel that measures the speed,
    /// metres.
    pub h_m: f64,
    /// `L`: wheelbase, metres.
    pub l_m: f64,
}

impl Default for CarGeometry {
    /// The values of `info.txt`: a = 0.95 m, b = 0.5 m, H = 0.76 m, L = 2.83 m.
    fn default() -> Self {
        CarGeometry {
            a_m: 0.95,
            b_m: 0.5,
            h_m: 0.76,
            l_m: 2.83,
        }
    }
}

impl CarGeometry {
    /// The speed at the centre of the rear axle from the speed measured at the rear-left
    /// wheel, `v / (1 − tan(steer) · H / L)`.
    pub fn centre_speed_mps(&self, wheel_speed_mps: f64, steer_rad: f64) -> f64 {
        wheel_speed_mps / (1.0 - steer_rad.tan() * self.h_m / self.l_m)
    }
}

/// One line of `inputs.dat`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveInput {
    /// Time, seconds.
    pub t_s: f64,
    /// Speed at the rear-left wheel, m/s.
    pub speed_mps: f64,
    /// Steering angle, radians.
    pub steer_rad: f64,
}

/// One line of `gps.dat`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalGpsFix {
    /// Time, seconds.
    pub t_s: f64,
    /// x in the local metric frame, metres (used as east).
    pub x_m: f64,
    /// y in the local metric frame, metres (used as north).
    pub y_m: f64,
}

/// One tree seen in a scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TreeDetection {
    /// Distance from the laser to the trunk's centre, metres.
    pub range_m: f64,
    /// Bearing in the laser frame, radians: 0 right, π/2 ahead, π left.
    pub bearing_rad: f64,
    /// Trunk diameter, metres.
    pub diameter_m: f64,
}

/// The trees detected in one laser scan.
#[derive(Debug, Clone, PartialEq)]
pub struct TreeScan {
    /// Line of the first detection, from 1.
    pub line: usize,
    /// Scan time, seconds.
    pub t_s: f64,
    /// The detections, in file order.
    pub detections: Vec<TreeDetection>,
}

/// The whole ASCII export.
#[derive(Debug, Clone, PartialEq)]
pub struct VictoriaPark {
    /// `inputs.dat`.
    pub inputs: Vec<DriveInput>,
    /// `gps.dat`.
    pub gps: Vec<LocalGpsFix>,
    /// `measurements.dat`, grouped by scan.
    pub scans: Vec<TreeScan>,
    /// The car's geometry (the documented defaults).
    pub geometry: CarGeometry,
}

impl VictoriaPark {
    /// Reads `inputs.dat`, `gps.dat` and `measurements.dat` from `dir`.
    ///
    /// # Errors
    /// The first malformed line of any of them, or an I/O error.
    pub fn read_dir(dir: impl AsRef<Path>) -> Result<VictoriaPark, LogError> {
        let dir = dir.as_ref();
        Ok(VictoriaPark {
            inputs: read_inputs(dir.join("inputs.dat"))?,
            gps: read_gps(dir.join("gps.dat"))?,
            scans: read_tree_scans(dir.join("measurements.dat"))?,
            geometry: CarGeometry::default(),
        })
    }
}

/// Reads `inputs.dat`.
///
/// # Errors
/// The first malformed line, or an I/O error.
pub fn read_inputs(path: impl AsRef<Path>) -> Result<Vec<DriveInput>, LogError> {
    let path = path.as_ref();
    parse_inputs_from(open_lines(path)?, path)
}

/// Reads `inputs.dat` lines from `text`; `path` names it in errors.
///
/// # Errors
/// The first malformed line.
pub fn parse_inputs(text: &str, path: impl AsRef<Path>) -> Result<Vec<DriveInput>, LogError> {
    parse_inputs_from(text.as_bytes(), path.as_ref())
}

fn parse_inputs_from(
    reader: impl std::io::BufRead,
    path: &Path,
) -> Result<Vec<DriveInput>, LogError> {
    parse_lines(reader, path, |line, text| {
        let mut fields = Fields::new(path, line, "drive input", text);
        let input = DriveInput {
            t_s: fields.number("t")?,
            speed_mps: fields.number("speed")?,
            steer_rad: fields.number("steer")?,
        };
        fields.end()?;
        Ok(input)
    })
}

/// Reads `gps.dat`.
///
/// # Errors
/// The first malformed line, or an I/O error.
pub fn read_gps(path: impl AsRef<Path>) -> Result<Vec<LocalGpsFix>, LogError> {
    let path = path.as_ref();
    parse_gps_from(open_lines(path)?, path)
}

/// Reads `gps.dat` lines from `text`; `path` names it in errors.
///
/// # Errors
/// The first malformed line.
pub fn parse_gps(text: &str, path: impl AsRef<Path>) -> Result<Vec<LocalGpsFix>, LogError> {
    parse_gps_from(text.as_bytes(), path.as_ref())
}

fn parse_gps_from(
    reader: impl std::io::BufRead,
    path: &Path,
) -> Result<Vec<LocalGpsFix>, LogError> {
    parse_lines(reader, path, |line, text| {
        let mut fields = Fields::new(path, line, "GPS fix", text);
        let fix = LocalGpsFix {
            t_s: fields.number("t")?,
            x_m: fields.number("x")?,
            y_m: fields.number("y")?,
        };
        fields.end()?;
        Ok(fix)
    })
}

/// Reads `measurements.dat`, grouping the detections of each scan time.
///
/// # Errors
/// The first malformed line (a time earlier than the line before it included), or an I/O
/// error.
pub fn read_tree_scans(path: impl AsRef<Path>) -> Result<Vec<TreeScan>, LogError> {
    let path = path.as_ref();
    parse_tree_scans_from(open_lines(path)?, path)
}

/// Reads `measurements.dat` lines from `text`; `path` names it in errors.
///
/// # Errors
/// The first malformed line.
pub fn parse_tree_scans(text: &str, path: impl AsRef<Path>) -> Result<Vec<TreeScan>, LogError> {
    parse_tree_scans_from(text.as_bytes(), path.as_ref())
}

fn parse_tree_scans_from(
    reader: impl std::io::BufRead,
    path: &Path,
) -> Result<Vec<TreeScan>, LogError> {
    let mut last_t_s = f64::NEG_INFINITY;
    let lines = parse_lines(reader, path, |line, text| {
        let mut fields = Fields::new(path, line, "tree detection", text);
        let t_s = fields.number("t")?;
        if t_s < last_t_s {
            return Err(fields.error(
                "t",
                FieldProblem::Invalid(format!("{t_s} s is earlier than the line before")),
            ));
        }
        last_t_s = t_s;
        let detection = TreeDetection {
            range_m: fields.number("range")?,
            bearing_rad: fields.number("bearing")?,
            diameter_m: fields.number("diameter")?,
        };
        if detection.range_m <= 0.0 {
            return Err(fields.error("range", FieldProblem::Invalid("not positive".into())));
        }
        if detection.diameter_m < 0.0 {
            return Err(fields.error("diameter", FieldProblem::Invalid("negative".into())));
        }
        fields.end()?;
        Ok((line, t_s, detection))
    })?;
    let mut scans: Vec<TreeScan> = Vec::new();
    for (line, t_s, detection) in lines {
        match scans.last_mut() {
            Some(scan) if scan.t_s == t_s => scan.detections.push(detection),
            _ => scans.push(TreeScan {
                line,
                t_s,
                detections: vec![detection],
            }),
        }
    }
    Ok(scans)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn victoria_park_ascii_export() {
        let Some(dir) =
            datasets::require("victoria_park/rfs_slam_ascii", "victoria_park_ascii_export")
        else {
            return;
        };
        let park = VictoriaPark::read_dir(&dir).unwrap();
        assert_eq!(park.inputs.len(), 61_945);
        assert_eq!(park.gps.len(), 4_466);
        assert_eq!(park.scans.len(), 7_230);
        let detections: usize = park.scans.iter().map(|s| s.detections.len()).sum();
        assert_eq!(detections, 52_974);
        assert_eq!(
            park.inputs[0],
            DriveInput {
                t_s: 0.973,
                speed_mps: 0.0,
                steer_rad: -0.0035
            }
        );
        assert_eq!(
            park.gps[1],
            LocalGpsFix {
                t_s: 1.001,
                x_m: -2.066,
                y_m: -1.840
            }
        );
        let first = &park.scans[0];
        assert_eq!((first.t_s, first.line), (0.852, 1));
        assert_eq!(
            first.detections[0],
            TreeDetection {
                range_m: 20.46202,
                bearing_rad: 0.88575,
                diameter_m: 0.35404
            }
        );
        assert!(park.scans.windows(2).all(|w| w[0].t_s < w[1].t_s));
        assert!(park.scans.iter().all(|s| {
            s.detections
                .iter()
                .all(|d| (0.0..=std::f64::consts::PI).contains(&d.bearing_rad))
        }));
        assert_eq!(park.geometry.l_m, 2.83);
    }

    #[test]
    fn centre_speed_from_the_wheel() {
        let car = CarGeometry::default();
        assert_eq!(car.centre_speed_mps(2.0, 0.0), 2.0);
        // Turning left, the left wheel is on the inside and slower than the centre.
        assert!(car.centre_speed_mps(2.0, 0.1) > 2.0);
    }

    #[test]
    fn malformed_victoria_lines() {
        let err = parse_inputs("0.1 0 0\n0.2 0\n", "inputs.dat").unwrap_err();
        assert_eq!((err.line(), err.field()), (Some(2), Some("steer")));
        assert!(
            err.to_string().starts_with("inputs.dat:2: drive input"),
            "{err}"
        );
        let err = parse_gps("0.1 0 0 7\n", "gps.dat").unwrap_err();
        assert_eq!(err.field(), Some("end of line"));
        let err = parse_tree_scans("1 2 0.5 0.2\n0.5 2 0.5 0.2\n", "m.dat").unwrap_err();
        assert_eq!((err.line(), err.field()), (Some(2), Some("t")));
        let err = parse_tree_scans("1 -2 0.5 0.2\n", "m.dat").unwrap_err();
        assert_eq!(err.field(), Some("range"));
        let err = parse_tree_scans("1 2 x 0.2\n", "m.dat").unwrap_err();
        assert_eq!(err.field(), Some("bearing"));
        let scans = parse_tree_scans("1 2 0.5 0.2\n1 3 0.6 0.2\n2 4 1 0.3\n", "m.dat").unwrap();
        assert_eq!(scans.len(), 2);
        assert_eq!((scans[0].detections.len(), scans[1].line), (2, 3));
    }
}
