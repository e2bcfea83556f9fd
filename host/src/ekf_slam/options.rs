//! Settings of the EKF submapping SLAM, each with a default that works on a car in a park.

use super::history_memory::HistoryMemoryOptions;
use super::jcbb::JcbbOptions;

/// How observations are paired with landmarks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssociationOptions {
    /// Confidence of the individual (per pairing) chi-square gate. It only shortlists
    /// candidates for the joint test ([`JcbbOptions::confidence`]), so it is set wider: an
    /// observation of a known landmark that fails it is dropped as ambiguous, and those are
    /// the observations with the largest innovations, the ones that would correct the
    /// largest errors. Dropping them makes the filter over-confident.
    pub individual_confidence: f64,
    /// The joint compatibility search.
    pub jcbb: JcbbOptions,
    /// An unpaired observation starts a new landmark only if its squared Mahalanobis distance
    /// to every landmark exceeds this; closer ones are ambiguous and dropped.
    pub new_landmark_distance2: f64,
    /// Diameters compatible within this many metres...
    pub diameter_tolerance_m: f64,
    /// ...plus this fraction of the larger diameter.
    pub diameter_tolerance_fraction: f64,
    /// Map joining only: a place the history memory recognised whose pairs the map's
    /// covariance finds implausible is fused only when at least this many trees back it.
    pub min_pairs_against_the_map: usize,
}

impl Default for AssociationOptions {
    /// A 99.7 % individual gate and a 99 % joint one; new landmarks beyond a squared
    /// distance of 25; diameters within 0.15 m + 30 %; a place the map finds implausible needs 15 trees (three times the
    /// place recognition's minimum).
    fn default() -> Self {
        AssociationOptions {
            individual_confidence: 0.997,
            jcbb: JcbbOptions::default(),
            new_landmark_distance2: 25.0,
            diameter_tolerance_m: 0.15,
            diameter_tolerance_fraction: 0.3,
            min_pairs_against_the_map: 15,
        }
    }
}

/// Settings of [`super::SubmapSlam`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubmapSlamOptions {
    /// A local map is closed and joined once it holds this many landmarks; `usize::MAX`
    /// keeps one global EKF.
    pub max_landmarks_per_local_map: usize,
    /// Association within a local map.
    pub association: AssociationOptions,
    /// Association of a finished local map's landmarks with the global map's.
    pub join_association: AssociationOptions,
    /// Landmarks seen fewer times than this are dropped when their local map closes.
    pub min_observations: u32,
    /// Place recognition over the older map when a local map closes; `None` relies on the
    /// join's gate alone.
    pub history: Option<HistoryMemoryOptions>,
}

impl Default for SubmapSlamOptions {
    /// Local maps of 30 landmarks, landmarks kept once seen twice, history memory on.
    fn default() -> Self {
        SubmapSlamOptions {
            max_landmarks_per_local_map: 30,
            association: AssociationOptions::default(),
            join_association: AssociationOptions {
                new_landmark_distance2: 0.0,
                ..AssociationOptions::default()
            },
            min_observations: 2,
            history: Some(HistoryMemoryOptions::default()),
        }
    }
}
