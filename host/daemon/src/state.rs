//! What the daemon knows right now: the pose, the maps, the counters. Written by the reader
//! and pipeline threads, read by the web view, the goal API and the live WebSocket.

use std::sync::{Arc, RwLock};

pub use host::PoseView;
use host::geometry::Pose2;
pub use host::link::LinkCounters;
use serde::{Deserialize, Serialize};

/// The live state behind a lock, shared between the daemon's threads.
pub type SharedState = Arc<RwLock<LiveState>>;

/// A landmark of the built map, for display.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LandmarkView {
    /// Position in the map frame, metres.
    pub x_m: f64,
    /// Position in the map frame, metres.
    pub y_m: f64,
    /// Latitude and longitude, degrees (WGS84), when geo-referenced.
    pub lat_lon_deg: Option<[f64; 2]>,
}

/// The current occupancy grid as a PNG, with where it lies in the map frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GridView {
    /// The PNG bytes (8-bit grey: 0 occupied, 255 free, 205 unknown).
    pub png: Vec<u8>,
    /// Cell size, metres.
    pub resolution_m: f64,
    /// Map-frame position of the lower-left corner of the lower-left cell, metres.
    pub origin_m: [f64; 2],
    /// Width and height in cells.
    pub size_cells: [u32; 2],
}

/// Whether the grid method knows where the robot is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TrackingView {
    /// Local tracking could not place the last scan: the pose shown is a prediction until a
    /// scan fits again.
    pub lost: bool,
    /// Scans it could not place so far.
    pub lost_scans: usize,
}

/// A feature the camera method looked for in the last frame: where it predicted it, and its
/// innovation covariance (the search region is its 3σ ellipse).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraFeatureView {
    /// Predicted pixel `[column, row]`.
    pub pixel: [f64; 2],
    /// Innovation covariance `[xx, xy, yy]`, px².
    pub covariance_px2: [f64; 3],
}

/// What the camera shows: its last frame's counts and, with the camera method running, what
/// the method made of it. The frame's JPEG is beside it in [`CameraView::jpeg`].
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraStatus {
    /// Where the frames come from (the device).
    pub source: String,
    /// Frames shown so far: the number of the frame in [`CameraView::jpeg`].
    pub frame: u64,
    /// Host time of that frame, s.
    pub time_s: f64,
    /// Its size, pixels.
    pub size_px: [u32; 2],
    /// Frames taken from the camera.
    pub frames_captured: u64,
    /// Frames the camera method was still busy for (it takes the newest).
    pub frames_skipped: u64,
    /// Frames that could not be decoded.
    pub frames_refused: u64,
    /// Whether the camera method tracks the frames (`slam.method = "camera"`).
    pub tracking: bool,
    /// The features looked for in this frame, with their search ellipses.
    pub features: Vec<CameraFeatureView>,
    /// Features found and used in this frame.
    pub measured: usize,
    /// Features started in this frame, px.
    pub added: Vec<[f64; 2]>,
    /// Corners found moving on their own in this frame, each `[now, a frame before]`, px.
    pub moving: Vec<[[f64; 2]; 2]>,
    /// Local maps so far.
    pub local_maps: usize,
    /// Places recognised so far.
    pub places_recognised: usize,
    /// Features deleted and corners refused as moving, so far.
    pub rejected_as_moving: usize,
    /// The map's scale from GPS (metres per map unit), once the fixes span far enough.
    pub scale_from_gps: Option<f64>,
}

/// Frames the web view can still ask for by number, the newest last.
pub const CAMERA_FRAMES_KEPT: usize = 8;

/// The camera's last frame and its status.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraView {
    /// The newest frames as JPEG with their numbers ([`CameraStatus::frame`]), oldest first,
    /// at most [`CAMERA_FRAMES_KEPT`]: the page that read the status of frame N asks for
    /// frame N, which may no longer be the newest.
    pub jpegs: std::collections::VecDeque<(u64, Arc<Vec<u8>>)>,
    /// The newest frame's counts and what the camera method made of it.
    pub status: CameraStatus,
}

impl CameraView {
    /// Shows `jpeg` as the next frame, taken at host time `time_s`.
    pub fn show(&mut self, jpeg: Arc<Vec<u8>>, time_s: f64, size_px: [u32; 2]) {
        self.status.frame += 1;
        self.status.time_s = time_s;
        self.status.size_px = size_px;
        if self.jpegs.len() == CAMERA_FRAMES_KEPT {
            self.jpegs.pop_front();
        }
        self.jpegs.push_back((self.status.frame, jpeg));
    }

    /// Frame `frame` as JPEG while it is kept; the newest with `None`.
    pub fn jpeg(&self, frame: Option<u64>) -> Option<&Arc<Vec<u8>>> {
        match frame {
            Some(frame) => self.jpegs.iter().find(|(n, _)| *n == frame).map(|(_, j)| j),
            None => self.jpegs.back().map(|(_, j)| j),
        }
    }
}

/// Everything the daemon shows.
#[derive(Debug, Clone, Default)]
pub struct LiveState {
    /// The current pose.
    pub pose: PoseView,
    /// The trajectory so far in the map frame, `[x_m, y_m]`, thinned for display.
    pub trajectory_m: Vec<[f64; 2]>,
    /// The trajectory so far in WGS84, `[lon_deg, lat_deg]`, when geo-referenced.
    pub trajectory_wgs84: Vec<[f64; 2]>,
    /// The landmark map (outdoor method).
    pub landmarks: Vec<LandmarkView>,
    /// The occupancy grid (indoor method), when one is built.
    pub grid: Option<GridView>,
    /// Whether the grid method knows where the robot is (indoor method).
    pub tracking: Option<TrackingView>,
    /// Link and sensor counters.
    pub counters: LinkCounters,
    /// The goal last set, in the map frame.
    pub goal: Option<GoalInMap>,
    /// The geo-referenced image under the map, when there is one.
    pub image: Option<ImageView>,
    /// Map frame → image pixels, once the map is geo-referenced: `[a, b, c, d, e, f]` with
    /// `col = a + b·x_m + c·y_m`, `row = d + e·x_m + f·y_m` (fitted over the map's extent).
    pub pixel_from_map: Option<[f64; 6]>,
    /// The datum `[lat_deg, lon_deg]` of the local metric frame (`enu`), once the map is
    /// geo-referenced.
    pub datum_lat_lon_deg: Option<[f64; 2]>,
    /// Where the map frame lies in the `enu` frame at the datum, once the map is
    /// geo-referenced: the identity for the EKF method (its map becomes the `enu` frame),
    /// the fitted alignment for the grid method.
    pub enu_from_map: Option<Pose2>,
    /// The camera, when there is one.
    pub camera: Option<CameraView>,
}

/// The geo-referenced image the web view draws under the map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImageView {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// The image's CRS, as its reader names it (e.g. `EPSG:32632`).
    pub crs: String,
}

impl LiveState {
    /// A new, empty state behind a lock.
    pub fn shared() -> SharedState {
        Arc::new(RwLock::new(LiveState::default()))
    }
}

/// A goal as the user asks for it: a pixel of the geo-referenced image or a WGS84 position.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum GoalRequest {
    /// A pixel of the image (column, row from the top-left outer corner, may be fractional).
    Pixel {
        /// Column, pixels.
        pixel_x: f64,
        /// Row, pixels.
        pixel_y: f64,
    },
    /// A WGS84 position.
    Geodetic {
        /// Latitude, degrees.
        lat_deg: f64,
        /// Longitude, degrees.
        lon_deg: f64,
    },
}

/// A goal resolved into the map frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GoalInMap {
    /// Goal in the map frame, metres.
    pub x_m: f64,
    /// Goal in the map frame, metres.
    pub y_m: f64,
    /// The goal in WGS84, degrees.
    pub lat_deg: f64,
    /// The goal in WGS84, degrees.
    pub lon_deg: f64,
    /// The goal as a pixel of the image, when there is one.
    pub pixel: Option<[f64; 2]>,
}

/// Why a goal was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GoalError {
    /// The pixel lies outside the image.
    #[error("pixel ({x:.1}, {y:.1}) is outside the {width}×{height} image")]
    OutsideImage {
        /// Column asked for.
        x: f64,
        /// Row asked for.
        y: f64,
        /// Image width, pixels.
        width: u32,
        /// Image height, pixels.
        height: u32,
    },
    /// The position lies outside the built map (farther than the margin from any part of it).
    #[error("({lat_deg:.7}, {lon_deg:.7}) is outside the map: {reason}")]
    OutsideMap {
        /// Latitude asked for, degrees.
        lat_deg: f64,
        /// Longitude asked for, degrees.
        lon_deg: f64,
        /// Why, in words.
        reason: String,
    },
    /// A value that is not a number, or a latitude/longitude out of range.
    #[error("invalid goal: {0}")]
    Invalid(String),
    /// There is no geo-referencing yet (no image, or the map is not aligned to GPS).
    #[error("cannot place a goal yet: {0}")]
    NotGeoreferenced(String),
}

/// Turns a goal request into the map frame: pixel → geodetic → map.
pub trait GoalResolver: Send + Sync {
    /// Resolves `request`, or says why it cannot.
    ///
    /// # Errors
    /// A pixel outside the image, a position outside the map, an invalid number, or no
    /// geo-referencing yet.
    fn resolve(&self, request: &GoalRequest) -> Result<GoalInMap, GoalError>;
}
