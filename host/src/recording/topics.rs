//! The topics of a recording and of the live view that the host itself produces.
//!
//! The board's decoded messages have one topic per kind, listed by
//! [`super::board_topic`].

/// The bytes of each read from the serial port, exactly as received: replay feeds them to a
/// [`crate::link::LinkReader`] again. Schemaless, message encoding [`RAW_ENCODING`].
pub const RAW_TOPIC: &str = "/link/raw";

/// The bytes of each write to the serial port (commands and time-sync pings), exactly as
/// sent: replay needs the pings to time the board's acknowledgements. Schemaless, message
/// encoding [`RAW_ENCODING`].
pub const SENT_TOPIC: &str = "/link/sent";

/// A reopened serial port (empty message): replay forgets a partial frame there, as the live
/// reader did. Schemaless, message encoding [`RAW_ENCODING`].
pub const RECONNECT_TOPIC: &str = "/link/reconnect";

/// Message encoding of [`RAW_TOPIC`]: opaque bytes.
pub const RAW_ENCODING: &str = "application/octet-stream";

/// The host's pose estimate in the map frame (`foxglove.PoseInFrame`).
pub const POSE_TOPIC: &str = "/host/pose";

/// The host's pose estimate in WGS84 once the map is geo-referenced (`foxglove.LocationFix`).
pub const POSE_LOCATION_TOPIC: &str = "/host/pose_location";

/// Each GPS fix with a position, in WGS84 (`foxglove.LocationFix`), for Foxglove's map panel.
pub const GPS_LOCATION_TOPIC: &str = "/gps/location";

/// The camera's frames as JPEG (`foxglove.CompressedImage`): Foxglove's image panel shows
/// them, and replay runs the camera method on them again.
pub const CAMERA_IMAGE_TOPIC: &str = "/camera/image";

/// The frame id of camera images (the camera's optical frame).
pub const CAMERA_FRAME: &str = "camera";

/// The link and sensor counters (JSON, live view only).
pub const COUNTERS_TOPIC: &str = "/host/counters";

/// The frame id of poses in the map frame.
pub const MAP_FRAME: &str = "map";

/// The frame id of GPS fixes (the antenna).
pub const GPS_FRAME: &str = "gps";
