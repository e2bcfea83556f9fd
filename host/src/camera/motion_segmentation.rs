//! Motion segmentation: which image points move on their own, from two consecutive frames
//! and the camera's estimated motion between them.
//!
//! A static point seen at pixel `u` now was, one frame earlier, somewhere on `u`'s *epipolar
//! segment* in the previous image: the pixels of the points `R·ray(u) + ρ·t` for every inverse
//! depth `ρ` from 0 (a point at infinity, moved by the rotation alone) to the nearest depth a
//! point may have, where `R`, `t` take the camera now to the camera then. Compensating the
//! camera's motion thus leaves a static point a one-dimensional freedom, its depth; what moves
//! it off the segment is its own motion. Each candidate is looked for in the previous image
//! by NCC of its patch:
//!
//! 1. first in a band around its segment, as wide as the camera's motion is uncertain (the
//!    pixel noise of both sightings and the rotation's standard deviation between the frames,
//!    at the gate's confidence): found there, the point is [`PointMotion::Static`];
//! 2. otherwise within [`MotionSegmentationOptions::search_half_px`] around the segment: found
//!    there with a correlation of at least [`MotionSegmentationOptions::min_correlation`] (a
//!    distinct match, not texture that merely resembles), it is
//!    [`PointMotion::Moving`]; not found at all (newly in view, occluded, changed), it is
//!    [`PointMotion::Unknown`].
//!
//! The test sees motion across the epipolar lines only: a car driving straight ahead of a
//! camera that drives straight moves along them, like a static point at another depth. Such a
//! point is caught over time instead, by the filter's per-feature consistency test
//! ([`super::MonoSlam`]): its measurements stop fitting any one 3D point.

use image::GrayImage;
use nalgebra::{UnitQuaternion, Vector3};

use super::patch::{Patch, search};
use super::pinhole::PinholeCamera;

/// How [`classify`] decides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionSegmentationOptions {
    /// The band around the epipolar segment: squared Mahalanobis distance from it, one degree
    /// of freedom (6.63: 99 %).
    pub gate_chi2: f64,
    /// The patch must correlate this well (NCC) in the band to call a point static.
    pub min_static_correlation: f32,
    /// And this well off the band to call it moving.
    pub min_correlation: f32,
    /// How far around the segment a point that left it is looked for, px.
    pub search_half_px: f64,
}

impl Default for MotionSegmentationOptions {
    fn default() -> Self {
        MotionSegmentationOptions {
            gate_chi2: 6.63,
            min_static_correlation: 0.8,
            min_correlation: 0.9,
            search_half_px: 30.0,
        }
    }
}

/// The camera's motion between the previous frame and this one, as the filter estimates it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameMotion {
    /// `previous_from_current`: a direction in the camera now, in the camera then.
    pub rotation: UnitQuaternion<f64>,
    /// The camera now in the camera then, in the filter's units.
    pub translation: Vector3<f64>,
    /// The rotation's standard deviation between the frames, rad.
    pub rotation_sigma_rad: f64,
    /// The translation's standard deviation between the frames, in the filter's units.
    pub translation_sigma: f64,
    /// A measured pixel's standard deviation, px.
    pub pixel_sigma_px: f64,
    /// The nearest a point may be, in the filter's units.
    pub min_depth: f64,
}

/// What [`classify`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointMotion {
    /// Found on its epipolar segment.
    Static,
    /// Found distinctly off it, at this pixel of the previous image.
    Moving { previous_px: [f64; 2] },
    /// Not found in the previous image.
    Unknown,
}

/// Samples along the segment: inverse depths from 0 to the nearest.
const SEGMENT_SAMPLES: usize = 9;

/// The epipolar segment of `pixel` in the previous image, as a polyline.
fn epipolar_segment(
    camera: &PinholeCamera,
    pixel: [f64; 2],
    motion: &FrameMotion,
) -> Vec<[f64; 2]> {
    let Some(ray) = camera.ray(pixel) else {
        return Vec::new();
    };
    let turned = motion.rotation * ray;
    let max_inverse_depth = 1.0 / motion.min_depth.max(1e-9);
    (0..SEGMENT_SAMPLES)
        .filter_map(|k| {
            let rho = max_inverse_depth * k as f64 / (SEGMENT_SAMPLES - 1) as f64;
            camera.project(&(turned + motion.translation * rho))
        })
        .collect()
}

/// The distance from `p` to the polyline, px.
fn distance_to(polyline: &[[f64; 2]], p: [f64; 2]) -> f64 {
    squared_distance_to(polyline, p).sqrt()
}

/// The squared distance from `p` to the polyline, px²: what a search's test of every pixel
/// of its box compares, without a root per pixel.
fn squared_distance_to(polyline: &[[f64; 2]], p: [f64; 2]) -> f64 {
    let point = |a: [f64; 2]| (a[0] - p[0]).powi(2) + (a[1] - p[1]).powi(2);
    let mut best = polyline.first().map_or(f64::INFINITY, |&a| point(a));
    for pair in polyline.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let length2 = dx * dx + dy * dy;
        if length2 <= 0.0 {
            continue;
        }
        let s = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length2).clamp(0.0, 1.0);
        best = best.min(point([a[0] + s * dx, a[1] + s * dy]));
    }
    best
}

/// The half width of the band around an epipolar segment where a static point lies at the
/// gate's confidence, px: both sightings' pixel noise, the rotation's uncertainty, and the
/// translation's at the nearest depth.
pub fn band_px(
    camera: &PinholeCamera,
    motion: &FrameMotion,
    options: &MotionSegmentationOptions,
) -> f64 {
    let focal_px = camera.fx_px.max(camera.fy_px);
    let rotation_px = focal_px * motion.rotation_sigma_rad;
    let translation_px = focal_px * motion.translation_sigma / motion.min_depth.max(1e-9);
    (options.gate_chi2
        * (2.0 * motion.pixel_sigma_px.powi(2) + rotation_px.powi(2) + translation_px.powi(2)))
    .sqrt()
}

/// How far the pixel `before` of the previous image lies from the epipolar segment of the
/// pixel `now`, px; `None` when the segment is not in view.
pub fn distance_from_segment(
    camera: &PinholeCamera,
    now: [f64; 2],
    before: [f64; 2],
    motion: &FrameMotion,
) -> Option<f64> {
    let segment = epipolar_segment(camera, now, motion);
    (!segment.is_empty()).then(|| distance_to(&segment, before))
}

/// Whether the point at `pixel` of the current image moved on its own since the previous one
/// (the images `[previous, current]`), static points
/// lying within `band_px` of their epipolar segments ([`band_px`] or wider). See the
/// [module documentation](self).
pub fn classify(
    camera: &PinholeCamera,
    [previous, current]: [&GrayImage; 2],
    pixel: [i64; 2],
    motion: &FrameMotion,
    band_px: f64,
    patch_half_px: u32,
    options: &MotionSegmentationOptions,
) -> PointMotion {
    let Some(template) = Patch::from_image(current, pixel, patch_half_px) else {
        return PointMotion::Unknown;
    };
    let segment = epipolar_segment(camera, [pixel[0] as f64, pixel[1] as f64], motion);
    if segment.is_empty() {
        return PointMotion::Unknown;
    }
    let bounds = |margin: f64| -> [[i64; 2]; 2] {
        let (mut min, mut max) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &segment {
            for axis in 0..2 {
                min[axis] = min[axis].min(p[axis]);
                max[axis] = max[axis].max(p[axis]);
            }
        }
        let limit = [
            f64::from(previous.width()) - 1.0,
            f64::from(previous.height()) - 1.0,
        ];
        let clip = |v: f64, axis: usize| v.clamp(0.0, limit[axis]);
        [
            [
                clip(min[0] - margin, 0).floor() as i64,
                clip(min[1] - margin, 1).floor() as i64,
            ],
            [
                clip(max[0] + margin, 0).ceil() as i64,
                clip(max[1] + margin, 1).ceil() as i64,
            ],
        ]
    };
    let near_segment = |limit: f64| {
        let segment = &segment;
        let limit_px2 = limit * limit;
        move |p: [i64; 2]| squared_distance_to(segment, [p[0] as f64, p[1] as f64]) <= limit_px2
    };
    let on_segment = search(&template, previous, bounds(band_px), near_segment(band_px));
    if on_segment.is_some_and(|(_, score)| score >= options.min_static_correlation) {
        return PointMotion::Static;
    }
    let reach = band_px + options.search_half_px;
    match search(&template, previous, bounds(reach), near_segment(reach)) {
        Some((at, score))
            if score >= options.min_correlation && distance_to(&segment, at) > band_px =>
        {
            PointMotion::Moving { previous_px: at }
        }
        _ => PointMotion::Unknown,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> PinholeCamera {
        PinholeCamera::ideal(500.0, 500.0, 100.0, 80.0, [200, 160])
    }

    /// A smooth, non-repeating pattern; `moved` shifts the square `region` by `shift` px.
    fn textured(shift: [f64; 2], region: [[u32; 2]; 2], moved: [f64; 2]) -> GrayImage {
        GrayImage::from_fn(200, 160, |x, y| {
            let inside = (region[0][0]..region[1][0]).contains(&x)
                && (region[0][1]..region[1][1]).contains(&y);
            let s = if inside { moved } else { shift };
            let (x, y) = (f64::from(x) - s[0], f64::from(y) - s[1]);
            let v = 128.0
                + 50.0 * (x * 0.31).sin() * (y * 0.23).cos()
                + 40.0 * (x * 0.07 + y * 0.11).sin()
                + 30.0 * (x * 0.013 * y * 0.017 + 0.5 * x * 0.05).cos();
            image::Luma([v.clamp(0.0, 255.0) as u8])
        })
    }

    fn still(translation: Vector3<f64>) -> FrameMotion {
        FrameMotion {
            rotation: UnitQuaternion::identity(),
            translation,
            rotation_sigma_rad: 0.0005,
            translation_sigma: 0.0,
            pixel_sigma_px: 0.5,
            min_depth: 1.0,
        }
    }

    #[test]
    fn with_a_camera_at_rest_only_the_moved_region_moves() {
        let region = [[110, 20], [180, 90]];
        let previous = textured([0.0, 0.0], region, [0.0, 0.0]);
        let current = textured([0.0, 0.0], region, [0.0, 7.0]);
        let options = MotionSegmentationOptions::default();
        let motion = still(Vector3::zeros());
        let at = |p| {
            classify(
                &camera(),
                [&previous, &current],
                p,
                &motion,
                band_px(&camera(), &motion, &options),
                5,
                &options,
            )
        };
        assert_eq!(at([50, 100]), PointMotion::Static);
        assert_eq!(at([40, 40]), PointMotion::Static);
        match at([140, 55]) {
            PointMotion::Moving { previous_px } => {
                assert!(
                    (previous_px[0] - 140.0).abs() < 0.5 && (previous_px[1] - 48.0).abs() < 0.5,
                    "{previous_px:?}"
                );
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn motion_along_the_epipolar_segment_is_a_depth_and_across_it_a_motion() {
        // The camera moved 2 cm to the right: a static point at depth d appears 10/d px
        // further left now, so the whole scene shifted left by 4 px (depth 2.5) is static;
        // a region shifted down as well moves.
        let region = [[110, 20], [180, 90]];
        let previous = textured([0.0, 0.0], region, [0.0, 0.0]);
        let current = textured([-4.0, 0.0], region, [-4.0, 6.0]);
        let options = MotionSegmentationOptions::default();
        let motion = still(Vector3::new(0.02, 0.0, 0.0));
        let at = |p| {
            classify(
                &camera(),
                [&previous, &current],
                p,
                &motion,
                band_px(&camera(), &motion, &options),
                5,
                &options,
            )
        };
        assert_eq!(at([50, 100]), PointMotion::Static);
        assert!(matches!(at([140, 55]), PointMotion::Moving { .. }));
        // The same shift with the camera moved the other way is no depth at all.
        let backwards = still(Vector3::new(-0.02, 0.0, 0.0));
        let reversed = classify(
            &camera(),
            [&previous, &current],
            [50, 100],
            &backwards,
            band_px(&camera(), &backwards, &options),
            5,
            &options,
        );
        assert!(
            matches!(reversed, PointMotion::Moving { .. }),
            "{reversed:?}"
        );
    }

    #[test]
    fn a_point_not_in_the_previous_image_is_unknown() {
        let previous = GrayImage::from_pixel(200, 160, image::Luma([90]));
        let current = textured([0.0, 0.0], [[0, 0], [0, 0]], [0.0, 0.0]);
        let options = MotionSegmentationOptions::default();
        let motion = still(Vector3::zeros());
        let verdict = classify(
            &camera(),
            [&previous, &current],
            [60, 60],
            &motion,
            1.0,
            5,
            &options,
        );
        assert_eq!(verdict, PointMotion::Unknown);
    }
}
