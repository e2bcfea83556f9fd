//! Commands from the host to the board. The board answers each with an [`crate::AckMsg`].

use serde::{Deserialize, Serialize};

use crate::scan::RangeUnit;

/// Field of view of the laser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum ScanAngle {
    /// 100° (40°–140° of the sensor frame).
    Deg100,
    /// 180°.
    Deg180,
}

impl ScanAngle {
    /// The angle in degrees.
    pub fn degrees(self) -> u16 {
        match self {
            ScanAngle::Deg100 => 100,
            ScanAngle::Deg180 => 180,
        }
    }
}

/// Angular resolution of the laser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub enum AngularResolution {
    /// 0.25° (only with the 100° field of view).
    Quarter,
    /// 0.5°.
    Half,
    /// 1°.
    One,
}

impl AngularResolution {
    /// The resolution in hundredths of a degree.
    pub fn centidegrees(self) -> u16 {
        match self {
            AngularResolution::Quarter => 25,
            AngularResolution::Half => 50,
            AngularResolution::One => 100,
        }
    }
}

/// Set the laser variant and units; the board runs bring-up again with them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct ConfigureLaserCmd {
    /// Field of view.
    pub angle: ScanAngle,
    /// Angular resolution.
    pub resolution: AngularResolution,
    /// Range unit.
    pub unit: RangeUnit,
}

impl ConfigureLaserCmd {
    /// Whether the sensor supports the combination (0.25° needs the 100° field of view).
    pub fn is_supported(&self) -> bool {
        !(self.resolution == AngularResolution::Quarter && self.angle == ScanAngle::Deg180)
    }

    /// Number of values one scan carries with this variant.
    pub fn values_per_scan(&self) -> u16 {
        self.angle.degrees() * 100 / self.resolution.centidegrees() + 1
    }
}

/// Start or stop continuous laser streaming.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct SetStreamingCmd {
    /// `true` to stream, `false` to stop.
    pub enabled: bool,
}

/// Ask the board for a status message now.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct RequestStatusCmd;

/// Clock synchronisation ping: the acknowledgement carries the board time at reception.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct TimeSyncPingCmd {
    /// Host time when the ping was sent, µs, echoed in the acknowledgement.
    pub host_time_us: u64,
}
