//! A GPS fix as the host's algorithms use it: degrees, metres and radians, converted once
//! from the board's message ([`protocol::GpsFixMsg`]: nanodegrees, millimetres, hundredths),
//! at the link's edge, as scans are.
//!
//! Receivers fill fields they do not report with zeros, so a zero HDOP or a zero GST sigma
//! reads as "not reported" here. An orientation of 0 is a real direction (north) and is kept.

use protocol::{FixQuality, FixSource, GpsFixMsg, GstSigmas};

/// The receiver's 1σ horizontal error ellipse (`$--GST`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorEllipse {
    /// Semi-major axis, metres.
    pub semi_major_m: f64,
    /// Semi-minor axis, metres.
    pub semi_minor_m: f64,
    /// Orientation of the major axis, clockwise from true north, radians.
    pub orientation_rad: f64,
}

/// One fix report in SI units. See the [module documentation](self).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpsFix {
    /// The sentence that produced the report.
    pub source: FixSource,
    /// UTC time of the fix, seconds since midnight: the epoch the report belongs to (a
    /// receiver reports one epoch in several sentences).
    pub utc_time_s: Option<f64>,
    /// Fix quality.
    pub quality: FixQuality,
    /// `[lat_deg, lon_deg]` on WGS84, as the report gives it (the board sends one only with a
    /// valid fix; [`GpsFix::has_position`] checks the quality too).
    pub lat_lon_deg: Option<[f64; 2]>,
    /// Height above the WGS84 ellipsoid (altitude above mean sea level plus the geoid
    /// separation, taken as zero when missing), metres; `None` without an altitude.
    pub height_m: Option<f64>,
    /// Satellites used.
    pub satellites: Option<u8>,
    /// Horizontal dilution of precision; `None` when missing or zero.
    pub hdop: Option<f64>,
    /// The GST error ellipse, when both semi-axes and the orientation are reported.
    pub error_ellipse: Option<ErrorEllipse>,
    /// The GST `[latitude, longitude]` 1σ errors, metres, when both are reported.
    pub lat_lon_sigma_m: Option<[f64; 2]>,
    /// Speed over ground, m/s.
    pub speed_mps: Option<f64>,
    /// Course over ground, clockwise from true north, radians.
    pub course_rad: Option<f64>,
}

impl GpsFix {
    /// The board's report in SI units.
    pub fn from_msg(msg: &GpsFixMsg) -> GpsFix {
        GpsFix {
            source: msg.source,
            utc_time_s: msg.time.map(|t| {
                f64::from(t.hour) * 3600.0
                    + f64::from(t.minute) * 60.0
                    + f64::from(t.second)
                    + f64::from(t.micros) * 1e-6
            }),
            quality: msg.quality,
            lat_lon_deg: msg.position.map(|p| [p.lat_deg(), p.lon_deg()]),
            height_m: msg.alt_msl_mm.map(|alt_msl_mm| {
                f64::from(alt_msl_mm) / 1000.0 + f64::from(msg.geoid_sep_mm.unwrap_or(0)) / 1000.0
            }),
            satellites: msg.num_sats,
            hdop: msg
                .hdop_centi
                .filter(|&centi| centi > 0)
                .map(|centi| f64::from(centi) / 100.0),
            error_ellipse: msg.gst.as_ref().and_then(error_ellipse),
            lat_lon_sigma_m: msg.gst.as_ref().and_then(|gst| {
                Some([
                    reported_mm_as_m(gst.lat_sigma_mm)?,
                    reported_mm_as_m(gst.lon_sigma_mm)?,
                ])
            }),
            speed_mps: msg.speed_mm_s.map(|mm_s| f64::from(mm_s) / 1000.0),
            course_rad: msg
                .course_cdeg
                .map(|cdeg| (f64::from(cdeg) / 100.0).to_radians()),
        }
    }

    /// Whether the report carries a valid position.
    pub fn has_position(&self) -> bool {
        self.quality != FixQuality::Invalid && self.lat_lon_deg.is_some()
    }
}

/// The GST error ellipse; `None` unless both semi-axes and the orientation are reported.
fn error_ellipse(gst: &GstSigmas) -> Option<ErrorEllipse> {
    Some(ErrorEllipse {
        semi_major_m: reported_mm_as_m(gst.semi_major_mm)?,
        semi_minor_m: reported_mm_as_m(gst.semi_minor_mm)?,
        orientation_rad: (f64::from(gst.orientation_cdeg?) / 100.0).to_radians(),
    })
}

/// A GST field in millimetres as metres; `None` when missing or zero (not reported).
fn reported_mm_as_m(value_mm: Option<u32>) -> Option<f64> {
    value_mm
        .filter(|&mm| mm > 0)
        .map(|mm| f64::from(mm) / 1000.0)
}

#[cfg(test)]
mod tests {
    use protocol::Position;

    use super::*;

    fn msg() -> GpsFixMsg {
        GpsFixMsg {
            stamp_us: 1,
            source: FixSource::Gga,
            talker: *b"GP",
            date: None,
            time: None,
            quality: FixQuality::Gps,
            position: Some(Position {
                lat_ndeg: 48_123_456_789,
                lon_ndeg: -11_500_000_000,
            }),
            alt_msl_mm: Some(352_000),
            geoid_sep_mm: Some(48_000),
            num_sats: Some(9),
            hdop_centi: Some(120),
            speed_mm_s: Some(1_500),
            course_cdeg: Some(9_000),
            gst: Some(GstSigmas {
                rms_mm: None,
                semi_major_mm: Some(2_000),
                semi_minor_mm: Some(1_000),
                orientation_cdeg: Some(0),
                lat_sigma_mm: Some(1_800),
                lon_sigma_mm: Some(0),
                alt_sigma_mm: None,
            }),
        }
    }

    #[test]
    fn every_field_is_converted_once_to_si() {
        let fix = GpsFix::from_msg(&msg());
        assert_eq!(fix.lat_lon_deg, Some([48.123_456_789, -11.5]));
        assert_eq!(fix.height_m, Some(400.0));
        assert_eq!(fix.hdop, Some(1.2));
        assert_eq!(fix.speed_mps, Some(1.5));
        assert_eq!(fix.course_rad, Some(std::f64::consts::FRAC_PI_2));
        let ellipse = fix.error_ellipse.expect("ellipse");
        assert_eq!((ellipse.semi_major_m, ellipse.semi_minor_m), (2.0, 1.0));
        assert_eq!(ellipse.orientation_rad, 0.0, "north is a direction");
        assert_eq!(fix.lat_lon_sigma_m, None, "a zero sigma is not reported");
        assert!(fix.has_position());
    }

    #[test]
    fn zeros_and_gaps_read_as_not_reported() {
        let fix = GpsFix::from_msg(&GpsFixMsg {
            hdop_centi: Some(0),
            alt_msl_mm: None,
            quality: FixQuality::Invalid,
            gst: None,
            ..msg()
        });
        assert_eq!(fix.hdop, None);
        assert_eq!(fix.height_m, None);
        assert_eq!(fix.error_ellipse, None);
        assert!(!fix.has_position());
    }
}
