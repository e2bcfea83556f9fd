//! The host's outputs as Foxglove's well-known messages (`foxglove.PoseInFrame`,
//! `foxglove.LocationFix`), shared by the recorder and the live view.

use foxglove::messages::{
    CompressedImage, LocationFix, Pose, PoseInFrame, Quaternion, Timestamp, Vector3, location_fix,
};
use protocol::GpsFixMsg;

use super::topics::{CAMERA_FRAME, GPS_FRAME, MAP_FRAME};
use crate::PoseView;

/// A Foxglove timestamp of host time `time_s`, saturated to the representable range.
pub fn timestamp(time_s: f64) -> Timestamp {
    Timestamp::saturating_from_epoch_secs_f64(time_s)
}

/// `pose` in the map frame, heading as a rotation about the z axis.
pub fn pose_in_frame(pose: &PoseView) -> PoseInFrame {
    let half_rad = 0.5 * pose.theta_rad;
    PoseInFrame {
        timestamp: Some(timestamp(pose.time_s)),
        frame_id: MAP_FRAME.to_string(),
        pose: Some(Pose {
            position: Some(Vector3 {
                x: pose.x_m,
                y: pose.y_m,
                z: 0.0,
            }),
            orientation: Some(Quaternion {
                x: 0.0,
                y: 0.0,
                z: half_rad.sin(),
                w: half_rad.cos(),
            }),
        }),
    }
}

/// A camera frame taken at host time `time_s`, as JPEG.
pub fn camera_image(time_s: f64, jpeg: &[u8]) -> CompressedImage {
    CompressedImage {
        timestamp: Some(timestamp(time_s)),
        frame_id: CAMERA_FRAME.to_string(),
        data: jpeg.to_vec().into(),
        format: "jpeg".to_string(),
    }
}

/// `pose` in WGS84, or `None` before the map is geo-referenced.
pub fn pose_location(pose: &PoseView) -> Option<LocationFix> {
    let (lat_deg, lon_deg) = (pose.lat_deg?, pose.lon_deg?);
    Some(LocationFix {
        timestamp: Some(timestamp(pose.time_s)),
        frame_id: MAP_FRAME.to_string(),
        latitude: lat_deg,
        longitude: lon_deg,
        ..Default::default()
    })
}

/// A GPS fix at host time `time_s` in WGS84, or `None` for a report without a position.
///
/// The altitude is above the ellipsoid when the receiver gives the geoid separation, above
/// mean sea level otherwise. With the receiver's error statistics (GST) the covariance is the
/// diagonal of east, north and up variances.
pub fn gps_location(time_s: f64, fix: &GpsFixMsg) -> Option<LocationFix> {
    let position = fix.position?;
    let altitude_mm = fix.alt_msl_mm.map_or(0, i64::from) + fix.geoid_sep_mm.map_or(0, i64::from);
    let variance_m2 = |sigma_mm: Option<u32>| sigma_mm.map(|s| (f64::from(s) * 1e-3).powi(2));
    let gst = fix.gst.unwrap_or_default();
    let (position_covariance, position_covariance_type) = match (
        variance_m2(gst.lon_sigma_mm),
        variance_m2(gst.lat_sigma_mm),
        variance_m2(gst.alt_sigma_mm),
    ) {
        (Some(east), Some(north), Some(up)) => (
            vec![east, 0.0, 0.0, 0.0, north, 0.0, 0.0, 0.0, up],
            location_fix::PositionCovarianceType::DiagonalKnown,
        ),
        _ => (Vec::new(), location_fix::PositionCovarianceType::Unknown),
    };
    Some(LocationFix {
        timestamp: Some(timestamp(time_s)),
        frame_id: GPS_FRAME.to_string(),
        latitude: position.lat_deg(),
        longitude: position.lon_deg(),
        altitude: altitude_mm as f64 * 1e-3,
        position_covariance,
        position_covariance_type: position_covariance_type as i32,
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::{FixQuality, FixSource, GstSigmas, Position};

    fn fix() -> GpsFixMsg {
        GpsFixMsg {
            stamp_us: 1,
            source: FixSource::Gga,
            talker: *b"GP",
            date: None,
            time: None,
            quality: FixQuality::Gps,
            position: Some(Position {
                lat_ndeg: -33_890_000_000,
                lon_ndeg: 151_190_000_000,
            }),
            alt_msl_mm: Some(40_000),
            geoid_sep_mm: Some(22_500),
            num_sats: Some(9),
            hdop_centi: Some(90),
            speed_mm_s: None,
            course_cdeg: None,
            gst: None,
        }
    }

    #[test]
    fn heading_becomes_a_rotation_about_z() {
        let pose = PoseView {
            x_m: 3.0,
            y_m: -2.0,
            theta_rad: std::f64::consts::FRAC_PI_2,
            time_s: 7.25,
            ..Default::default()
        };
        let msg = pose_in_frame(&pose);
        let q = msg.pose.unwrap().orientation.unwrap();
        // Yaw from the quaternion: atan2(2(wz + xy), 1 − 2(y² + z²)).
        let yaw = (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z));
        assert!((yaw - pose.theta_rad).abs() < 1e-12);
        let t = msg.timestamp.unwrap();
        assert_eq!((t.sec(), t.nsec()), (7, 250_000_000));
        assert!(pose_location(&pose).is_none());
    }

    #[test]
    fn fix_position_altitude_and_covariance() {
        let mut f = fix();
        let loc = gps_location(2.0, &f).unwrap();
        assert!((loc.latitude + 33.89).abs() < 1e-12);
        assert!((loc.longitude - 151.19).abs() < 1e-12);
        assert!((loc.altitude - 62.5).abs() < 1e-9);
        assert!(loc.position_covariance.is_empty());

        f.gst = Some(GstSigmas {
            lat_sigma_mm: Some(2_000),
            lon_sigma_mm: Some(1_000),
            alt_sigma_mm: Some(3_000),
            ..Default::default()
        });
        let loc = gps_location(2.0, &f).unwrap();
        assert_eq!(loc.position_covariance[0], 1.0);
        assert_eq!(loc.position_covariance[4], 4.0);
        assert_eq!(loc.position_covariance[8], 9.0);

        f.position = None;
        assert!(gps_location(2.0, &f).is_none());
    }
}
