//! A feature's appearance as first seen, warped to how the camera sees it now.
//!
//! A patch taken at a feature's first sighting no longer looks the same once the camera has
//! rolled, turned or come closer: correlated as it was, a feature seen rolled by 30° is not
//! found. As in MonoSLAM, the patch is warped by the predicted change of view before the
//! search, the surface around the feature taken as a small plane facing the camera that
//! first saw it. Each pixel of the template around the predicted pixel is taken along its
//! ray to that plane (through the feature's estimated point), from there to the camera as
//! it was at the first sighting (the camera model, distortion included, both ways), and
//! sampled there, bilinearly, from a crop of the first image kept for it. A feature whose
//! depth is still at infinity is warped by the rotation alone, which is all the view change
//! does to a point that far.

use image::GrayImage;
use nalgebra::{UnitQuaternion, Vector3};

use super::patch::{Patch, sample};
use super::pinhole::PinholeCamera;

/// The first sighting: a crop of the image around it and the camera's orientation then.
#[derive(Clone, Debug)]
pub struct Appearance {
    /// The crop, row-major, `side × side`.
    crop: Vec<f32>,
    side: usize,
    /// The first sighting's frame and pixel in the full image, and the crop's corner pixel.
    frame: usize,
    pixel: [f64; 2],
    corner: [i64; 2],
    /// The camera at the first sighting: its position and `world_from_camera`.
    position: Vector3<f64>,
    orientation: UnitQuaternion<f64>,
    /// The surface's unit normal in the world frame, where it is known (a flat known
    /// target's); else the surface is taken to face the first camera.
    normal: Option<Vector3<f64>>,
}

impl Appearance {
    /// Keeps the crop of `image` (frame number `frame`) within `half_px` of `pixel`
    /// (integer), seen with the camera at `position` and `orientation`; `None` when the crop
    /// does not fit in the image.
    pub fn new(
        frame: usize,
        image: &GrayImage,
        pixel: [i64; 2],
        half_px: u32,
        position: Vector3<f64>,
        orientation: UnitQuaternion<f64>,
    ) -> Option<Self> {
        let crop = sample(image, pixel, half_px)?;
        let half = i64::from(half_px);
        Some(Appearance {
            crop,
            side: (2 * half + 1) as usize,
            frame,
            pixel: [pixel[0] as f64, pixel[1] as f64],
            corner: [pixel[0] - half, pixel[1] - half],
            position,
            orientation,
            normal: None,
        })
    }

    /// The first sighting: its frame number and pixel.
    pub fn sighting(&self) -> (usize, [f64; 2]) {
        (self.frame, self.pixel)
    }

    /// The same sighting of a surface whose unit normal (world frame) is known.
    pub fn with_normal(self, normal: Vector3<f64>) -> Self {
        Appearance {
            normal: normal.try_normalize(f64::EPSILON),
            ..self
        }
    }

    /// Expresses the first sighting's camera in another world frame: `new_from_old`, then
    /// `translation` (the old frame's origin in the new one).
    pub fn change_frame(&mut self, new_from_old: UnitQuaternion<f64>, translation: Vector3<f64>) {
        self.position = new_from_old * self.position + translation;
        self.orientation = new_from_old * self.orientation;
        self.normal = self.normal.map(|n| new_from_old * n);
    }

    /// The crop's value at `pixel` of the first image, bilinearly; `None` outside the crop.
    fn sample(&self, pixel: [f64; 2]) -> Option<f32> {
        let x = pixel[0] - self.corner[0] as f64;
        let y = pixel[1] - self.corner[1] as f64;
        let last = (self.side - 1) as f64;
        if !(0.0..last).contains(&x) || !(0.0..last).contains(&y) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let at = |c: usize, r: usize| self.crop[r * self.side + c];
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
        let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
        Some(top * (1.0 - fy) + bottom * fy)
    }

    /// The template of half size `half_px` the camera at `position` and `orientation`
    /// should see around `predicted` (its pixel now), the feature's point estimated at
    /// `point` (`None`: at infinity); `None` where the warp leaves the crop or the template
    /// is flat.
    pub fn template(
        &self,
        camera: &PinholeCamera,
        position: &Vector3<f64>,
        orientation: UnitQuaternion<f64>,
        point: Option<&Vector3<f64>>,
        predicted: [f64; 2],
        half_px: u32,
    ) -> Option<Patch> {
        let first_from_world = self.orientation.inverse();
        // The plane through the point, facing the first camera unless its normal is known:
        // its unit normal and the point, relative to the camera now.
        let plane = point.and_then(|point| {
            let normal = match self.normal {
                Some(normal) => normal,
                None => (self.position - point).try_normalize(f64::EPSILON)?,
            };
            Some((normal, point - position))
        });
        // The warp maps the predicted pixel's own ray near the first pixel; the remaining
        // offset (the prediction's error in the first image) is removed so that the template
        // is centred on the feature.
        let map = |pixel: [f64; 2]| -> Option<[f64; 2]> {
            let ray = orientation * camera.ray(pixel)?;
            let in_first = match plane {
                Some((normal, to_point)) => {
                    let along = normal.dot(&ray);
                    let reach = normal.dot(&to_point) / along;
                    if !(reach.is_finite() && reach > 0.0) {
                        return None;
                    }
                    first_from_world * (position + ray * reach - self.position)
                }
                None => first_from_world * ray,
            };
            camera.project(&in_first)
        };
        let centre = map(predicted)?;
        let shift = [self.pixel[0] - centre[0], self.pixel[1] - centre[1]];
        let half = i64::from(half_px);
        let mut values = Vec::with_capacity(((2 * half + 1) * (2 * half + 1)) as usize);
        for dy in -half..=half {
            for dx in -half..=half {
                let p = map([predicted[0] + dx as f64, predicted[1] + dy as f64])?;
                values.push(self.sample([p[0] + shift[0], p[1] + shift[1]])?);
            }
        }
        Patch::from_values(values, half_px)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth texture's grey level at a (real) pixel.
    fn texture(x: f64, y: f64) -> u8 {
        let v =
            128.0 + 60.0 * (x * 0.31).sin() * (y * 0.23).cos() + 40.0 * (x * 0.07 + y * 0.11).sin();
        v.clamp(0.0, 255.0) as u8
    }

    fn textured(width: u32, height: u32) -> GrayImage {
        GrayImage::from_fn(width, height, |x, y| {
            image::Luma([texture(f64::from(x), f64::from(y))])
        })
    }

    #[test]
    fn without_a_change_of_view_the_template_is_the_patch() {
        let camera = PinholeCamera::ideal(300.0, 300.0, 100.0, 80.0, [200, 160]);
        let image = textured(200, 160);
        let appearance = Appearance::new(
            0,
            &image,
            [100, 80],
            12,
            Vector3::zeros(),
            UnitQuaternion::identity(),
        )
        .expect("fits");
        let template = appearance
            .template(
                &camera,
                &Vector3::zeros(),
                UnitQuaternion::identity(),
                None,
                [140.0, 20.0],
                5,
            )
            .expect("inside");
        let patch = Patch::from_image(&image, [100, 80], 5).expect("textured");
        assert!(template.correlation_with(&patch) > 0.999);
    }

    #[test]
    fn a_rolled_camera_sees_the_patch_rolled() {
        // The camera rolls 30° about its axis: the feature at the image centre is seen
        // turned by 30°, which the warp predicts.
        let camera = PinholeCamera::ideal(300.0, 300.0, 100.0, 80.0, [200, 160]);
        let image = textured(200, 160);
        let roll =
            UnitQuaternion::from_axis_angle(&nalgebra::Vector3::z_axis(), 30f64.to_radians());
        let rolled = GrayImage::from_fn(200, 160, |x, y| {
            // The rolled camera's pixel (x, y) sees the first camera's pixel at the inverse
            // rotation about the centre.
            let (dx, dy) = (f64::from(x) - 100.0, f64::from(y) - 80.0);
            let (s, c) = 30f64.to_radians().sin_cos();
            let (sx, sy) = (c * dx - s * dy + 100.0, s * dx + c * dy + 80.0);
            let (sx, sy) = (
                sx.round().clamp(0.0, 199.0) as u32,
                sy.round().clamp(0.0, 159.0) as u32,
            );
            *image.get_pixel(sx, sy)
        });
        let appearance = Appearance::new(
            0,
            &image,
            [100, 80],
            12,
            Vector3::zeros(),
            UnitQuaternion::identity(),
        )
        .expect("fits");
        let warped = appearance
            .template(&camera, &Vector3::zeros(), roll, None, [100.0, 80.0], 5)
            .expect("inside");
        let seen = Patch::from_image(&rolled, [100, 80], 5).expect("textured");
        let unwarped = Patch::from_image(&image, [100, 80], 5).expect("textured");
        let with_warp = warped.correlation_with(&seen);
        let without = unwarped.correlation_with(&seen);
        assert!(
            with_warp > 0.95 && with_warp > without + 0.1,
            "{with_warp} against {without}"
        );
    }

    #[test]
    fn a_camera_come_closer_sees_the_patch_grown() {
        // The feature lies on a plane 10 m ahead; the camera moves 7.5 m towards it, and
        // sees its surroundings four times as large.
        let camera = PinholeCamera::ideal(300.0, 300.0, 100.0, 80.0, [200, 160]);
        let image = textured(200, 160);
        let closer = GrayImage::from_fn(200, 160, |x, y| {
            let sx = 100.0 + (f64::from(x) - 100.0) / 4.0;
            let sy = 80.0 + (f64::from(y) - 80.0) / 4.0;
            image::Luma([texture(sx, sy)])
        });
        let appearance = Appearance::new(
            0,
            &image,
            [100, 80],
            12,
            Vector3::zeros(),
            UnitQuaternion::identity(),
        )
        .expect("fits");
        let now = Vector3::new(0.0, 0.0, 7.5);
        let point = Vector3::new(0.0, 0.0, 10.0);
        let still = UnitQuaternion::identity();
        let warped = appearance
            .template(&camera, &now, still, Some(&point), [100.0, 80.0], 5)
            .expect("inside");
        let unwarped = appearance
            .template(&camera, &now, still, None, [100.0, 80.0], 5)
            .expect("inside");
        let seen = Patch::from_image(&closer, [100, 80], 5).expect("textured");
        let with_warp = warped.correlation_with(&seen);
        let without = unwarped.correlation_with(&seen);
        assert!(
            with_warp > 0.95 && with_warp > without + 0.1,
            "{with_warp} against {without}"
        );
    }
}
