//! Turning the pipelines' estimates into the live state: the map-frame pose, trajectory and
//! landmarks, and, once the map is geo-referenced, their latitude, longitude and image pixels.

use crate::state::{GridView, LandmarkView, LiveState, PoseView};
use host::ekf_slam::EkfPipeline;
use host::geoimage::GeoImage;
use host::georef::LocalFrame;
use host::grid::{MapExport, MapExportOptions};
use host::slam::GridPipeline;

/// At most this many trajectory points are shown; longer trajectories are thinned evenly.
const MAX_SHOWN_TRAJECTORY_POINTS: usize = 2_000;

/// Half the side of the square over which map → pixel is fitted, metres.
const PIXEL_FIT_HALF_SIDE_M: f64 = 200.0;

/// Writes the EKF pipeline's estimate into `state`.
pub fn publish_ekf(state: &mut LiveState, ekf: &EkfPipeline, image: Option<&GeoImage>) {
    let (pose, covariance) = ekf.pose();
    let frame = ekf.frame().filter(|_| ekf.is_geo_referenced());
    let lon_lat = |xy: [f64; 2]| frame.and_then(|f| f.to_lon_lat_deg(xy).ok());
    let pose_lon_lat = lon_lat([pose[0], pose[1]]);
    state.pose = PoseView {
        x_m: pose[0],
        y_m: pose[1],
        theta_rad: pose[2],
        lat_deg: pose_lon_lat.map(|p| p[1]),
        lon_deg: pose_lon_lat.map(|p| p[0]),
        position_cov_m2: [covariance[(0, 0)], covariance[(0, 1)], covariance[(1, 1)]],
        time_s: ekf.trajectory().last().map_or(0.0, |p| p.time_s),
    };
    let trajectory = thinned(ekf.trajectory(), MAX_SHOWN_TRAJECTORY_POINTS);
    state.trajectory_m = trajectory
        .iter()
        .map(|p| [p.pose_in_map[0], p.pose_in_map[1]])
        .collect();
    state.trajectory_wgs84 = state
        .trajectory_m
        .iter()
        .filter_map(|&xy| lon_lat(xy))
        .collect();
    state.landmarks = ekf
        .landmarks_in_map()
        .into_iter()
        .map(|xy| LandmarkView {
            x_m: xy[0],
            y_m: xy[1],
            lat_lon_deg: lon_lat(xy).map(|[lon, lat]| [lat, lon]),
        })
        .collect();
    state.datum_lat_lon_deg = frame.map(|f| [f.datum_lat_deg(), f.datum_lon_deg()]);
    state.pixel_from_map = match (frame, image) {
        (Some(frame), Some(image)) => pixel_from_map(frame, image, [pose[0], pose[1]]),
        _ => None,
    };
}

/// Writes the grid pipeline's estimate into `state`: the grid always, the pose and trajectory
/// when `owns_pose` (no EKF running).
pub fn publish_grid(state: &mut LiveState, grid: &GridPipeline, owns_pose: bool) {
    state.grid = Some(grid_view(grid));
    if owns_pose {
        publish_grid_pose(state, grid);
    }
}

/// Writes the grid pipeline's pose and trajectory into `state` (cheap: no grid drawn).
pub fn publish_grid_pose(state: &mut LiveState, grid: &GridPipeline) {
    let pose = grid.pose();
    let trajectory = grid.trajectory();
    state.pose = PoseView {
        x_m: pose.x_m,
        y_m: pose.y_m,
        theta_rad: pose.theta_rad,
        lat_deg: None,
        lon_deg: None,
        // Scan matching against the submap pins the pose to about a cell.
        position_cov_m2: [0.05f64.powi(2), 0.0, 0.05f64.powi(2)],
        time_s: trajectory.last().map_or(0.0, |p| p.0),
    };
    state.trajectory_m = thinned(&trajectory, MAX_SHOWN_TRAJECTORY_POINTS)
        .iter()
        .map(|(_, p)| [p.x_m, p.y_m])
        .collect();
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

/// At most `max` items of `items`, evenly spaced, always with the last.
fn thinned<T: Clone>(items: &[T], max: usize) -> Vec<T> {
    if items.len() <= max || max < 2 {
        return items.to_vec();
    }
    let step = items.len().div_ceil(max - 1);
    let mut out: Vec<T> = items.iter().step_by(step).cloned().collect();
    if let Some(last) = items.last()
        && !(items.len() - 1).is_multiple_of(step)
    {
        out.push(last.clone());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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
