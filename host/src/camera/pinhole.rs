//! A pinhole camera with radial–tangential (Brown–Conrady) distortion.
//!
//! The camera frame is x right, y down, z forward (the optical axis). A point in the camera
//! frame projects to normalised coordinates `(x/z, y/z)`, which the lens distorts with three
//! radial (`k1 k2 k3`) and two tangential (`p1 p2`) coefficients, the model of OpenCV and of
//! the TUM RGB-D calibrations; the intrinsics then give the pixel. Pixel `(0, 0)` is the
//! centre of the top-left pixel.

use nalgebra::Vector3;

/// A pinhole camera's intrinsics and lens distortion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeCamera {
    /// Focal lengths in pixels.
    pub fx_px: f64,
    pub fy_px: f64,
    /// Principal point in pixels.
    pub cx_px: f64,
    pub cy_px: f64,
    /// Radial distortion coefficients `k1, k2, k3`.
    pub radial: [f64; 3],
    /// Tangential distortion coefficients `p1, p2`.
    pub tangential: [f64; 2],
    /// Image size in pixels.
    pub width_px: u32,
    pub height_px: u32,
}

impl PinholeCamera {
    /// An ideal camera (no distortion).
    pub fn ideal(fx_px: f64, fy_px: f64, cx_px: f64, cy_px: f64, size_px: [u32; 2]) -> Self {
        PinholeCamera {
            fx_px,
            fy_px,
            cx_px,
            cy_px,
            radial: [0.0; 3],
            tangential: [0.0; 2],
            width_px: size_px[0],
            height_px: size_px[1],
        }
    }

    /// The distorted normalised coordinates of undistorted ones.
    pub fn distort(&self, normalised: [f64; 2]) -> [f64; 2] {
        let [x, y] = normalised;
        let [k1, k2, k3] = self.radial;
        let [p1, p2] = self.tangential;
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        [
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        ]
    }

    /// The undistorted normalised coordinates of distorted ones (Newton's method on
    /// [`Self::distort`]); `None` where it does not converge (far outside the calibrated field).
    pub fn undistort(&self, distorted: [f64; 2]) -> Option<[f64; 2]> {
        let mut estimate = distorted;
        for _ in 0..20 {
            let [fx, fy] = self.distort(estimate);
            let residual = [fx - distorted[0], fy - distorted[1]];
            if residual[0].hypot(residual[1]) < 1e-12 {
                return Some(estimate);
            }
            // Jacobian of distort by central differences (exact enough for the step).
            let h = 1e-7;
            let dx = self.distort([estimate[0] + h, estimate[1]]);
            let dy = self.distort([estimate[0], estimate[1] + h]);
            let (a, c) = ((dx[0] - fx) / h, (dx[1] - fy) / h);
            let (b, d) = ((dy[0] - fx) / h, (dy[1] - fy) / h);
            let det = a * d - b * c;
            if det.abs() < 1e-12 {
                return None;
            }
            estimate[0] -= (d * residual[0] - b * residual[1]) / det;
            estimate[1] -= (-c * residual[0] + a * residual[1]) / det;
        }
        let [fx, fy] = self.distort(estimate);
        ((fx - distorted[0]).hypot(fy - distorted[1]) < 1e-6).then_some(estimate)
    }

    /// The pixel of `point_in_camera`, or `None` when it lies behind the camera.
    pub fn project(&self, point_in_camera: &Vector3<f64>) -> Option<[f64; 2]> {
        if point_in_camera.z <= 1e-9 {
            return None;
        }
        let [x, y] = self.distort([
            point_in_camera.x / point_in_camera.z,
            point_in_camera.y / point_in_camera.z,
        ]);
        Some([self.fx_px * x + self.cx_px, self.fy_px * y + self.cy_px])
    }

    /// The ray through `pixel` in the camera frame, with `z = 1`.
    pub fn ray(&self, pixel: [f64; 2]) -> Option<Vector3<f64>> {
        let distorted = [
            (pixel[0] - self.cx_px) / self.fx_px,
            (pixel[1] - self.cy_px) / self.fy_px,
        ];
        let [x, y] = self.undistort(distorted)?;
        Some(Vector3::new(x, y, 1.0))
    }

    /// Whether `pixel` lies at least `margin_px` inside the image.
    pub fn contains(&self, pixel: [f64; 2], margin_px: f64) -> bool {
        pixel[0] >= margin_px
            && pixel[1] >= margin_px
            && pixel[0] <= f64::from(self.width_px) - 1.0 - margin_px
            && pixel[1] <= f64::from(self.height_px) - 1.0 - margin_px
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The TUM Freiburg 1 calibration, strongly distorted.
    fn freiburg1() -> PinholeCamera {
        PinholeCamera {
            radial: [0.262383, -0.953104, 1.163314],
            tangential: [-0.005358, 0.002628],
            ..PinholeCamera::ideal(517.306408, 516.469215, 318.643040, 255.313989, [640, 480])
        }
    }

    #[test]
    fn a_ray_projects_back_to_its_pixel() {
        let camera = freiburg1();
        for pixel in [[0.0, 0.0], [320.0, 240.0], [639.0, 479.0], [100.0, 400.0]] {
            let ray = camera.ray(pixel).expect("inside the calibrated field");
            let back = camera.project(&(ray * 3.7)).expect("in front");
            assert!(
                (back[0] - pixel[0]).hypot(back[1] - pixel[1]) < 1e-6,
                "{pixel:?} {back:?}"
            );
        }
    }

    #[test]
    fn a_point_behind_the_camera_has_no_pixel() {
        let camera = freiburg1();
        assert!(camera.project(&Vector3::new(0.0, 0.0, -1.0)).is_none());
        assert!(camera.contains([0.0, 0.0], 0.0));
        assert!(!camera.contains([640.0, 0.0], 0.0));
    }
}
