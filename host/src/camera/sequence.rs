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

impl SequenceLayout {
    /// Whether the layout's sequences come from a camera looking forward from a road
    /// vehicle, which moves along its optical axis ([`super::ForwardMotionPrior`]): the KITTI
    /// odometry layout is that of the KITTI car's cameras; a TUM RGB-D sequence's camera may
    /// be hand-held and move in any direction.
    pub fn is_forward_looking_vehicle(self) -> bool {
        matches!(self, SequenceLayout::Kitti)
    }
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

/// A camera's position (m) and `world_from_camera`.
pub type PoseInWorld = (Vector3<f64>, UnitQuaternion<f64>);

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

/// The largest side of a frame the readers decode, px.
pub const MAX_FRAME_SIDE_PX: u32 = 8192;

/// Reads `path` as an 8-bit grey image.
///
/// # Errors
/// When the file cannot be read or decoded.
pub fn load_gray(path: &Path) -> Result<GrayImage, SequenceError> {
    let bytes = std::fs::read(path).map_err(|source| SequenceError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode_gray(&bytes, path)
}

/// Decodes `bytes`, the contents of the image file `path`, as 8-bit grey.
///
/// # Errors
/// When they are not an image of a supported format; the error names `path`.
pub fn decode_gray(bytes: &[u8], path: &Path) -> Result<GrayImage, SequenceError> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|source| SequenceError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    // A camera frame is at most 8K on a side and its decoding needs at most 256 MiB: a
    // header that claims more is refused before anything is allocated.
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_FRAME_SIDE_PX);
    limits.max_image_height = Some(MAX_FRAME_SIDE_PX);
    limits.max_alloc = Some(256 * 1024 * 1024);
    reader.limits(limits);
    let image = reader.decode().map_err(|source| SequenceError::Image {
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

/// The intrinsics `[fx, fy, cx, cy]` of the `P0:` line of a KITTI `calib.txt`.
///
/// # Errors
/// No `P0:` line, or one without 12 finite numbers; the error names `path` and the line.
pub fn parse_kitti_calibration(text: &str, path: &Path) -> Result<[f64; 4], SequenceError> {
    let (line, p0) = data_lines(text)
        .find(|(_, l)| l.starts_with("P0:"))
        .ok_or_else(|| parse_error(path, 1, "no `P0:` line"))?;
    let fields: Vec<&str> = p0["P0:".len()..].split_whitespace().collect();
    if fields.len() != 12 {
        return Err(parse_error(path, line, "P0 needs 12 numbers"));
    }
    let p = numbers(path, line, &fields)?;
    Ok([p[0], p[5], p[2], p[6]])
}

/// The times of a KITTI `times.txt`, seconds.
///
/// # Errors
/// A line that is not one finite number; the error names `path` and the line.
pub fn parse_times(text: &str, path: &Path) -> Result<Vec<f64>, SequenceError> {
    data_lines(text)
        .map(|(line, row)| Ok(row_of(path, line, row, "t")?[0]))
        .collect()
}

/// The poses of a KITTI `poses.txt`: position and `world_from_camera` per line.
///
/// # Errors
/// A line without 12 finite numbers; the error names `path` and the line.
pub fn parse_kitti_poses(text: &str, path: &Path) -> Result<Vec<PoseInWorld>, SequenceError> {
    data_lines(text)
        .map(|(line, row)| {
            let m = row_of(
                path,
                line,
                row,
                "r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz",
            )?;
            let rotation = Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
            // Orthonormal with determinant 1, to the precision the files are written with;
            // anything else is refused rather than fitted.
            let orthonormal = (rotation * rotation.transpose() - Matrix3::identity()).amax();
            if !(orthonormal < 1e-3 && (rotation.determinant() - 1.0).abs() < 1e-3) {
                return Err(parse_error(path, line, "not a rotation matrix"));
            }
            let orientation =
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rotation));
            Ok((Vector3::new(m[3], m[7], m[11]), orientation))
        })
        .collect()
}

/// The calibration line of a TUM `calib.txt`: `fx fy cx cy k1 k2 p1 p2 k3`.
///
/// # Errors
/// No such line; the error names `path` and the line.
pub fn parse_tum_calibration(text: &str, path: &Path) -> Result<[f64; 9], SequenceError> {
    let (line, row) = data_lines(text)
        .next()
        .ok_or_else(|| parse_error(path, 1, "no calibration line"))?;
    let c = row_of(path, line, row, "fx fy cx cy k1 k2 p1 p2 k3")?;
    let mut calibration = [0.0; 9];
    calibration.copy_from_slice(&c);
    Ok(calibration)
}

/// The frames of a TUM `rgb.txt`: time and file, per line.
///
/// # Errors
/// A line that is not `time file`; the error names `path` and the line.
pub fn parse_frame_list(text: &str, path: &Path) -> Result<Vec<(f64, String)>, SequenceError> {
    data_lines(text)
        .map(|(line, row)| {
            let fields: Vec<&str> = row.split_whitespace().collect();
            let [time, file] = fields[..] else {
                return Err(parse_error(path, line, "expected `time file`"));
            };
            Ok((numbers(path, line, &[time])?[0], file.to_string()))
        })
        .collect()
}

/// The poses of a TUM `groundtruth.txt` (`t tx ty tz qx qy qz qw`).
///
/// # Errors
/// A line without 8 finite numbers, or whose quaternion is not of unit length (to 1 %);
/// the error names `path` and the line.
pub fn parse_tum_truth(text: &str, path: &Path) -> Result<Vec<TruePose>, SequenceError> {
    data_lines(text)
        .map(|(line, row)| {
            let v = row_of(path, line, row, "t tx ty tz qx qy qz qw")?;
            let q = nalgebra::Quaternion::new(v[7], v[4], v[5], v[6]);
            let deviation = (q.norm() - 1.0).abs();
            if deviation.is_nan() || deviation > 0.01 {
                return Err(parse_error(
                    path,
                    line,
                    "the quaternion is not of unit length",
                ));
            }
            Ok(TruePose {
                time_s: v[0],
                position_m: Vector3::new(v[1], v[2], v[3]),
                orientation: UnitQuaternion::from_quaternion(q),
            })
        })
        .collect()
}

fn open_kitti(dir: &Path) -> Result<CameraSequence, SequenceError> {
    let calib_path = dir.join("calib.txt");
    let [fx, fy, cx, cy] = parse_kitti_calibration(&read(&calib_path)?, &calib_path)?;
    let times_path = dir.join("times.txt");
    let frames: Vec<FrameFile> = parse_times(&read(&times_path)?, &times_path)?
        .into_iter()
        .enumerate()
        .map(|(index, time_s)| FrameFile {
            time_s,
            path: dir.join("image_0").join(format!("{index:06}.png")),
        })
        .collect();
    let (width_px, height_px) = first_image_size(dir, &frames)?;
    let camera = PinholeCamera::ideal(fx, fy, cx, cy, [width_px, height_px]);
    let poses_path = dir.join("poses.txt");
    let mut truth = Vec::new();
    if poses_path.is_file() {
        let poses = parse_kitti_poses(&read(&poses_path)?, &poses_path)?;
        truth = poses
            .into_iter()
            .zip(&frames)
            .map(|((position_m, orientation), frame)| TruePose {
                time_s: frame.time_s,
                position_m,
                orientation,
            })
            .collect();
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
    let c = parse_tum_calibration(&read(&calib_path)?, &calib_path)?;
    let list_path = dir.join("rgb.txt");
    let frames: Vec<FrameFile> = parse_frame_list(&read(&list_path)?, &list_path)?
        .into_iter()
        .map(|(time_s, file)| FrameFile {
            time_s,
            path: dir.join(file),
        })
        .collect();
    let (width_px, height_px) = first_image_size(dir, &frames)?;
    let camera = PinholeCamera {
        radial: [c[4], c[5], c[8]],
        tangential: [c[6], c[7]],
        ..PinholeCamera::ideal(c[0], c[1], c[2], c[3], [width_px, height_px])
    };
    let truth_path = dir.join("groundtruth.txt");
    let truth = if truth_path.is_file() {
        parse_tum_truth(&read(&truth_path)?, &truth_path)?
    } else {
        Vec::new()
    };
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
    fn a_pose_that_is_no_rotation_is_refused_at_once() {
        // Found by the `camera_sequence` fuzz target: fitting a rotation to this matrix
        // did not finish.
        let bytes = include_bytes!(
            "../../fuzz/regressions/camera_sequence/timeout-e591d3baa9881d9b8ea95f183fb324f7ca028381"
        );
        let text = String::from_utf8_lossy(bytes);
        let error = parse_kitti_poses(&text, Path::new("poses.txt")).expect_err("no rotation");
        assert!(error.to_string().contains("poses.txt:"), "{error}");
        let text = "2 0 0 0 0 1 0 0 0 0 1 0\n";
        let error = parse_kitti_poses(text, Path::new("poses.txt")).expect_err("scaled");
        assert!(
            error.to_string().contains("not a rotation matrix"),
            "{error}"
        );
    }

    #[test]
    fn a_pose_without_a_unit_quaternion_is_refused() {
        let text = "# t tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 0\n";
        let error = parse_tum_truth(text, Path::new("groundtruth.txt")).expect_err("zero");
        assert!(error.to_string().contains("groundtruth.txt:3"), "{error}");
    }

    #[test]
    fn a_frame_that_is_no_image_names_its_file() {
        let error = decode_gray(b"\x89PNG not really", Path::new("000001.png")).expect_err("bad");
        assert!(error.to_string().contains("000001.png"), "{error}");
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
