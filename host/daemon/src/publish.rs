//! Turning the pipelines' estimates into the live state: the map-frame pose, trajectory and
//! landmarks, and, once the map is geo-referenced, their latitude, longitude and image pixels.

use crate::state::{GridView, LandmarkView, LiveState, PoseView, TrackingView};
use host::camera::{CameraPipeline, CameraPose};
use host::ekf_slam::EkfPipeline;
use host::geoimage::GeoImage;
use host::geometry::Pose2;
use host::georef::{GeoReferencer, LocalFrame};
use host::grid::{MapExport, MapExportOptions};
use host::slam::GridPipeline;

/// At most this many trajectory points are shown; longer trajectories are thinned evenly.
pub const MAX_SHOWN_TRAJECTORY_POINTS: usize = 2_000;

/// Half the side of the square over which map → pixel is fitted, metres.
const PIXEL_FIT_HALF_SIDE_M: f64 = 200.0;

/// Writes the EKF pipeline's estimate into `state`.
pub fn publish_ekf(state: &mut LiveState, ekf: &EkfPipeline, image: Option<&GeoImage>) {
    let (pose, covariance) = ekf.pose();
    let time_s = ekf.last_pose().map_or(0.0, |p| p.time_s);
    let trajectory_m = ekf
        .thinned_trajectory()
        .map(|p| [p.pose_in_map.x_m, p.pose_in_map.y_m]);
    // Once aligned, the EKF's map frame is the `enu` frame itself.
    let placement = ekf
        .frame()
        .filter(|_| ekf.is_geo_referenced())
        .map(|frame| (*frame, Pose2::IDENTITY));
    let covariance_m2 = [covariance[(0, 0)], covariance[(0, 1)], covariance[(1, 1)]];
    publish_pose(
        state,
        (pose, covariance_m2, time_s),
        trajectory_m,
        placement,
        image,
    );
    // Refilled in place: the shown vectors keep their capacity from one call to the next.
    state.landmarks.clear();
    state
        .landmarks
        .extend(ekf.mapped_landmarks().iter().map(|landmark| {
            let xy = landmark.position_in_map;
            LandmarkView {
                x_m: xy[0],
                y_m: xy[1],
                lat_lon_deg: lon_lat_of(placement, xy).map(|[lon, lat]| [lat, lon]),
            }
        }));
}

/// Writes the camera method's estimate into `state`: the pose and path, and the map's points
/// every `with_map` call; in the `enu` frame once the fixes have aligned the map, in the
/// camera method's own (unscaled) frame before.
pub fn publish_camera(
    state: &mut LiveState,
    camera: &CameraPipeline,
    image: Option<&GeoImage>,
    with_map: bool,
) {
    let Some(last) = camera.poses().last() else {
        return;
    };
    let Some(pose) = camera.pose_at(last.time_s) else {
        return;
    };
    let geo_referenced = camera.is_geo_referenced();
    let trajectory_m: Vec<[f64; 2]> = if geo_referenced {
        let poses = camera.trajectory_in_enu().unwrap_or_default();
        thinned_by_index(poses.len(), MAX_SHOWN_TRAJECTORY_POINTS, |i| {
            poses.get(i).map(|p| [p.position.x, p.position.y])
        })
    } else {
        let poses = camera.poses();
        thinned_by_index(poses.len(), MAX_SHOWN_TRAJECTORY_POINTS, |i| {
            poses.get(i).map(CameraPose::in_map)
        })
    };
    // Aligned, the poses are in the `enu` frame itself.
    let placement = camera
        .local_frame()
        .filter(|_| geo_referenced)
        .map(|frame| (*frame, Pose2::IDENTITY));
    // The camera method gives no metric covariance of its aligned pose: no ellipse is drawn.
    publish_pose(
        state,
        (pose, [0.0; 3], last.time_s),
        trajectory_m,
        placement,
        image,
    );
    if with_map {
        state.landmarks = camera_map_points(camera)
            .into_iter()
            .map(|xy| LandmarkView {
                x_m: xy[0],
                y_m: xy[1],
                lat_lon_deg: lon_lat_of(placement, xy).map(|[lon, lat]| [lat, lon]),
            })
            .collect();
    }
}

/// The camera method's map points on the ground plane: in the `enu` frame once aligned, in
/// its own `map` frame (forward, left of the first camera, unscaled) before.
pub fn camera_map_points(camera: &CameraPipeline) -> Vec<[f64; 2]> {
    match camera.map_points_in_enu() {
        Some(points) => points.iter().map(|p| [p.x, p.y]).collect(),
        None => camera
            .slam()
            .map_points()
            .iter()
            .map(|p| [p.z, -p.x])
            .collect(),
    }
}

/// Writes the grid pipeline's estimate into `state`: the grid always, the pose and trajectory
/// when `owns_pose` (no EKF running), geo-referenced through `georef` once it is aligned.
pub fn publish_grid(
    state: &mut LiveState,
    grid: &GridPipeline,
    owns_pose: bool,
    georef: Option<&GeoReferencer>,
    image: Option<&GeoImage>,
) {
    state.grid = Some(grid_view(grid));
    if owns_pose {
        publish_grid_pose(state, grid, georef, image);
    }
}

/// Writes the grid pipeline's pose and trajectory into `state` (cheap: no grid drawn), with
/// their latitude, longitude and image pixels once `georef` has aligned the map to GPS.
pub fn publish_grid_pose(
    state: &mut LiveState,
    grid: &GridPipeline,
    georef: Option<&GeoReferencer>,
    image: Option<&GeoImage>,
) {
    // Called on every scan: only the poses shown are looked up.
    let scans = grid.scan_count();
    let time_s = scans
        .checked_sub(1)
        .and_then(|last| grid.stamped_pose(last))
        .map_or(0.0, |p| p.0);
    let trajectory_m = thinned_by_index(scans, MAX_SHOWN_TRAJECTORY_POINTS, |i| {
        grid.stamped_pose(i).map(|(_, p)| [p.x_m, p.y_m])
    });
    let placement = georef.and_then(|g| Some((*g.frame()?, g.alignment()?.enu_from_map)));
    state.tracking = Some(TrackingView {
        lost: grid.is_lost(),
        lost_scans: grid.stats().lost_scans,
    });
    // Scan matching against the submap pins the pose to about a cell.
    let covariance_m2 = [0.05f64.powi(2), 0.0, 0.05f64.powi(2)];
    publish_pose(
        state,
        (grid.pose(), covariance_m2, time_s),
        trajectory_m,
        placement,
        image,
    );
}

/// Where a map lies on the Earth: the `enu` frame and `enu_from_map`.
type Placement = Option<(LocalFrame, Pose2)>;

/// `[lon_deg, lat_deg]` of a map point, once the map is placed.
fn lon_lat_of(placement: Placement, xy_in_map: [f64; 2]) -> Option<[f64; 2]> {
    let (frame, enu_from_map) = placement?;
    frame
        .to_lon_lat_deg(enu_from_map.transform_point(xy_in_map))
        .ok()
}

/// Writes the pose (with its `[xx, xy, yy]` position covariance and time), the trajectory and,
/// once the map is placed, their WGS84 positions and the map's place on the image.
fn publish_pose(
    state: &mut LiveState,
    (pose, position_cov_m2, time_s): (Pose2, [f64; 3], f64),
    trajectory_m: impl IntoIterator<Item = [f64; 2]>,
    placement: Placement,
    image: Option<&GeoImage>,
) {
    let pose_lon_lat = lon_lat_of(placement, [pose.x_m, pose.y_m]);
    state.pose = PoseView {
        x_m: pose.x_m,
        y_m: pose.y_m,
        theta_rad: pose.theta_rad,
        lat_deg: pose_lon_lat.map(|p| p[1]),
        lon_deg: pose_lon_lat.map(|p| p[0]),
        position_cov_m2,
        time_s,
    };
    // Refilled in place, so a call allocates nothing once the trajectory is at its shown size.
    state.trajectory_m.clear();
    state.trajectory_m.extend(trajectory_m);
    state.trajectory_wgs84.clear();
    state.trajectory_wgs84.extend(
        state
            .trajectory_m
            .iter()
            .filter_map(|&xy| lon_lat_of(placement, xy)),
    );
    state.datum_lat_lon_deg = placement.map(|(f, _)| [f.datum_lat_deg(), f.datum_lon_deg()]);
    state.enu_from_map = placement.map(|(_, enu_from_map)| enu_from_map);
    state.pixel_from_map = match (placement, image) {
        (Some((frame, enu_from_map)), Some(image)) => {
            let centre_in_enu = enu_from_map.transform_point([pose.x_m, pose.y_m]);
            pixel_from_map(&frame, image, centre_in_enu)
                .map(|pixel_from_enu| compose_affine(pixel_from_enu, enu_from_map))
        }
        _ => None,
    };
}

/// `pixel_from_map` from `pixel_from_enu` (`[a, b, c, d, e, f]` as in
/// [`LiveState::pixel_from_map`]) and the rigid `enu_from_map`.
fn compose_affine(pixel_from_enu: [f64; 6], enu_from_map: Pose2) -> [f64; 6] {
    let [a, b, c, d, e, f] = pixel_from_enu;
    let (sin, cos) = enu_from_map.theta_rad.sin_cos();
    let (tx, ty) = (enu_from_map.x_m, enu_from_map.y_m);
    [
        a + b * tx + c * ty,
        b * cos + c * sin,
        c * cos - b * sin,
        d + e * tx + f * ty,
        e * cos + f * sin,
        f * cos - e * sin,
    ]
}

/// The affine map → pixel transform fitted at three points around `centre_m` (the frame is
/// small enough for the projection to be affine over a few hundred metres).
pub fn pixel_from_map(
    frame: &LocalFrame,
    image: &GeoImage,
    centre_m: [f64; 2],
) -> Option<[f64; 6]> {
    let h = PIXEL_FIT_HALF_SIDE_M;
    let to_pixel = |dx: f64, dy: f64| -> Option<[f64; 2]> {
        let [lon, lat] = frame
            .to_lon_lat_deg([centre_m[0] + dx, centre_m[1] + dy])
            .ok()?;
        image.wgs84_to_pixel(lon, lat).ok()
    };
    let origin = to_pixel(0.0, 0.0)?;
    let east = to_pixel(h, 0.0)?;
    let north = to_pixel(0.0, h)?;
    let b = (east[0] - origin[0]) / h;
    let c = (north[0] - origin[0]) / h;
    let e = (east[1] - origin[1]) / h;
    let f = (north[1] - origin[1]) / h;
    let a = origin[0] - b * centre_m[0] - c * centre_m[1];
    let d = origin[1] - e * centre_m[0] - f * centre_m[1];
    [a, b, c, d, e, f]
        .iter()
        .all(|v| v.is_finite())
        .then_some([a, b, c, d, e, f])
}

/// At most `max` of the `len` items that `at` gives by index, evenly spaced, always with the
/// last; only those are looked up.
fn thinned_by_index<T>(len: usize, max: usize, at: impl Fn(usize) -> Option<T>) -> Vec<T> {
    let step = if len <= max || max < 2 {
        1
    } else {
        len.div_ceil(max - 1)
    };
    let mut indices: Vec<usize> = (0..len).step_by(step).collect();
    if let Some(last) = len.checked_sub(1)
        && !last.is_multiple_of(step)
    {
        indices.push(last);
    }
    indices.into_iter().filter_map(at).collect()
}

/// The grid pipeline's global grid as the live view shows it.
pub fn grid_view(grid: &GridPipeline) -> GridView {
    let export = MapExport::from_grid(&grid.global_grid(), &MapExportOptions::default());
    let mut png = Vec::new();
    // Writing into memory fails only on an empty grid, which shows as no grid.
    let _ = export.write_png(&mut png);
    GridView {
        png,
        resolution_m: export.resolution_m(),
        origin_m: export.lower_corner_in_grid(),
        size_cells: [export.width_px() as u32, export.height_px() as u32],
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn composed_pixel_transform_maps_through_the_alignment() {
        let pixel_from_enu = [10.0, 2.0, 0.5, -3.0, -0.25, -2.0];
        let enu_from_map = super::Pose2::new(5.0, -7.0, 0.8);
        let composed = super::compose_affine(pixel_from_enu, enu_from_map);
        let apply = |m: [f64; 6], [x, y]: [f64; 2]| {
            [m[0] + m[1] * x + m[2] * y, m[3] + m[4] * x + m[5] * y]
        };
        let point_in_map = [3.0, 4.0];
        let expected = apply(pixel_from_enu, enu_from_map.transform_point(point_in_map));
        let got = apply(composed, point_in_map);
        assert!((expected[0] - got[0]).abs() < 1e-12 && (expected[1] - got[1]).abs() < 1e-12);
    }
    use super::*;

    /// `items` thinned as the live view thins a trajectory.
    fn thinned(items: &[usize], max: usize) -> Vec<usize> {
        thinned_by_index(items.len(), max, |i| items.get(i).copied())
    }

    #[test]
    fn thinning_keeps_ends_and_bounds_the_count() {
        let items: Vec<usize> = (0..10_001).collect();
        let out = thinned(&items, 100);
        assert!(out.len() <= 101, "{}", out.len());
        assert_eq!(out.first(), Some(&0));
        assert_eq!(out.last(), Some(&10_000));
        assert_eq!(thinned(&items[..50], 100).len(), 50);
    }
}
