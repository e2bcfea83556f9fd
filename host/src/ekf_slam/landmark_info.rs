//! What the filter knows about a landmark besides its position: its measured diameter and
//! how often it was seen.

/// Bookkeeping of one landmark, kept beside its entries of the state vector.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LandmarkInfo {
    /// Mean of the diameters measured so far, metres (`None` when none was measured).
    pub diameter_m: Option<f64>,
    /// Number of diameters in the mean.
    pub diameter_count: u32,
    /// Number of observations associated with the landmark.
    pub observations: u32,
}

impl LandmarkInfo {
    /// A landmark seen once, with the diameter measured then.
    pub fn first_seen(diameter_m: Option<f64>) -> LandmarkInfo {
        LandmarkInfo {
            diameter_m,
            diameter_count: u32::from(diameter_m.is_some()),
            observations: 1,
        }
    }

    /// Records one more observation with its measured diameter.
    pub fn observe(&mut self, diameter_m: Option<f64>) {
        self.observations = self.observations.saturating_add(1);
        if let Some(d) = diameter_m.filter(|d| d.is_finite()) {
            let n = f64::from(self.diameter_count);
            self.diameter_m = Some(self.diameter_m.map_or(d, |mean| (mean * n + d) / (n + 1.0)));
            self.diameter_count = self.diameter_count.saturating_add(1);
        }
    }

    /// Combines what two records of the same landmark know.
    pub fn merge(&mut self, other: &LandmarkInfo) {
        self.observations = self.observations.saturating_add(other.observations);
        match (self.diameter_m, other.diameter_m) {
            (Some(a), Some(b)) => {
                let (na, nb) = (
                    f64::from(self.diameter_count),
                    f64::from(other.diameter_count),
                );
                self.diameter_m = Some((a * na + b * nb) / (na + nb).max(1.0));
                self.diameter_count = self.diameter_count.saturating_add(other.diameter_count);
            }
            (None, Some(_)) => {
                self.diameter_m = other.diameter_m;
                self.diameter_count = other.diameter_count;
            }
            _ => {}
        }
    }

    /// Whether a measured `diameter_m` is compatible with this landmark's: within
    /// `tolerance_m` plus `tolerance_fraction` of the larger one. Always compatible when either
    /// is unknown.
    pub fn diameter_compatible(
        &self,
        diameter_m: Option<f64>,
        tolerance_m: f64,
        tolerance_fraction: f64,
    ) -> bool {
        match (self.diameter_m, diameter_m) {
            (Some(a), Some(b)) => (a - b).abs() <= tolerance_m + tolerance_fraction * a.max(b),
            _ => true,
        }
    }
}
