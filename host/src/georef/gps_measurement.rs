//! A GPS fix as a 2D position in the `enu` frame with its 2×2 covariance.
//!
//! The position is the fix's latitude and longitude converted by a [`LocalFrame`]; the height
//! used for the conversion is the ellipsoidal one ([`GpsFix::height_m`], the datum height when
//! the altitude is missing). The height barely matters for the horizontal result: an error of
//! `h` metres shifts a fix `d` metres from the datum by about `h · d / 6.4e6` metres.
//!
//! The covariance comes from the best source the report carries, in this order:
//!
//! 1. `$--GST` error ellipse (semi-major, semi-minor axis and orientation, 1σ): the full matrix
//!    `a² u uᵀ + b² v vᵀ`, with `u = (sin φ, cos φ)` the major axis at `φ` clockwise from north
//!    and `v` perpendicular to it. Preferred because it keeps the east-north correlation.
//! 2. `$--GST` latitude and longitude sigmas (1σ): `diag(σ_lon², σ_lat²)`.
//! 3. HDOP × user-equivalent range error (UERE): HDOP scales the UERE to the horizontal DRMS,
//!    `sqrt(σ_e² + σ_n²) = HDOP · UERE`, split evenly over east and north:
//!    `σ_e² = σ_n² = (HDOP · UERE)² / 2`.
//!
//! A GST field of 0 mm, or an HDOP of 0, is read as "not reported" (receivers fill empty fields
//! with zeros; [`GpsFix`] drops them), and the next source is used. The GST sigmas are given in
//! the local frame at the fix; the meridian convergence between it and the datum's frame (under
//! 0.1° within 10 km) is neglected.

use nalgebra::Matrix2;
use protocol::FixQuality;

use super::{GeoRefError, LocalFrame};
use crate::link::{ErrorEllipse, GpsFix};

/// How GPS reports become measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpsMeasurementOptions {
    /// User-equivalent range error, 1σ, metres, that HDOP scales into a horizontal error when
    /// the report carries no GST statistics. Default 3.0 m, a typical autonomous (non-RTK)
    /// single-frequency value; use about 1 m for SBAS/DGPS receivers.
    pub uere_m: f64,
    /// HDOP assumed for reports that carry neither GST statistics nor an HDOP (RMC and GLL
    /// sentences). `None` (the default) rejects them with [`GeoRefError::NoAccuracy`], which
    /// also keeps the RMC of an epoch from doubling the GGA of the same epoch.
    pub assumed_hdop: Option<f64>,
}

impl Default for GpsMeasurementOptions {
    fn default() -> Self {
        GpsMeasurementOptions {
            uere_m: 3.0,
            assumed_hdop: None,
        }
    }
}

/// Which information a measurement's covariance was built from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CovarianceSource {
    /// The GST error ellipse: semi-axes and orientation.
    GstEllipse,
    /// The GST latitude and longitude sigmas.
    GstLatLon,
    /// The report's HDOP times [`GpsMeasurementOptions::uere_m`].
    Hdop,
    /// [`GpsMeasurementOptions::assumed_hdop`] times [`GpsMeasurementOptions::uere_m`].
    AssumedHdop,
    /// A standard deviation given by the caller ([`GpsMeasurement::from_lat_lon`]).
    Given,
}

/// A GPS position in the `enu` frame with its horizontal covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpsMeasurement {
    /// `[east_m, north_m]` of the fix in the `enu` frame.
    pub position_in_enu_m: [f64; 2],
    /// Covariance of `position_in_enu_m`, m², rows and columns ordered east, north.
    pub covariance_in_enu_m2: Matrix2<f64>,
    /// What the covariance was built from.
    pub covariance_source: CovarianceSource,
}

impl GpsMeasurement {
    /// Converts the report `fix` into a measurement in `frame`, with the covariance from the
    /// best source it carries (see the module documentation).
    ///
    /// # Errors
    ///
    /// * [`GeoRefError::NoFix`] if the report has no position or its quality is
    ///   [`FixQuality::Invalid`];
    /// * [`GeoRefError::NoAccuracy`] if it has neither GST statistics nor an HDOP and
    ///   `options.assumed_hdop` is `None`;
    /// * [`GeoRefError::InvalidLatitude`] / [`GeoRefError::InvalidLongitude`] for an
    ///   out-of-range position;
    /// * [`GeoRefError::InvalidOptions`] for a UERE or assumed HDOP that is not finite and
    ///   positive.
    pub fn from_fix(
        fix: &GpsFix,
        frame: &LocalFrame,
        options: &GpsMeasurementOptions,
    ) -> Result<Self, GeoRefError> {
        check_options(options)?;
        let [lat_deg, lon_deg] = match (fix.quality, fix.lat_lon_deg) {
            (FixQuality::Invalid, _) | (_, None) => return Err(GeoRefError::NoFix),
            (_, Some(lat_lon_deg)) => lat_lon_deg,
        };
        let (covariance_in_enu_m2, covariance_source) = fix_covariance_m2(fix, options)?;
        let alt_m = fix.height_m.unwrap_or_else(|| frame.datum_alt_m());
        let [east_m, north_m, _] = frame.to_enu_m(lat_deg, lon_deg, alt_m)?;
        Ok(GpsMeasurement {
            position_in_enu_m: [east_m, north_m],
            covariance_in_enu_m2,
            covariance_source,
        })
    }

    /// As [`GpsMeasurement::from_fix`] in `*frame`; while there is no frame yet, in a new one
    /// at the fix, which is kept only if the fix makes a measurement (a report the measurement
    /// refuses never sets the datum).
    ///
    /// # Errors
    /// As [`GpsMeasurement::from_fix`], and those of [`LocalFrame::new`] for a first fix.
    pub fn in_frame_or_first(
        fix: &GpsFix,
        frame: &mut Option<LocalFrame>,
        options: &GpsMeasurementOptions,
    ) -> Result<Self, GeoRefError> {
        if let Some(frame) = frame {
            return GpsMeasurement::from_fix(fix, frame, options);
        }
        let [lat_deg, lon_deg] = fix.lat_lon_deg.ok_or(GeoRefError::NoFix)?;
        let first = LocalFrame::new(lat_deg, lon_deg, 0.0)?;
        let measurement = GpsMeasurement::from_fix(fix, &first, options)?;
        *frame = Some(first);
        Ok(measurement)
    }

    /// Builds a measurement from a plain position, for logs that carry no NMEA: (`lat_deg`,
    /// `lon_deg`) at the datum's height, with the isotropic standard deviation `sigma_m` on
    /// each of east and north.
    ///
    /// # Errors
    ///
    /// [`GeoRefError::InvalidLatitude`] / [`GeoRefError::InvalidLongitude`] for a NaN or
    /// out-of-range position, [`GeoRefError::InvalidSigma`] unless `sigma_m` is finite and
    /// positive.
    pub fn from_lat_lon(
        frame: &LocalFrame,
        lat_deg: f64,
        lon_deg: f64,
        sigma_m: f64,
    ) -> Result<Self, GeoRefError> {
        if !(sigma_m.is_finite() && sigma_m > 0.0) {
            return Err(GeoRefError::InvalidSigma { sigma_m });
        }
        let [east_m, north_m, _] = frame.to_enu_m(lat_deg, lon_deg, frame.datum_alt_m())?;
        Ok(GpsMeasurement {
            position_in_enu_m: [east_m, north_m],
            covariance_in_enu_m2: Matrix2::identity() * (sigma_m * sigma_m),
            covariance_source: CovarianceSource::Given,
        })
    }
}

fn check_options(options: &GpsMeasurementOptions) -> Result<(), GeoRefError> {
    if !(options.uere_m.is_finite() && options.uere_m > 0.0) {
        return Err(GeoRefError::InvalidOptions(
            "uere_m must be finite and positive",
        ));
    }
    if let Some(hdop) = options.assumed_hdop
        && !(hdop.is_finite() && hdop > 0.0)
    {
        return Err(GeoRefError::InvalidOptions(
            "assumed_hdop must be finite and positive",
        ));
    }
    Ok(())
}

/// The covariance of `fix` in east-north order, m², from its best source.
fn fix_covariance_m2(
    fix: &GpsFix,
    options: &GpsMeasurementOptions,
) -> Result<(Matrix2<f64>, CovarianceSource), GeoRefError> {
    if let Some(ellipse) = &fix.error_ellipse {
        return Ok((ellipse_covariance_m2(ellipse), CovarianceSource::GstEllipse));
    }
    if let Some([lat_sigma_m, lon_sigma_m]) = fix.lat_lon_sigma_m {
        let covariance = Matrix2::new(
            lon_sigma_m * lon_sigma_m,
            0.0,
            0.0,
            lat_sigma_m * lat_sigma_m,
        );
        return Ok((covariance, CovarianceSource::GstLatLon));
    }
    let (hdop, source) = match fix.hdop {
        Some(hdop) => (hdop, CovarianceSource::Hdop),
        None => match options.assumed_hdop {
            Some(hdop) => (hdop, CovarianceSource::AssumedHdop),
            None => return Err(GeoRefError::NoAccuracy),
        },
    };
    let drms_m = hdop * options.uere_m;
    Ok((Matrix2::identity() * (drms_m * drms_m / 2.0), source))
}

/// The covariance of the GST error ellipse, east-north order, m².
fn ellipse_covariance_m2(ellipse: &ErrorEllipse) -> Matrix2<f64> {
    let (major_m, minor_m) = (ellipse.semi_major_m, ellipse.semi_minor_m);
    let (sin, cos) = ellipse.orientation_rad.sin_cos();
    // Unit vectors of the major axis (clockwise from north) and the minor axis, east-north.
    let u = nalgebra::Vector2::new(sin, cos);
    let v = nalgebra::Vector2::new(cos, -sin);
    u * u.transpose() * (major_m * major_m) + v * v.transpose() * (minor_m * minor_m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::{FixSource, GpsFixMsg, GstSigmas, Position};

    fn frame() -> LocalFrame {
        LocalFrame::new(47.3, 8.5, 400.0).unwrap()
    }

    /// A GGA report 1 arc-minute north of the datum with HDOP 1.2 and no GST.
    fn gga_fix() -> GpsFixMsg {
        GpsFixMsg {
            stamp_us: 1_000_000,
            source: FixSource::Gga,
            talker: *b"GP",
            date: None,
            time: None,
            quality: FixQuality::Gps,
            position: Some(Position {
                lat_ndeg: 47_316_666_667,
                lon_ndeg: 8_500_000_000,
            }),
            alt_msl_mm: Some(352_000),
            geoid_sep_mm: Some(48_000),
            num_sats: Some(9),
            hdop_centi: Some(120),
            speed_mm_s: None,
            course_cdeg: None,
            gst: None,
        }
    }

    fn assert_matrix_close(a: Matrix2<f64>, b: Matrix2<f64>) {
        assert!((a - b).abs().max() < 1e-12, "{a} != {b}");
    }

    #[test]
    fn test_position_matches_local_frame() {
        let measurement = GpsMeasurement::from_fix(
            &GpsFix::from_msg(&gga_fix()),
            &frame(),
            &GpsMeasurementOptions::default(),
        )
        .unwrap();
        let [east_m, north_m, _] = frame().to_enu_m(47.316_666_667, 8.5, 400.0).unwrap();
        assert!((measurement.position_in_enu_m[0] - east_m).abs() < 1e-9);
        assert!((measurement.position_in_enu_m[1] - north_m).abs() < 1e-9);
        assert!((north_m - 1853.06).abs() < 0.1, "{north_m}");
    }

    #[test]
    fn test_hdop_covariance() {
        let measurement = GpsMeasurement::from_fix(
            &GpsFix::from_msg(&gga_fix()),
            &frame(),
            &GpsMeasurementOptions::default(),
        )
        .unwrap();
        assert_eq!(measurement.covariance_source, CovarianceSource::Hdop);
        // DRMS = 1.2 * 3 m = 3.6 m, split over two axes: 6.48 m² each.
        assert_matrix_close(measurement.covariance_in_enu_m2, Matrix2::identity() * 6.48);
    }

    #[test]
    fn test_gst_lat_lon_covariance() {
        let mut fix = gga_fix();
        fix.gst = Some(GstSigmas {
            lat_sigma_mm: Some(1_500),
            lon_sigma_mm: Some(800),
            semi_major_mm: Some(0),
            ..GstSigmas::default()
        });
        let measurement = GpsMeasurement::from_fix(
            &GpsFix::from_msg(&fix),
            &frame(),
            &GpsMeasurementOptions::default(),
        )
        .unwrap();
        assert_eq!(measurement.covariance_source, CovarianceSource::GstLatLon);
        assert_matrix_close(
            measurement.covariance_in_enu_m2,
            Matrix2::new(0.64, 0.0, 0.0, 2.25),
        );
    }

    #[test]
    fn test_gst_ellipse_covariance() {
        let mut fix = gga_fix();
        // Major axis 2 m pointing north-east (45°), minor 1 m.
        fix.gst = Some(GstSigmas {
            semi_major_mm: Some(2_000),
            semi_minor_mm: Some(1_000),
            orientation_cdeg: Some(4_500),
            lat_sigma_mm: Some(1_581),
            lon_sigma_mm: Some(1_581),
            ..GstSigmas::default()
        });
        let measurement = GpsMeasurement::from_fix(
            &GpsFix::from_msg(&fix),
            &frame(),
            &GpsMeasurementOptions::default(),
        )
        .unwrap();
        assert_eq!(measurement.covariance_source, CovarianceSource::GstEllipse);
        // Variances (4 + 1) / 2 on each axis, covariance (4 - 1) / 2 (east and north grow
        // together along a north-east axis).
        assert_matrix_close(
            measurement.covariance_in_enu_m2,
            Matrix2::new(2.5, 1.5, 1.5, 2.5),
        );
        // A north-pointing ellipse puts the major axis on north.
        fix.gst = Some(GstSigmas {
            semi_major_mm: Some(2_000),
            semi_minor_mm: Some(1_000),
            orientation_cdeg: Some(0),
            ..GstSigmas::default()
        });
        let measurement = GpsMeasurement::from_fix(
            &GpsFix::from_msg(&fix),
            &frame(),
            &GpsMeasurementOptions::default(),
        )
        .unwrap();
        assert_matrix_close(
            measurement.covariance_in_enu_m2,
            Matrix2::new(1.0, 0.0, 0.0, 4.0),
        );
    }

    #[test]
    fn test_rejects_reports_without_fix() {
        let options = GpsMeasurementOptions::default();
        let mut fix = gga_fix();
        fix.quality = FixQuality::Invalid;
        assert!(matches!(
            GpsMeasurement::from_fix(&GpsFix::from_msg(&fix), &frame(), &options),
            Err(GeoRefError::NoFix)
        ));
        let mut fix = gga_fix();
        fix.position = None;
        assert!(matches!(
            GpsMeasurement::from_fix(&GpsFix::from_msg(&fix), &frame(), &options),
            Err(GeoRefError::NoFix)
        ));
        let mut fix = gga_fix();
        fix.position = Some(Position {
            lat_ndeg: 95_000_000_000,
            lon_ndeg: 0,
        });
        assert!(matches!(
            GpsMeasurement::from_fix(&GpsFix::from_msg(&fix), &frame(), &options),
            Err(GeoRefError::InvalidLatitude { .. })
        ));
        let mut fix = gga_fix();
        fix.position = Some(Position {
            lat_ndeg: 0,
            lon_ndeg: i64::MIN,
        });
        assert!(matches!(
            GpsMeasurement::from_fix(&GpsFix::from_msg(&fix), &frame(), &options),
            Err(GeoRefError::InvalidLongitude { .. })
        ));
    }

    #[test]
    fn test_report_without_accuracy() {
        let mut fix = gga_fix();
        fix.source = FixSource::Rmc;
        fix.hdop_centi = None;
        fix.alt_msl_mm = None;
        assert!(matches!(
            GpsMeasurement::from_fix(
                &GpsFix::from_msg(&fix),
                &frame(),
                &GpsMeasurementOptions::default()
            ),
            Err(GeoRefError::NoAccuracy)
        ));
        let options = GpsMeasurementOptions {
            assumed_hdop: Some(2.0),
            ..GpsMeasurementOptions::default()
        };
        let measurement =
            GpsMeasurement::from_fix(&GpsFix::from_msg(&fix), &frame(), &options).unwrap();
        assert_eq!(measurement.covariance_source, CovarianceSource::AssumedHdop);
        assert_matrix_close(measurement.covariance_in_enu_m2, Matrix2::identity() * 18.0);
        let bad = GpsMeasurementOptions {
            uere_m: f64::NAN,
            ..GpsMeasurementOptions::default()
        };
        assert!(matches!(
            GpsMeasurement::from_fix(&GpsFix::from_msg(&gga_fix()), &frame(), &bad),
            Err(GeoRefError::InvalidOptions(_))
        ));
    }

    #[test]
    fn test_from_lat_lon() {
        let measurement = GpsMeasurement::from_lat_lon(&frame(), 47.3, 8.5, 2.0).unwrap();
        assert!(measurement.position_in_enu_m[0].abs() < 1e-9);
        assert!(measurement.position_in_enu_m[1].abs() < 1e-9);
        assert_matrix_close(measurement.covariance_in_enu_m2, Matrix2::identity() * 4.0);
        assert!(matches!(
            GpsMeasurement::from_lat_lon(&frame(), f64::NAN, 8.5, 2.0),
            Err(GeoRefError::InvalidLatitude { .. })
        ));
        assert!(matches!(
            GpsMeasurement::from_lat_lon(&frame(), 47.3, 8.5, 0.0),
            Err(GeoRefError::InvalidSigma { .. })
        ));
    }
}
