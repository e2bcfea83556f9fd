//! A known target: a few corners of known position seen in the first frame, which start the
//! camera method with a metric scale (MonoSLAM's initialisation, Davison et al. 2007).
//!
//! A single camera fixes no scale: without help, the map and the trajectory come out in
//! arbitrary units. Given a target (a printed sheet, a box) whose corners' positions are known
//! and whose corners are found in the first image, each corner enters the filter as a
//! Euclidean point with a small covariance and its patch from the first image; the other
//! features are measured against them, and the run's units are metres.
//!
//! The file is text, one corner per line, `u_px v_px x_m y_m z_m`: the corner's pixel in the
//! first frame and its position in the first camera's frame (x right, y down, z forward).
//! Lines starting with `#` and blank lines are ignored.
//!
//! A flat target (its corners on one plane, as a printed sheet's or the road's) also tells
//! the surface each corner's patch lies on, which the patch warp then uses instead of
//! taking the surface to face the camera.

use nalgebra::{Matrix3, Vector3};

/// One corner of a known target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetCorner {
    /// Where the corner is in the first frame, px.
    pub pixel: [f64; 2],
    /// Where it is in the first camera's frame, m.
    pub position_m: [f64; 3],
}

/// A known target: at least two corners, so that the distance between them fixes a scale.
#[derive(Clone, Debug, PartialEq)]
pub struct KnownTarget {
    pub corners: Vec<TargetCorner>,
}

impl KnownTarget {
    /// The unit normal of the plane the corners lie on, facing the first camera (at the
    /// origin), when there are at least three and they lie on one: off it by no more than
    /// a twentieth of their spread across it, root mean square.
    pub fn surface_normal(&self) -> Option<Vector3<f64>> {
        if self.corners.len() < 3 {
            return None;
        }
        let points: Vec<Vector3<f64>> = self
            .corners
            .iter()
            .map(|c| Vector3::from(c.position_m))
            .collect();
        let centroid = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
        let scatter = points
            .iter()
            .map(|p| (p - centroid) * (p - centroid).transpose())
            .sum::<Matrix3<f64>>()
            / points.len() as f64;
        let eigen = scatter.symmetric_eigen();
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
        let (off, across) = (eigen.eigenvalues[order[0]], eigen.eigenvalues[order[1]]);
        if !(across > 0.0 && off.max(0.0).sqrt() <= across.sqrt() / 20.0) {
            return None;
        }
        let normal = eigen.eigenvectors.column(order[0]).into_owned();
        Some(if normal.dot(&centroid) > 0.0 {
            -normal
        } else {
            normal
        })
    }
}

/// Corners a target needs.
pub const MIN_TARGET_CORNERS: usize = 2;

/// What is wrong with a target file; names the line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TargetError {
    #[error("line {line}: {what}")]
    Line { line: usize, what: String },
    #[error("a known target needs at least {MIN_TARGET_CORNERS} corners; found {0}")]
    TooFewCorners(usize),
    #[error("corner {corner} at pixel ({u_px}, {v_px}): {what}")]
    Corner {
        corner: usize,
        u_px: f64,
        v_px: f64,
        what: &'static str,
    },
}

/// Parses a target file's text. See the [module documentation](self).
///
/// # Errors
/// A line without five numbers, a number that is not finite, a corner behind the camera
/// (`z_m` not positive), or fewer than [`MIN_TARGET_CORNERS`] corners.
pub fn parse_known_target(text: &str) -> Result<KnownTarget, TargetError> {
    let mut corners = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let content = raw.trim();
        if content.is_empty() || content.starts_with('#') {
            continue;
        }
        let fail = |what: String| TargetError::Line { line, what };
        let fields: Vec<&str> = content.split_whitespace().collect();
        if fields.len() != 5 {
            return Err(fail(format!(
                "expected `u_px v_px x_m y_m z_m`, found {} fields",
                fields.len()
            )));
        }
        let mut values = [0.0; 5];
        for (value, (field, name)) in values
            .iter_mut()
            .zip(fields.iter().zip(["u_px", "v_px", "x_m", "y_m", "z_m"]))
        {
            *value = field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| fail(format!("{name}: `{field}` is not a finite number")))?;
        }
        if values[4] <= 0.0 {
            return Err(fail(format!(
                "z_m: {} puts the corner behind the camera",
                values[4]
            )));
        }
        corners.push(TargetCorner {
            pixel: [values[0], values[1]],
            position_m: [values[2], values[3], values[4]],
        });
    }
    if corners.len() < MIN_TARGET_CORNERS {
        return Err(TargetError::TooFewCorners(corners.len()));
    }
    Ok(KnownTarget { corners })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_target_file_is_read_with_its_comments() {
        let text = "# an A4 sheet at 1 m\n160 120 0 0 1\n\n190 120 0.1 0 1\n";
        let target = parse_known_target(text).expect("valid");
        assert_eq!(target.corners.len(), 2);
        assert_eq!(target.corners[1].pixel, [190.0, 120.0]);
        assert_eq!(target.corners[1].position_m, [0.1, 0.0, 1.0]);
    }

    #[test]
    fn a_bad_line_is_named_with_what_is_wrong() {
        let error = parse_known_target("160 120 0 0 1\n190 120 0.1 zero 1\n").unwrap_err();
        assert_eq!(
            error.to_string(),
            "line 2: y_m: `zero` is not a finite number"
        );
        let error = parse_known_target("160 120 0 0 1\n190 120 0.1 0\n").unwrap_err();
        assert!(error.to_string().starts_with("line 2: expected"), "{error}");
        let error = parse_known_target("160 120 0 0 -1\n190 120 0.1 0 1\n").unwrap_err();
        assert!(error.to_string().contains("behind the camera"), "{error}");
        let error = parse_known_target("160 120 0 0 1\n").unwrap_err();
        assert_eq!(error, TargetError::TooFewCorners(1));
        let error = parse_known_target("160 120 0 0 inf\n1 1 1 1 1\n").unwrap_err();
        assert!(error.to_string().contains("z_m"), "{error}");
    }

    #[test]
    fn a_flat_target_knows_its_surface() {
        let corner = |x: f64, y: f64, z: f64| TargetCorner {
            pixel: [0.0, 0.0],
            position_m: [x, y, z],
        };
        // The road 1.65 m below the camera: the normal points up, to the camera (−y).
        let road = KnownTarget {
            corners: vec![
                corner(-1.0, 1.65, 6.0),
                corner(0.5, 1.65, 6.5),
                corner(2.0, 1.65, 12.0),
                corner(-3.0, 1.65, 15.0),
            ],
        };
        let normal = road.surface_normal().expect("flat");
        assert!(
            (normal - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-9,
            "{normal}"
        );
        // A box's corners are not on one plane, and two corners tell no plane.
        let cube = KnownTarget {
            corners: vec![
                corner(0.0, 0.0, 5.0),
                corner(1.0, 0.0, 5.0),
                corner(0.0, 1.0, 5.0),
                corner(0.0, 0.0, 6.0),
            ],
        };
        assert_eq!(cube.surface_normal(), None);
        let pair = KnownTarget {
            corners: road.corners[..2].to_vec(),
        };
        assert_eq!(pair.surface_normal(), None);
    }
}
