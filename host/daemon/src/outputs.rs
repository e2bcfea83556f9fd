//! What a run leaves in its output folder: the trajectory, the map as a PNG, the map drawn
//! over the geo-referenced image, the map and trajectory in WGS84 (GeoJSON, KML), and a
//! summary.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use serde_json::json;
use tiny_skia::{FillRule, Paint, PathBuilder, Pixmap, Stroke, Transform};

use crate::publish::camera_map_points;
use crate::runner::RunOutcome;
use crate::web::render_map_png;
use host::camera::CameraPipeline;
use host::geoimage::GeoImage;
use host::geometry::Pose2;
use host::georef::{LandmarkInEnu, LocalFrame, write_geojson, write_kml};
use host::grid::{MapExport, MapExportOptions};

/// The longer side of the landmark map drawing, pixels.
const MAP_DRAWING_SIDE_PX: u32 = 2000;

/// An output that cannot be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {message}")]
pub struct OutputError {
    /// The file.
    pub path: PathBuf,
    /// Why.
    pub message: String,
}

fn output_error(path: &Path) -> impl Fn(String) -> OutputError + '_ {
    move |message| OutputError {
        path: path.to_path_buf(),
        message,
    }
}

/// The files written, by name.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct WrittenOutputs {
    /// Paths written, in order.
    pub files: Vec<PathBuf>,
}

/// Writes the outputs of `outcome` into `dir`; the map over `image` when there is one and the
/// map is geo-referenced.
///
/// # Errors
/// A file that cannot be written, named.
pub fn write_outputs(
    dir: &Path,
    outcome: &RunOutcome,
    image: Option<&GeoImage>,
) -> Result<WrittenOutputs, OutputError> {
    fs::create_dir_all(dir).map_err(|e| output_error(dir)(e.to_string()))?;
    let mut written = WrittenOutputs::default();
    let path = dir.join("trajectory.tsv");
    let trajectory = trajectory_rows(outcome).map_err(|e| output_error(&path)(e.to_string()))?;
    write_trajectory(&path, &trajectory).map_err(|e| output_error(&path)(e.to_string()))?;
    written.files.push(path);

    let path = dir.join("map.png");
    if let Some(grid) = &outcome.grid {
        let export = MapExport::from_grid(&grid.global_grid(), &MapExportOptions::default());
        export
            .save_png(&path)
            .map_err(|e| output_error(&path)(e.to_string()))?;
        written.files.push(path);
        let yaml = dir.join("map.yaml");
        export
            .save_ros_map(&yaml)
            .map_err(|e| output_error(&yaml)(e.to_string()))?;
        written.files.push(dir.join("map.pgm"));
        written.files.push(yaml);
    } else if let Some(landmarks) = outcome
        .ekf
        .as_ref()
        .map(|ekf| ekf.landmarks_in_map())
        .or_else(|| outcome.camera.as_ref().map(camera_map_points))
    {
        let points: Vec<[f64; 2]> = trajectory.iter().map(|r| [r.1.x_m, r.1.y_m]).collect();
        let png = render_map_png(&points, &landmarks, MAP_DRAWING_SIDE_PX)
            .map_err(|e| output_error(&path)(e.to_string()))?;
        fs::write(&path, png).map_err(|e| output_error(&path)(e.to_string()))?;
        written.files.push(path);
    }

    let geo = geo_referencing(outcome);
    if let Some((frame, enu_from_map, landmarks_in_map)) = &geo {
        let to_enu = |p: [f64; 2]| enu_from_map.transform_point(p);
        // A point that is not a number (a camera feature whose depth ran off) has no place
        // on the Earth: left out rather than failing the export.
        let finite = |p: &[f64; 2]| p.iter().all(|v| v.is_finite());
        let track: Vec<[f64; 2]> = trajectory
            .iter()
            .map(|r| to_enu([r.1.x_m, r.1.y_m]))
            .filter(finite)
            .collect();
        let landmarks_in_enu: Vec<[f64; 2]> = landmarks_in_map
            .iter()
            .map(|&p| to_enu(p))
            .filter(finite)
            .collect();
        let landmarks: Vec<LandmarkInEnu> = landmarks_in_enu
            .iter()
            .enumerate()
            .map(|(id, &p)| LandmarkInEnu {
                id: Some(id as u64),
                position_in_enu_m: p,
                diameter_m: None,
            })
            .collect();
        let path = dir.join("map.geojson");
        let file = File::create(&path).map_err(|e| output_error(&path)(e.to_string()))?;
        write_geojson(BufWriter::new(file), frame, &track, &landmarks)
            .map_err(|e| output_error(&path)(e.to_string()))?;
        written.files.push(path);
        let path = dir.join("map.kml");
        let file = File::create(&path).map_err(|e| output_error(&path)(e.to_string()))?;
        write_kml(BufWriter::new(file), frame, &track, &landmarks)
            .map_err(|e| output_error(&path)(e.to_string()))?;
        written.files.push(path);
        if let Some(image) = image {
            let path = dir.join("map_over_image.png");
            let drawing = draw_over_image(image, frame, &track, &landmarks_in_enu)
                .map_err(output_error(&path))?;
            drawing
                .save_png(&path)
                .map_err(|e| output_error(&path)(e.to_string()))?;
            written.files.push(path);
        }
    }

    let path = dir.join("summary.json");
    let summary = json!({
        "scans": trajectory.len(),
        "counters": outcome.state.counters,
        "ekf": outcome.ekf.as_ref().map(|e| e.stats()),
        "grid": outcome.grid.as_ref().map(|g| g.stats()),
        "geo_referenced": geo.is_some(),
        "landmarks": outcome.ekf.as_ref().map_or(0, |e| e.landmarks_in_map().len()),
        "camera": outcome.camera.as_ref().map(camera_summary),
        "recording": outcome.recording,
        "final_pose": outcome.state.pose,
    });
    fs::write(
        &path,
        serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n",
    )
    .map_err(|e| output_error(&path)(e.to_string()))?;
    written.files.push(path);
    Ok(written)
}

/// The map's geo-referencing, once there is one: the `enu` frame, `enu_from_map` and the
/// landmarks in the map frame. Method 1's map is the `enu` frame itself once aligned; the grid
/// method's is placed by its alignment to the fixes.
fn geo_referencing(outcome: &RunOutcome) -> Option<(LocalFrame, Pose2, Vec<[f64; 2]>)> {
    if let Some(ekf) = &outcome.ekf {
        let frame = ekf.frame().filter(|_| ekf.is_geo_referenced())?;
        return Some((*frame, Pose2::IDENTITY, ekf.landmarks_in_map()));
    }
    if let Some(camera) = &outcome.camera {
        let frame = camera
            .local_frame()
            .filter(|_| camera.is_geo_referenced())?;
        return Some((*frame, Pose2::IDENTITY, camera_map_points(camera)));
    }
    let georef = outcome.grid_georef.as_ref()?;
    let alignment = georef.alignment()?;
    Some((*georef.frame()?, alignment.enu_from_map, Vec::new()))
}

/// The camera method's counts, and its scale from GPS.
fn camera_summary(camera: &CameraPipeline) -> serde_json::Value {
    let slam = camera.slam_stats();
    let fixes = camera.stats();
    json!({
        "frames": slam.frames,
        "features_measured": slam.measured,
        "features_added": slam.added,
        "local_maps": slam.local_maps,
        "places_recognised": slam.places_recognised,
        "features_rejected_as_moving": slam.features_rejected_as_moving,
        "corners_rejected_as_moving": slam.corners_rejected_as_moving,
        "map_points": camera.slam().map_points().len(),
        "fixes": fixes.fixes,
        "fixes_paired": fixes.fixes_paired,
        "fixes_fused": fixes.fixes_fused,
        "fixes_gated": fixes.fixes_gated,
        "geo_referenced": camera.is_geo_referenced(),
        "scale_from_gps": camera.alignment().map(|a| a.scale),
        "scale_sigma": camera.alignment().map(|a| a.scale_sigma),
    })
}

/// `(host_time_s, pose_in_map, lost)` per scan (per frame for the camera method) from the
/// pipeline that owns the pose: `lost` when the grid method's local tracking could not place
/// the scan (never for the EKF or the camera).
fn trajectory_rows(outcome: &RunOutcome) -> io::Result<Vec<(f64, Pose2, bool)>> {
    if let Some(ekf) = &outcome.ekf {
        return Ok(ekf
            .trajectory()?
            .iter()
            .map(|p| (p.time_s, p.pose_in_map, false))
            .collect());
    }
    if let Some(camera) = &outcome.camera {
        return Ok(camera
            .poses()
            .iter()
            .filter_map(|p| Some((p.time_s, camera.pose_at(p.time_s)?, false)))
            .collect());
    }
    Ok(outcome.grid.as_ref().map_or_else(Vec::new, |grid| {
        let lost = grid.lost();
        grid.trajectory()
            .into_iter()
            .enumerate()
            .map(|(i, (t, p))| (t, p, lost.get(i).copied().unwrap_or(false)))
            .collect()
    }))
}

fn write_trajectory(path: &Path, rows: &[(f64, Pose2, bool)]) -> io::Result<()> {
    let mut w = BufWriter::new(File::create(path)?);
    writeln!(w, "# host_time_s\tx_m\ty_m\ttheta_rad\tlost")?;
    for (t, p, lost) in rows {
        writeln!(
            w,
            "{t:.6}\t{:.4}\t{:.4}\t{:.5}\t{}",
            p.x_m,
            p.y_m,
            p.theta_rad,
            u8::from(*lost)
        )?;
    }
    w.flush()
}

/// The map and trajectory (map frame = the local metric frame at the datum) drawn over the
/// geo-referenced image.
///
/// # Errors
/// The image's pixels cannot be decoded.
pub fn draw_over_image(
    image: &GeoImage,
    frame: &LocalFrame,
    trajectory_m: &[[f64; 2]],
    landmarks_m: &[[f64; 2]],
) -> Result<Pixmap, String> {
    let rgba = image.to_rgba8().map_err(|e| e.to_string())?;
    let size = tiny_skia::IntSize::from_wh(image.width(), image.height())
        .ok_or_else(|| "the image is empty".to_string())?;
    let mut pixmap =
        Pixmap::from_vec(rgba, size).ok_or_else(|| "the image's pixels do not fit".to_string())?;
    let to_px = |p: &[f64; 2]| -> Option<(f32, f32)> {
        let [lon, lat] = frame.to_lon_lat_deg(*p).ok()?;
        let [col, row] = image.wgs84_to_pixel(lon, lat).ok()?;
        Some((col as f32, row as f32))
    };
    let trajectory_px: Vec<(f32, f32)> = trajectory_m.iter().filter_map(to_px).collect();
    let landmarks_px: Vec<(f32, f32)> = landmarks_m.iter().filter_map(to_px).collect();
    draw_track_and_landmarks(&mut pixmap, &trajectory_px, &landmarks_px);
    Ok(pixmap)
}

fn draw_track_and_landmarks(
    pixmap: &mut Pixmap,
    trajectory: &[(f32, f32)],
    landmarks: &[(f32, f32)],
) {
    let mut paint = Paint {
        anti_alias: true,
        ..Paint::default()
    };
    if trajectory.len() >= 2 {
        let mut path = PathBuilder::new();
        path.move_to(trajectory[0].0, trajectory[0].1);
        for &(x, y) in &trajectory[1..] {
            path.line_to(x, y);
        }
        if let Some(path) = path.finish() {
            paint.set_color_rgba8(30, 90, 220, 255);
            let stroke = Stroke {
                width: 2.0,
                ..Stroke::default()
            };
            pixmap.stroke_path(&path, &paint, &stroke, Transform::identity(), None);
        }
    }
    paint.set_color_rgba8(230, 40, 40, 255);
    for &(x, y) in landmarks {
        if let Some(circle) = PathBuilder::from_circle(x, y, 3.0) {
            pixmap.fill_path(
                &circle,
                &paint,
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }
}
