//! What the camera method made of a run (`--method camera`): its path geo-referenced by GPS
//! against the camera's truth, and the map's scale from GPS against the scale the truth
//! gives it.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use host::camera::{CameraPipeline, CameraPose, trajectory_error};
use host::georef::{LandmarkInEnu, write_geojson, write_kml};
use nalgebra::Vector3;
use serde::Serialize;

use super::host_side::CameraRecord;

/// The camera part of `summary.json`.
#[derive(Debug, Clone, Serialize)]
pub struct CameraOutcome {
    /// Frames the camera method took.
    pub frames: usize,
    /// GPS fixes paired with the camera's path.
    pub fixes_paired: usize,
    /// Of them, those fused into the camera method's filter (`--camera-fuse-gps`), and
    /// those left out as further from its estimate than the two covariances allow.
    pub fixes_fused: usize,
    pub fixes_gated: usize,
    /// Whether the fixes put the camera's map into the world (GPS) frame.
    pub geo_referenced: bool,
    /// Metres per unit of the camera's map, from GPS.
    pub scale_from_gps: Option<f64>,
    /// Its standard deviation (a priori, from the fixes' covariances).
    pub scale_sigma_from_gps: Option<f64>,
    /// The scale that takes the camera's path onto its true path best (a similarity).
    pub scale_from_truth: Option<f64>,
    /// `scale_from_gps / scale_from_truth − 1`.
    pub scale_error: Option<f64>,
    /// RMS distance of the fixes from the path under the whole run's one similarity (the
    /// fit that gives the scale; the path itself is placed segment by segment), m.
    pub gps_residual_rms_m: Option<f64>,
    /// RMS horizontal distance of the geo-referenced camera from its true position, m.
    pub rms_position_m: Option<f64>,
    /// The scale of the best similarity taking the geo-referenced path (the map as it is
    /// exported, each segment placed by its own fit) onto the true path on the ground (east
    /// and north), less one: how far the exported map's distances are from the true ones.
    /// [`Self::scale_error`] is that of the camera method's own units over the whole run,
    /// one number for a path whose local maps each have their own.
    pub geo_referenced_scale_error: Option<f64>,
    /// The same at the last frame, m.
    pub final_position_m: Option<f64>,
    /// Mean angle between the geo-referenced camera's orientation and the true one, degrees.
    pub mean_rotation_error_deg: Option<f64>,
    /// Length of the camera's true path, m.
    pub travelled_m: f64,
    /// Local maps of the camera method.
    pub local_maps: usize,
    /// Places recognised by its history memory.
    pub places_recognised: usize,
    /// Features deleted as moving, and corners not taken as features as moving.
    pub features_rejected_as_moving: usize,
    pub corners_rejected_as_moving: usize,
}

impl CameraOutcome {
    /// Scores `pipeline`'s path against `records`' truth (the same frames, in order).
    pub fn new(pipeline: &CameraPipeline, records: &[CameraRecord]) -> Self {
        let slam = pipeline.slam_stats();
        let alignment = pipeline.alignment();
        let estimate: Vec<_> = pipeline
            .poses()
            .iter()
            .map(|p| (p.position, p.orientation))
            .collect();
        let truth: Vec<_> = records
            .iter()
            .map(|r| (r.position_m, r.orientation))
            .collect();
        let scale_from_truth = trajectory_error(&estimate, &truth).map(|e| e.scale);
        let travelled_m = records
            .windows(2)
            .map(|w| (w[1].position_m - w[0].position_m).norm())
            .sum();
        let mut outcome = CameraOutcome {
            frames: records.len(),
            fixes_paired: pipeline.stats().fixes_paired,
            fixes_fused: pipeline.stats().fixes_fused,
            fixes_gated: pipeline.stats().fixes_gated,
            geo_referenced: alignment.is_some(),
            scale_from_gps: alignment.map(|a| a.scale),
            scale_sigma_from_gps: alignment.map(|a| a.scale_sigma),
            scale_from_truth,
            scale_error: None,
            gps_residual_rms_m: alignment.map(|a| a.rms_residual_m),
            rms_position_m: None,
            geo_referenced_scale_error: None,
            final_position_m: None,
            mean_rotation_error_deg: None,
            travelled_m,
            local_maps: slam.local_maps,
            places_recognised: slam.places_recognised,
            features_rejected_as_moving: slam.features_rejected_as_moving,
            corners_rejected_as_moving: slam.corners_rejected_as_moving,
        };
        if let (Some(gps), Some(truth)) = (outcome.scale_from_gps, scale_from_truth) {
            outcome.scale_error = Some(gps / truth - 1.0);
        }
        if let Some(in_enu) = pipeline.trajectory_in_enu()
            && !in_enu.is_empty()
        {
            let errors: Vec<f64> = in_enu
                .iter()
                .zip(records)
                .map(|(e, t)| (e.position - t.position_m).xy().norm())
                .collect();
            let n = errors.len() as f64;
            outcome.rms_position_m = Some((errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt());
            outcome.final_position_m = errors.last().copied();
            // On the ground: GPS places the path east and north, not up.
            let on_ground = |(p, q): (Vector3<f64>, _)| (Vector3::new(p.x, p.y, 0.0), q);
            let placed: Vec<_> = in_enu
                .iter()
                .map(|p| on_ground((p.position, p.orientation)))
                .collect();
            let true_ground: Vec<_> = truth.iter().copied().map(on_ground).collect();
            outcome.geo_referenced_scale_error =
                trajectory_error(&placed, &true_ground).map(|e| e.scale - 1.0);
            outcome.mean_rotation_error_deg = Some(
                in_enu
                    .iter()
                    .zip(records)
                    .map(|(e, t)| e.orientation.angle_to(&t.orientation).to_degrees())
                    .sum::<f64>()
                    / n,
            );
        }
        outcome
    }
}

/// Writes `camera_trajectory.tum` (the camera method's path: in the world frame once
/// geo-referenced, else in the first camera's frame) and `camera_ground_truth.tum` (the
/// camera's truth, world frame), `t tx ty tz qx qy qz qw` a line; once geo-referenced,
/// also `camera_map.geojson` and `camera_map.kml`: the path and the map's points in WGS84.
///
/// # Errors
/// A file that cannot be written.
pub fn write_camera_outputs(
    out: &Path,
    pipeline: &CameraPipeline,
    records: &[CameraRecord],
) -> io::Result<()> {
    // The path in the world frame, once: for the TUM file and for the WGS84 exports.
    let in_enu = pipeline.trajectory_in_enu();
    let (poses, frame) = match &in_enu {
        Some(poses) => (
            poses.as_slice(),
            "world frame: east and north at the datum by GPS, up from the first camera's height",
        ),
        None => (
            pipeline.poses(),
            "the first camera's frame (x right, y down, z forward), no metric scale: GPS \
             never spanned enough to align it",
        ),
    };
    write_tum(&out.join("camera_trajectory.tum"), frame, poses)?;
    let truth: Vec<CameraPose> = records
        .iter()
        .map(|r| CameraPose {
            time_s: r.t_s,
            position: r.position_m,
            orientation: r.orientation,
        })
        .collect();
    write_tum(
        &out.join("camera_ground_truth.tum"),
        "world frame: east, north, up at the datum",
        &truth,
    )?;
    let (Some(frame), Some(in_enu), Some(points)) =
        (pipeline.local_frame(), in_enu, pipeline.map_points_in_enu())
    else {
        return Ok(());
    };
    // A point of a feature whose depth ran off to infinity has no place on the Earth.
    let path: Vec<[f64; 2]> = in_enu
        .iter()
        .map(|p| [p.position.x, p.position.y])
        .filter(|p| p.iter().all(|v| v.is_finite()))
        .collect();
    let points: Vec<LandmarkInEnu> = points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.x.is_finite() && p.y.is_finite())
        .map(|(id, p)| LandmarkInEnu {
            id: Some(id as u64),
            position_in_enu_m: [p.x, p.y],
            diameter_m: None,
        })
        .collect();
    let create = |name: &str| fs::File::create(out.join(name)).map(BufWriter::new);
    write_geojson(create("camera_map.geojson")?, frame, &path, &points)
        .map_err(io::Error::other)?;
    write_kml(create("camera_map.kml")?, frame, &path, &points).map_err(io::Error::other)
}

fn write_tum(path: &Path, frame: &str, poses: &[CameraPose]) -> io::Result<()> {
    let mut file = BufWriter::new(fs::File::create(path)?);
    writeln!(file, "# t tx ty tz qx qy qz qw ({frame})")?;
    for pose in poses {
        let [x, y, z] = [pose.position.x, pose.position.y, pose.position.z];
        let q = pose.orientation.quaternion();
        writeln!(
            file,
            "{:.6} {x:.6} {y:.6} {z:.6} {:.9} {:.9} {:.9} {:.9}",
            pose.time_s, q.i, q.j, q.k, q.w
        )?;
    }
    file.flush()
}
