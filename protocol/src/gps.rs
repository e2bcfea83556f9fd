//! GPS fixes decoded from NMEA sentences.
//!
//! Latitude and longitude are integers in nanodegrees (1e-9 °, about 0.1 mm), converted from
//! the receiver's `ddmm.mmmm` text without floating-point rounding. Other quantities are
//! fixed-point integers in the unit their name gives.

use serde::{Deserialize, Serialize};

/// Which sentence produced a fix report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum FixSource {
    /// `$--GGA`: fix data with quality, satellites, HDOP and altitude.
    Gga,
    /// `$--RMC`: recommended minimum with date, speed and course.
    Rmc,
    /// `$--GLL`: position and time only.
    Gll,
}

/// Fix quality as GGA reports it (RMC/GLL status and mode letters map onto it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum FixQuality {
    /// No fix, or the data is not valid.
    Invalid,
    /// Autonomous GNSS fix.
    Gps,
    /// Differential (DGPS / SBAS).
    Dgps,
    /// Precise positioning service.
    Pps,
    /// RTK with fixed integer ambiguities.
    RtkFixed,
    /// RTK float.
    RtkFloat,
    /// Dead reckoning / estimated.
    Estimated,
    /// Manual input.
    Manual,
    /// Simulator.
    Simulator,
}

impl FixQuality {
    /// The GGA quality digit.
    pub fn gga_digit(self) -> u8 {
        self as u8
    }

    /// Reads a GGA quality digit; `None` for digits NMEA does not define.
    pub fn from_gga_digit(digit: u8) -> Option<Self> {
        Some(match digit {
            0 => FixQuality::Invalid,
            1 => FixQuality::Gps,
            2 => FixQuality::Dgps,
            3 => FixQuality::Pps,
            4 => FixQuality::RtkFixed,
            5 => FixQuality::RtkFloat,
            6 => FixQuality::Estimated,
            7 => FixQuality::Manual,
            8 => FixQuality::Simulator,
            _ => return None,
        })
    }
}

/// A calendar date (UTC).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct Date {
    /// Full year, e.g. 2024.
    pub year: u16,
    /// 1–12.
    pub month: u8,
    /// 1–31.
    pub day: u8,
}

/// A UTC time of day.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct TimeOfDay {
    /// 0–23.
    pub hour: u8,
    /// 0–59.
    pub minute: u8,
    /// 0–60 (60 for a leap second).
    pub second: u8,
    /// Fraction of the second in microseconds.
    pub micros: u32,
}

/// A horizontal position on WGS84.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct Position {
    /// Latitude, north positive, in 1e-9 degrees.
    pub lat_ndeg: i64,
    /// Longitude, east positive, in 1e-9 degrees.
    pub lon_ndeg: i64,
}

impl Position {
    /// Latitude in degrees.
    pub fn lat_deg(&self) -> f64 {
        self.lat_ndeg as f64 / 1e9
    }

    /// Longitude in degrees.
    pub fn lon_deg(&self) -> f64 {
        self.lon_ndeg as f64 / 1e9
    }
}

/// Error statistics from `$--GST` (1-sigma, metres as millimetres).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct GstSigmas {
    /// RMS of the pseudorange residuals, mm.
    pub rms_mm: Option<u32>,
    /// Semi-major axis of the horizontal error ellipse, mm.
    pub semi_major_mm: Option<u32>,
    /// Semi-minor axis of the horizontal error ellipse, mm.
    pub semi_minor_mm: Option<u32>,
    /// Orientation of the semi-major axis from true north, hundredths of a degree.
    pub orientation_cdeg: Option<u32>,
    /// Latitude error, mm.
    pub lat_sigma_mm: Option<u32>,
    /// Longitude error, mm.
    pub lon_sigma_mm: Option<u32>,
    /// Altitude error, mm.
    pub alt_sigma_mm: Option<u32>,
}

/// One fix report. A report without a valid fix has `position: None` and
/// `quality: FixQuality::Invalid`: a no-fix sentence never yields a position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct GpsFixMsg {
    /// Board time (µs since boot) when the sentence's `$` arrived.
    pub stamp_us: u64,
    /// The sentence that produced the report.
    pub source: FixSource,
    /// The two-letter talker (`GP`, `GN`, `GL`, …) as ASCII bytes.
    pub talker: [u8; 2],
    /// UTC date (from RMC; the last one seen for GGA/GLL).
    pub date: Option<Date>,
    /// UTC time of the fix.
    pub time: Option<TimeOfDay>,
    /// Fix quality.
    pub quality: FixQuality,
    /// Position, present only with a valid fix.
    pub position: Option<Position>,
    /// Altitude above mean sea level, mm.
    pub alt_msl_mm: Option<i32>,
    /// Geoid separation (geoid above the WGS84 ellipsoid), mm.
    pub geoid_sep_mm: Option<i32>,
    /// Satellites used in the fix.
    pub num_sats: Option<u8>,
    /// Horizontal dilution of precision, hundredths.
    pub hdop_centi: Option<u16>,
    /// Speed over ground, mm/s.
    pub speed_mm_s: Option<u32>,
    /// Course over ground from true north, hundredths of a degree.
    pub course_cdeg: Option<u32>,
    /// Error statistics of the epoch, when the receiver sends GST.
    pub gst: Option<GstSigmas>,
}
