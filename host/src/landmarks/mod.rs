//! Landmark front end: trees/poles and corners extracted from raw laser scans, for an EKF SLAM
//! with range-bearing landmark observations, and a filter that tells static landmarks from
//! moving objects.
//!
//! The layout follows one concept per file:
//!
//! * [`RangeScan`]: the input, ranges in beam order with their beam angles, sensor frame.
//! * [`segment_scan`] ([`segmentation`]): clusters of consecutive returns by the adaptive
//!   breakpoint detector (Borges and Aldon 2004), each marked where it meets an occlusion edge.
//! * [`fit_circle`] ([`circle_fit`]): Kåsa's algebraic circle refined by Levenberg–Marquardt
//!   on the geometric distance.
//! * [`detect_tree`] ([`tree`]): trunks and poles, a convex arc in a small cluster that agrees
//!   with the free space around it and is not partly hidden; the chord of a thin pole's two or
//!   three returns.
//! * [`split_into_lines`] ([`line_split`]): split-and-merge into total-least-squares lines.
//! * [`find_corners`] ([`corner`]): consecutive lines meeting at 60°–120°.
//! * [`extract_features`] ([`front_end`]): the recipe, scan in, [`Feature`]s out, set by one
//!   [`FrontEndOptions`].
//! * [`StaticFilter`] ([`static_filter`]): tracks in the map frame; a track whose positions
//!   drift is moving.
//!
//! Frames: the sensor frame has `x` forward, `y` left, angles counter-clockwise from `x`; a
//! [`Feature`] is a range and bearing in it. The caller places features in the map frame
//! before handing them to the [`StaticFilter`].

pub mod circle_fit;
pub mod corner;
pub mod feature;
pub mod front_end;
pub mod line_split;
pub mod range_scan;
pub mod segmentation;
pub mod static_filter;
pub mod tree;

#[cfg(test)]
mod test_scene;

pub use circle_fit::{CircleFit, fit_circle};
pub use corner::{Corner, CornerOptions, find_corners};
pub use feature::{Feature, FeatureKind};
pub use front_end::{FrontEndOptions, extract_features};
pub use line_split::{LineSegment, LineSplitOptions, split_into_lines};
pub use range_scan::RangeScan;
pub use segmentation::{Cluster, SegmentationOptions, segment_scan};
pub use static_filter::{StaticFilter, StaticFilterOptions};
pub use tree::{Tree, TreeOptions, detect_tree};
