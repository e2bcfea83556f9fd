//! Recorded image sequences in the KITTI odometry and TUM RGB-D layouts, with their
//! calibration and, where present, their ground truth.
//!
//! * KITTI: `image_0/NNNNNN.png`, `times.txt` (one time per frame, seconds), `calib.txt`
//!   (`P0: fx 0 cx 0 0 fy cy 0 0 0 1 0`, rectified, no distortion) and optionally
//!   `poses.txt` (per frame the row-major 3×4 `[R|t]` of the camera in the first frame's
//!   camera frame).
//! * TUM: `rgb.txt` (`time file` per frame), the images it names, `calib.txt` (one line
//!   `fx fy cx cy k1 k2 p1 p2 k3`) and optionally `groundtruth.txt`
//!   (`t tx ty tz qx qy qz qw`, the camera in the motion-capture frame).
//!
//! Lines starting with `#` are comments in every text file.

use std::path::{Path, PathBuf};

use image::GrayImage;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::pinhole::PinholeCamera;

/// What went wrong reading a sequence; names the file and line.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    #[error("{0}: not a KITTI (image_0/, times.txt) or TUM (rgb.txt) sequence folder")]
    UnknownLayout(PathBuf),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {what}")]
    Parse {
        path: PathBuf,
        line: usize,
        what: String,
    },
    #[error("{path}: {source}")]
    Image {
        path: PathBuf,
        source: image::ImageError,
    },
    #[error("{0}: the sequence has no frames")]
    Empty(PathBuf),
}

/// Which layout a folder follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SequenceLayout {
    Kitti,
    Tum,
}

/// One frame of a sequence: when, and where its image is.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameFile {
    pub time_s: f64,
    pub path: PathBuf,
}

/// A true camera pose: `world_from_camera`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruePose {
    pub time_s: f64,
    pub position_m: Vector3<f64>,
    pub orientation: UnitQuaternion<f64>,
}

/// A sequence folder, read. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct CameraSequence {
    pub layout: SequenceLayout,
    pub camera: PinholeCamera,
    pub frames: Vec<FrameFile>,
    /// Empty when the folder has none.
    pub truth: Vec<TruePose>,
}

impl CameraSequence {
    /// Reads the folder's calibration, frame list and ground truth (not the images).
    ///
    /// # Errors
    /// When the folder follows neither layout, or a file is missing or malformed.
    pub fn open(dir: &Path) -> Result<Self, SequenceError> {
        if dir.join("times.txt").is_file() && dir.join("image_0").is_dir() {
            open_kitti(dir)
        } else if dir.join("rgb.txt").is_file() {
            open_tum(dir)
        } else {
            Err(SequenceError::UnknownLayout(dir.to_path_buf()))
        }
    }

    /// The image of frame `index`, as 8-bit grey.
    ///
    /// # Errors
    /// When the file cannot be read or decoded.
    pub fn load(&self, index: usize) -> Result<GrayImage, SequenceError> {
        let path = self
            .frames
            .get(index)
            .map(|f| f.path.clone())
            .unwrap_or_default();
        load_gray(&path)
    }
}

/// Reads `path` as an 8-bit grey image.
///
/// # Errors
/// When the file cannot be read or decoded.
pub fn load_gray(path: &Path) -> Result<GrayImage, SequenceError> {
    let image = image::ImageReader::open(path)
        .map_err(|source| SequenceError::Io {
            path: path.to_path_buf(),
            source,
        })?
        .decode()
        .map_err(|source| SequenceError::Image {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(image.into_luma8())
}

/// The size of the first frame's image, px.
fn first_image_size(dir: &Path, frames: &[FrameFile]) -> Result<(u32, u32), SequenceError> {
    let first = frames
        .first()
        .ok_or_else(|| SequenceError::Empty(dir.to_path_buf()))?;
    image::image_dimensions(&first.path).map_err(|source| SequenceError::Image {
        path: first.path.clone(),
        source,
    })
}

fn read(path: &Path) -> Result<String, SequenceError> {
    std::fs::read_to_string(path).map_err(|source| SequenceError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The non-comment, non-blank lines of `text`, with their 1-based numbers.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, line)| (i + 1, line.trim()))
        .filter(|(_, line)| !line.is_empty() && !line.starts_with('#'))
}

fn numbers(path: &Path, line: usize, fields: &[&str]) -> Result<Vec<f64>, SequenceError> {
    fields
        .iter()
        .map(|field| {
            field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| SequenceError::Parse {
                    path: path.to_path_buf(),
                    line,
                    what: format!("`{field}` is not a finite number"),
                })
        })
        .collect()
}

/// The numbers of a line that must hold one per name of `names` (space-separated).
fn row_of(path: &Path, line: usize, text: &str, names: &str) -> Result<Vec<f64>, SequenceError> {
    let fields: Vec<&str> = text.split_whitespace().collect();
    if fields.len() != names.split_whitespace().count() {
        return Err(parse_error(path, line, format!("expected `{names}`")));
    }
    numbers(path, line, &fields)
}

fn parse_error(path: &Path, line: usize, what: impl Into<String>) -> SequenceError {
    SequenceError::Parse {
        path: path.to_path_buf(),
        line,
        what: what.into(),
    }
}

fn open_kitti(dir: &Path) -> Result<CameraSequence, SequenceError> {
    let calib_path = dir.join("calib.txt");
    let calib = read(&calib_path)?;
    let (line, p0) = data_lines(&calib)
        .find(|(_, l)| l.starts_with("P0:"))
        .ok_or_else(|| parse_error(&calib_path, 1, "no `P0:` line"))?;
    let fields: Vec<&str> = p0["P0:".len()..].split_whitespace().collect();
    if fields.len() != 12 {
        return Err(parse_error(&calib_path, line, "P0 needs 12 numbers"));
    }
    let p = numbers(&calib_path, line, &fields)?;
    let times_path = dir.join("times.txt");
    let times = read(&times_path)?;
    let mut frames = Vec::new();
    for (line, text) in data_lines(&times) {
        let time_s = numbers(&times_path, line, &[text])?[0];
        frames.push(FrameFile {
            time_s,
            path: dir.join("image_0").join(format!("{:06}.png", frames.len())),
        });
    }
    let (width_px, height_px) = first_image_size(dir, &frames)?;
    let camera = PinholeCamera::ideal(p[0], p[5], p[2], p[6], [width_px, height_px]);
    let poses_path = dir.join("poses.txt");
    let mut truth = Vec::new();
    if poses_path.is_file() {
        let poses = read(&poses_path)?;
        for (index, (line, text)) in data_lines(&poses).enumerate() {
            let fields: Vec<&str> = text.split_whitespace().collect();
            if fields.len() != 12 {
                return Err(parse_error(&poses_path, line, "a pose needs 12 numbers"));
            }
            let m = numbers(&poses_path, line, &fields)?;
            let Some(frame) = frames.get(index) else {
                break;
            };
            let rotation = Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
            truth.push(TruePose {
                time_s: frame.time_s,
                position_m: Vector3::new(m[3], m[7], m[11]),
                orientation: UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_eps(
                    &rotation,
                    1e-9,
                    50,
                    Rotation3::identity(),
                )),
            });
        }
    }
    Ok(CameraSequence {
        layout: SequenceLayout::Kitti,
        camera,
        frames,
        truth,
    })
}

fn open_tum(dir: &Path) -> Result<CameraSequence, SequenceError> {
    let calib_path = dir.join("calib.txt");
    let calib = read(&calib_path)?;
    let (line, text) = data_lines(&calib)
        .next()
        .ok_or_else(|| parse_error(&calib_path, 1, "no calibration line"))?;
    let c = row_of(&calib_path, line, text, "fx fy cx cy k1 k2 p1 p2 k3")?;
    let list_path = dir.join("rgb.txt");
    let list = read(&list_path)?;
    let mut frames = Vec::new();
    for (line, text) in data_lines(&list) {
        let fields: Vec<&str> = text.split_whitespace().collect();
        let [time, file] = fields[..] else {
            return Err(parse_error(&list_path, line, "expected `time file`"));
        };
        frames.push(FrameFile {
            time_s: numbers(&list_path, line, &[time])?[0],
            path: dir.join(file),
        });
    }
    let (width_px, height_px) = first_image_size(dir, &frames)?;
    let camera = PinholeCamera {
        radial: [c[4], c[5], c[8]],
        tangential: [c[6], c[7]],
        ..PinholeCamera::ideal(c[0], c[1], c[2], c[3], [width_px, height_px])
    };
    let truth_path = dir.join("groundtruth.txt");
    let mut truth = Vec::new();
    if truth_path.is_file() {
        let text = read(&truth_path)?;
        for (line, row) in data_lines(&text) {
            let v = row_of(&truth_path, line, row, "t tx ty tz qx qy qz qw")?;
            truth.push(TruePose {
                time_s: v[0],
                position_m: Vector3::new(v[1], v[2], v[3]),
                orientation: UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    v[7], v[4], v[5], v[6],
                )),
            });
        }
    }
    Ok(CameraSequence {
        layout: SequenceLayout::Tum,
        camera,
        frames,
        truth,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_of_neither_layout_is_named() {
        let dir = tempfile::tempdir().expect("temp dir");
        let error = CameraSequence::open(dir.path()).expect_err("no layout");
        assert!(error.to_string().contains("not a KITTI"), "{error}");
    }

    #[test]
    fn a_bad_calibration_names_its_line() {
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::write(dir.path().join("rgb.txt"), "# frames\n1.0 rgb/a.png\n").expect("write");
        std::fs::write(
            dir.path().join("calib.txt"),
            "# c\n517 516 318 x 0 0 0 0 0\n",
        )
        .expect("write");
        let error = CameraSequence::open(dir.path()).expect_err("bad calib");
        assert!(error.to_string().contains("calib.txt:2"), "{error}");
        assert!(error.to_string().contains("`x`"), "{error}");
    }
}
