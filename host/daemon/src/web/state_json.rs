//! The body of `GET /api/state`: the live state as the page draws it.
//!
//! Everything in [`LiveState`] but the grid's PNG bytes, which the page fetches from
//! `/api/map.png` only when the grid's `revision` changes, and the camera's JPEG, which it
//! fetches from `/api/camera.jpg` when the camera's `frame` changes.

use std::hash::{DefaultHasher, Hash, Hasher};

use serde::Serialize;

use crate::state::{CameraStatus, GridView, ImageView, LandmarkView, TrackingView};
use crate::{GoalInMap, LinkCounters, LiveState, PoseView};

/// A view of [`LiveState`] borrowed for serialisation.
#[derive(Debug, Serialize)]
pub(crate) struct StateJson<'a> {
    /// The current pose.
    pose: &'a PoseView,
    /// Link and sensor counters.
    counters: &'a LinkCounters,
    /// Trajectory in the map frame, `[x_m, y_m]`, to the millimetre.
    #[serde(serialize_with = "to_millimetres")]
    trajectory_m: &'a [[f64; 2]],
    /// Trajectory in WGS84, `[lon_deg, lat_deg]`, to 1e-8° (about a millimetre).
    #[serde(serialize_with = "to_hundred_millionths")]
    trajectory_wgs84: &'a [[f64; 2]],
    /// Landmarks of the built map.
    landmarks: &'a [LandmarkView],
    /// The occupancy grid's placement, when there is one.
    grid: Option<GridJson>,
    /// Whether the grid method knows where the robot is ("tracking lost" when not).
    tracking: Option<TrackingView>,
    /// The goal last set.
    goal: Option<&'a GoalInMap>,
    /// The geo-referenced image, when there is one.
    image: Option<&'a ImageView>,
    /// Map frame → image pixels, `[a, b, c, d, e, f]`, once geo-referenced.
    pixel_from_map: Option<[f64; 6]>,
    /// The camera's last frame and what the camera method made of it; the frame itself is
    /// at `/api/camera.jpg`.
    camera: Option<&'a CameraStatus>,
}

/// Points rounded to `1 / per_unit`: the page only draws them, and the page asks twice a
/// second; seventeen digits a number take about twice the bytes.
fn rounded_points<S: serde::Serializer>(
    points: &[[f64; 2]],
    per_unit: f64,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    // `+ 0.0` writes a negative zero as `0.0`.
    let round = |v: f64| (v * per_unit).round() / per_unit + 0.0;
    serializer.collect_seq(points.iter().map(|&[a, b]| [round(a), round(b)]))
}

fn to_millimetres<S: serde::Serializer>(
    points: &&[[f64; 2]],
    serializer: S,
) -> Result<S::Ok, S::Error> {
    rounded_points(points, 1e3, serializer)
}

fn to_hundred_millionths<S: serde::Serializer>(
    points: &&[[f64; 2]],
    serializer: S,
) -> Result<S::Ok, S::Error> {
    rounded_points(points, 1e8, serializer)
}

/// Where the occupancy grid lies, without its pixels.
#[derive(Debug, Serialize, PartialEq)]
pub(crate) struct GridJson {
    /// Cell size, metres.
    resolution_m: f64,
    /// Map-frame position of the grid's lower-left corner, metres.
    origin_m: [f64; 2],
    /// Width and height in cells.
    size_cells: [u32; 2],
    /// Changes whenever the PNG changes: a hash of its bytes, in hexadecimal.
    revision: String,
}

impl<'a> From<&'a LiveState> for StateJson<'a> {
    fn from(state: &'a LiveState) -> Self {
        StateJson {
            pose: &state.pose,
            counters: &state.counters,
            trajectory_m: &state.trajectory_m,
            trajectory_wgs84: &state.trajectory_wgs84,
            landmarks: &state.landmarks,
            grid: state.grid.as_ref().map(GridJson::from),
            tracking: state.tracking,
            goal: state.goal.as_ref(),
            image: state.image.as_ref(),
            pixel_from_map: state.pixel_from_map,
            camera: state.camera.as_ref().map(|c| &c.status),
        }
    }
}

impl From<&GridView> for GridJson {
    fn from(grid: &GridView) -> Self {
        let mut hasher = DefaultHasher::new();
        grid.png.hash(&mut hasher);
        GridJson {
            resolution_m: grid.resolution_m,
            origin_m: grid.origin_m,
            size_cells: grid.size_cells,
            revision: format!("{:016x}", hasher.finish()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(png: Vec<u8>) -> GridView {
        GridView {
            png,
            resolution_m: 0.05,
            origin_m: [-1.0, -2.0],
            size_cells: [40, 20],
        }
    }

    #[test]
    fn test_grid_revision_follows_the_png_bytes() {
        let first = GridJson::from(&grid(vec![1, 2, 3]));
        let same = GridJson::from(&grid(vec![1, 2, 3]));
        let changed = GridJson::from(&grid(vec![1, 2, 4]));
        assert_eq!(first.revision, same.revision);
        assert_ne!(first.revision, changed.revision);
    }

    #[test]
    fn test_state_json_leaves_out_the_grid_pixels() {
        let state = LiveState {
            grid: Some(grid(vec![0x89, b'P', b'N', b'G'])),
            ..LiveState::default()
        };
        let json = serde_json::to_value(StateJson::from(&state)).unwrap();
        let grid = &json["grid"];
        assert_eq!(grid["resolution_m"], 0.05);
        assert_eq!(grid["origin_m"], serde_json::json!([-1.0, -2.0]));
        assert_eq!(grid["size_cells"], serde_json::json!([40, 20]));
        assert!(grid.get("png").is_none());
    }

    #[test]
    fn test_trajectories_are_rounded_to_about_a_millimetre() {
        let state = LiveState {
            trajectory_m: vec![[12.345_678_9, -0.000_4]],
            trajectory_wgs84: vec![[7.834_567_891_23, 48.012_345_678_9]],
            ..LiveState::default()
        };
        let json = serde_json::to_string(&StateJson::from(&state)).unwrap();
        assert!(json.contains(r#""trajectory_m":[[12.346,0.0]]"#), "{json}");
        assert!(
            json.contains(r#""trajectory_wgs84":[[7.83456789,48.01234568]]"#),
            "{json}"
        );
    }
}
