//! A part of a search table's poses: what a search may take where the hypotheses are not the
//! whole table (a robot that lost its heading lies on a ring around where it lost it, and
//! its heading turns with its place on the ring).

/// Poses a search may take ([`super::FastMatcher::match_prepared_within`]), in the frame of the
/// match's poses (the reference scan's).
pub trait PoseRegion {
    /// Whether a pose headed `heading_rad` whose position lies in the rectangle from `min_m`
    /// to `max_m` (metres, each corner's x and y) may lie in the region.
    ///
    /// It may answer `true` where no such pose lies in the region (the search then splits a
    /// block in vain), never `false` where one does. For a rectangle of one point it decides
    /// whether that pose lies in the region.
    fn may_hold(&self, heading_rad: f64, min_m: [f64; 2], max_m: [f64; 2]) -> bool;
}
