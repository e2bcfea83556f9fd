//! What a camera on the robot sees of a seeded world, rendered in software.
//!
//! The worlds are flat ground with upright things on it: walls (a segment and a height),
//! trunks, pillars and walkers (a circle and a height), and outdoors a ball of leaves on
//! each trunk. A camera held level on the robot (no pitch or roll) sees each image column
//! of an ideal pinhole as one vertical half-plane through the camera, so a column is
//! rendered from the 2D intersections of its ray with every outline: for each pixel of the
//! column, the nearest of the surfaces whose height range its elevation meets, a crown's
//! ball (a circle in the column's plane), the ground below the horizon, or the sky. That is
//! exact for this world, and costs one 2D ray per column. The lens's distortion is applied
//! after, by sampling the ideal image where each output pixel's undistorted ray falls
//! (bilinearly, from an ideal image a little larger than the output).
//!
//! Surfaces carry value noise fixed to them (a hash of the world seed, the surface and the
//! lattice cell, four octaves from 5 cm to 1.35 m), so a feature on a wall is the same
//! feature from every view. Octaves finer than two pixels' footprint at the hit are left
//! out, as a lens would blur them, so that distant texture does not alias into flicker.
//! Each frame then gets an exposure: a gain drawn per frame and Gaussian noise per pixel,
//! both from the seed and the frame's number, so a run is the same for the same seed.

use host::camera::PinholeCamera;
use image::{GrayImage, Luma};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::outdoor::crown_radius_m;
use super::{RobotState, Scenario, Shape, WorldKind};

/// The camera on the robot and how its frames are exposed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraRigOptions {
    /// The camera: intrinsics, distortion and image size.
    pub camera: PinholeCamera,
    /// Height of the camera's centre above the ground, m.
    pub height_m: f64,
    /// No solid further than this is drawn (the sky or the ground instead; the ground itself
    /// reaches the horizon), m.
    pub max_range_m: f64,
    /// Standard deviation of each pixel's noise, grey levels.
    pub noise_sigma: f64,
    /// Standard deviation of a frame's exposure gain (1 on average).
    pub gain_sigma: f64,
}

impl CameraRigOptions {
    /// The default rig with a camera of `width_px` × `height_px` and the same field of view
    /// and distortion.
    pub fn with_size(width_px: u32, height_px: u32) -> Self {
        let mut rig = CameraRigOptions::default();
        let scale = f64::from(width_px) / f64::from(rig.camera.width_px);
        let mut camera = PinholeCamera::ideal(
            rig.camera.fx_px * scale,
            rig.camera.fy_px * scale,
            (f64::from(width_px) - 1.0) / 2.0,
            (f64::from(height_px) - 1.0) / 2.0,
            [width_px, height_px],
        );
        camera.radial = rig.camera.radial;
        camera.tangential = rig.camera.tangential;
        rig.camera = camera;
        rig
    }
}

impl Default for CameraRigOptions {
    /// A 640 × 480 camera with a 65° horizontal field of view and mild barrel distortion,
    /// 1.2 m above the ground; 2 grey levels of noise and 3 % of gain change per frame.
    fn default() -> Self {
        let mut camera = PinholeCamera::ideal(500.0, 500.0, 319.5, 239.5, [640, 480]);
        camera.radial = [-0.12, 0.02, 0.0];
        CameraRigOptions {
            camera,
            height_m: 1.2,
            max_range_m: 150.0,
            noise_sigma: 2.0,
            gain_sigma: 0.03,
        }
    }
}

/// Something moving on its own where the camera sees it (a walker): an upright cylinder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mover {
    /// Where it stands now, world frame, m.
    pub center_m: [f64; 2],
    pub radius_m: f64,
    pub height_m: f64,
    /// Its texture.
    pub id: u32,
}

/// A surface the camera can see.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Solid {
    Wall {
        a_m: [f64; 2],
        b_m: [f64; 2],
        height_m: f64,
        texture: u32,
        material: Material,
    },
    Post {
        center_m: [f64; 2],
        radius_m: f64,
        height_m: f64,
        texture: u32,
        material: Material,
    },
    Crown {
        center_m: [f64; 3],
        radius_m: f64,
        texture: u32,
    },
}

/// How a surface's noise turns into grey levels: its mean and its contrast.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Material {
    mean: f64,
    contrast: f64,
}

const BUILDING: Material = Material {
    mean: 150.0,
    contrast: 70.0,
};
const BARK: Material = Material {
    mean: 80.0,
    contrast: 60.0,
};
const LEAVES: Material = Material {
    mean: 85.0,
    contrast: 90.0,
};
const GROUND: Material = Material {
    mean: 110.0,
    contrast: 70.0,
};
const CLOTHES: Material = Material {
    mean: 120.0,
    contrast: 160.0,
};

/// Texture numbers of the ground and of movers (surfaces of the world count from 0).
const GROUND_TEXTURE: u32 = u32::MAX;
const MOVER_TEXTURE_BASE: u32 = 1 << 30;

/// The renderer for one world and one camera. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct CameraView {
    options: CameraRigOptions,
    seed: u64,
    solids: Vec<Solid>,
    /// The ideal image's corner pixel and size.
    canvas_origin: [i64; 2],
    canvas_size: [usize; 2],
    /// For each output pixel (row-major), where its ray falls in the ideal image, relative
    /// to the canvas's corner; `None` where the lens model has no ray.
    remap: Vec<Option<[f32; 2]>>,
}

impl CameraView {
    /// The renderer for `scenario`'s world seen by the camera of `options`.
    pub fn new(scenario: &Scenario, options: CameraRigOptions) -> Self {
        let mut solids = Vec::new();
        let shapes = scenario.world().shapes();
        debug_assert_eq!(shapes.len(), scenario.heights_m().len());
        for (index, (shape, &height_m)) in shapes.iter().zip(scenario.heights_m()).enumerate() {
            let texture = index as u32;
            match *shape {
                Shape::Segment { a_m, b_m } => solids.push(Solid::Wall {
                    a_m,
                    b_m,
                    height_m,
                    texture,
                    material: BUILDING,
                }),
                Shape::Circle { center_m, radius_m } => solids.push(Solid::Post {
                    center_m,
                    radius_m,
                    height_m,
                    texture,
                    material: BARK,
                }),
            }
        }
        if scenario.kind() == WorldKind::Outdoor {
            let trunks = shapes.len() - scenario.landmarks().len();
            for (index, tree) in scenario.landmarks().iter().enumerate() {
                let radius_m = crown_radius_m(tree.radius_m);
                let top_m = scenario.heights_m()[trunks + index];
                solids.push(Solid::Crown {
                    center_m: [tree.center_m[0], tree.center_m[1], top_m + 0.75 * radius_m],
                    radius_m,
                    texture: (shapes.len() + index) as u32,
                });
            }
        }
        let camera = options.camera;
        let (width, height) = (camera.width_px as usize, camera.height_px as usize);
        let ideal: Vec<Option<[f64; 2]>> = (0..height)
            .flat_map(|y| (0..width).map(move |x| [x as f64, y as f64]))
            .map(|pixel| {
                let ray = camera.ray(pixel)?;
                (ray.z > 0.0).then(|| {
                    [
                        camera.fx_px * ray.x / ray.z + camera.cx_px,
                        camera.fy_px * ray.y / ray.z + camera.cy_px,
                    ]
                })
            })
            .collect();
        let (mut low, mut high) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in ideal.iter().flatten() {
            for axis in 0..2 {
                low[axis] = low[axis].min(p[axis]);
                high[axis] = high[axis].max(p[axis]);
            }
        }
        if low[0] > high[0] {
            (low, high) = ([0.0; 2], [0.0; 2]);
        }
        let canvas_origin = [low[0].floor() as i64 - 1, low[1].floor() as i64 - 1];
        let canvas_size = [
            (high[0].ceil() as i64 + 2 - canvas_origin[0]) as usize,
            (high[1].ceil() as i64 + 2 - canvas_origin[1]) as usize,
        ];
        let remap = ideal
            .into_iter()
            .map(|p| {
                p.map(|p| {
                    [
                        (p[0] - canvas_origin[0] as f64) as f32,
                        (p[1] - canvas_origin[1] as f64) as f32,
                    ]
                })
            })
            .collect();
        CameraView {
            options,
            seed: scenario.seed(),
            solids,
            canvas_origin,
            canvas_size,
            remap,
        }
    }

    /// The camera.
    pub fn camera(&self) -> &PinholeCamera {
        &self.options.camera
    }

    /// The camera's pose for the robot at `state`: its position (world frame, z up) and
    /// `world_from_camera` (camera x right, y down, z forward along the robot's heading).
    pub fn camera_pose(&self, state: &RobotState) -> (Vector3<f64>, UnitQuaternion<f64>) {
        let (sin, cos) = state.theta_rad.sin_cos();
        let right = Vector3::new(sin, -cos, 0.0);
        let down = Vector3::new(0.0, 0.0, -1.0);
        let forward = Vector3::new(cos, sin, 0.0);
        let rotation =
            nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[
                right, down, forward,
            ]));
        (
            Vector3::new(state.x_m, state.y_m, self.options.height_m),
            UnitQuaternion::from_rotation_matrix(&rotation),
        )
    }

    /// Frame number `frame` as the camera on the robot at `state` sees the world and the
    /// `movers` in it.
    pub fn render(&self, state: &RobotState, movers: &[Mover], frame: u64) -> GrayImage {
        self.render_with_movers(state, movers, frame).0
    }

    /// [`CameraView::render`]'s frame, and a mask of it: 255 where a pixel sees a mover
    /// (the nearest ideal pixel to where its ray falls), 0 elsewhere.
    pub fn render_with_movers(
        &self,
        state: &RobotState,
        movers: &[Mover],
        frame: u64,
    ) -> (GrayImage, GrayImage) {
        let (ideal, on_mover) = self.render_ideal(state, movers);
        let camera = &self.options.camera;
        let [cw, ch] = self.canvas_size;
        let mut rng = ChaCha8Rng::seed_from_u64(
            self.seed
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .wrapping_add(frame),
        );
        let gain =
            Normal::new(1.0, self.options.gain_sigma.max(0.0)).map_or(1.0, |n| n.sample(&mut rng));
        let noise = Normal::new(0.0, self.options.noise_sigma.max(0.0)).ok();
        let mut image = GrayImage::new(camera.width_px, camera.height_px);
        let mut mask = GrayImage::new(camera.width_px, camera.height_px);
        for (index, label) in mask.pixels_mut().enumerate() {
            if let Some([x, y]) = self.remap[index] {
                let (c, r) = (
                    (x.round().max(0.0) as usize).min(cw - 1),
                    (y.round().max(0.0) as usize).min(ch - 1),
                );
                if on_mover[r * cw + c] {
                    *label = Luma([255]);
                }
            }
        }
        for (index, pixel) in image.pixels_mut().enumerate() {
            let value = self.remap[index].map_or(0.0, |[x, y]| {
                let (x0, y0) = (
                    (x.floor().max(0.0) as usize).min(cw - 2),
                    (y.floor().max(0.0) as usize).min(ch - 2),
                );
                let (fx, fy) = (x - x0 as f32, y - y0 as f32);
                let at = |c: usize, r: usize| ideal[r * cw + c];
                let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
                let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
                f64::from(top * (1.0 - fy) + bottom * fy)
            });
            let noisy = value * gain + noise.map_or(0.0, |n| n.sample(&mut rng));
            *pixel = Luma([noisy.round().clamp(0.0, 255.0) as u8]);
        }
        (image, mask)
    }

    /// The ideal pinhole image over the canvas, grey levels, row-major, and whether each of
    /// its pixels sees a mover.
    fn render_ideal(&self, state: &RobotState, movers: &[Mover]) -> (Vec<f32>, Vec<bool>) {
        let camera = &self.options.camera;
        let h = self.options.height_m;
        let [cw, ch] = self.canvas_size;
        let origin = [state.x_m, state.y_m];
        let mover_solids = mover_solids(movers);
        let mut out = vec![0.0f32; cw * ch];
        let mut on_mover = vec![false; cw * ch];
        let mut hits: Vec<(f64, &Solid)> = Vec::new();
        for column in 0..cw {
            let u = (column as i64 + self.canvas_origin[0]) as f64;
            let (dir, norm) = self.column_ray(state, u);
            hits.clear();
            for solid in self.solids.iter().chain(&mover_solids) {
                if let Some(t) = entry_range(solid, origin, dir)
                    && t <= self.options.max_range_m
                {
                    hits.push((t, solid));
                }
            }
            hits.sort_by(|a, b| a.0.total_cmp(&b.0));
            for row in 0..ch {
                let v = (row as i64 + self.canvas_origin[1]) as f64;
                // Height gained per metre of range along this pixel's ray.
                let k = (camera.cy_px - v) / (camera.fy_px * norm);
                let footprint = |t: f64| t * norm / camera.fx_px;
                let mut value = None;
                let mut nearest = f64::INFINITY;
                for &(t, solid) in &hits {
                    if t >= nearest {
                        break;
                    }
                    if let Some((range, shade)) =
                        self.shade(solid, origin, dir, h, k, t, &footprint)
                        && range < nearest
                    {
                        nearest = range;
                        value = Some(shade);
                        on_mover[row * cw + column] = matches!(
                            solid,
                            Solid::Post { texture, .. } if *texture >= MOVER_TEXTURE_BASE
                        );
                    }
                }
                let value = value.unwrap_or_else(|| {
                    // The ground reaches the horizon, as a plane does: cut at a range, its far
                    // edge would be a curve fixed to the camera (the same range every way),
                    // drawn in steps of a pixel, whose corners turn with the camera and not
                    // with the world. Far off, its texture is finer than a pixel and it is
                    // its mean.
                    if k < 0.0 {
                        let t = h / -k;
                        let ground = [origin[0] + dir[0] * t, origin[1] + dir[1] * t];
                        // Along the ground, a pixel covers more than across it.
                        let across = footprint(t);
                        let along = across * t / h;
                        material_value(
                            GROUND,
                            noise(
                                self.seed,
                                GROUND_TEXTURE,
                                ground,
                                across.max(along * 0.5),
                                None,
                            ),
                        )
                    } else {
                        // The sky: brighter towards the zenith.
                        (205.0 + 30.0 * k.clamp(0.0, 1.0)) as f32
                    }
                });
                out[row * cw + column] = value;
            }
        }
        (out, on_mover)
    }

    /// The world point (z up) the camera on the robot at `state` sees at `pixel` of its
    /// frame, with the `movers` there; `None` where it sees the sky or the lens has no ray.
    pub fn point_seen(
        &self,
        state: &RobotState,
        movers: &[Mover],
        pixel: [f64; 2],
    ) -> Option<Vector3<f64>> {
        let camera = &self.options.camera;
        let ray = camera.ray(pixel).filter(|r| r.z > 0.0)?;
        // The ideal image's column and row the pixel's ray falls on.
        let u = camera.fx_px * ray.x / ray.z + camera.cx_px;
        let v = camera.fy_px * ray.y / ray.z + camera.cy_px;
        let (dir, norm) = self.column_ray(state, u);
        let k = (camera.cy_px - v) / (camera.fy_px * norm);
        let (origin, h) = ([state.x_m, state.y_m], self.options.height_m);
        let footprint = |t: f64| t * norm / camera.fx_px;
        let range = self
            .solids
            .iter()
            .chain(&mover_solids(movers))
            .filter_map(|solid| {
                let t = entry_range(solid, origin, dir)?;
                if t > self.options.max_range_m {
                    return None;
                }
                self.shade(solid, origin, dir, h, k, t, &footprint)
                    .map(|(range, _)| range)
            })
            .min_by(f64::total_cmp)
            .or_else(|| (k < 0.0).then(|| h / -k))?;
        Some(Vector3::new(
            origin[0] + dir[0] * range,
            origin[1] + dir[1] * range,
            h + k * range,
        ))
    }

    /// The ground-plane direction (unit) of the ideal image's column `u` for the camera on
    /// the robot at `state`, and the length of its ray `(x/z, 1)` in the camera's frame.
    fn column_ray(&self, state: &RobotState, u: f64) -> ([f64; 2], f64) {
        let camera = &self.options.camera;
        let (sin, cos) = state.theta_rad.sin_cos();
        let (forward, right) = ([cos, sin], [sin, -cos]);
        let xn = (u - camera.cx_px) / camera.fx_px;
        let norm = (1.0 + xn * xn).sqrt();
        (
            [
                (forward[0] + xn * right[0]) / norm,
                (forward[1] + xn * right[1]) / norm,
            ],
            norm,
        )
    }

    /// Where this pixel's ray (in a column of 2D direction `dir`, rising `k` per metre from
    /// height `h`) meets `solid`, whose outline the column's ray enters at range `t`: the
    /// range and the grey level there.
    #[allow(clippy::too_many_arguments)]
    fn shade(
        &self,
        solid: &Solid,
        origin: [f64; 2],
        dir: [f64; 2],
        h: f64,
        k: f64,
        t: f64,
        footprint: &impl Fn(f64) -> f64,
    ) -> Option<(f64, f32)> {
        match *solid {
            Solid::Wall {
                a_m,
                height_m,
                texture,
                material,
                ..
            } => {
                let z = h + k * t;
                if !(0.0..=height_m).contains(&z) {
                    return None;
                }
                let hit = [origin[0] + dir[0] * t, origin[1] + dir[1] * t];
                let along = (hit[0] - a_m[0]).hypot(hit[1] - a_m[1]);
                Some((
                    t,
                    material_value(
                        material,
                        noise(self.seed, texture, [along, z], footprint(t), None),
                    ),
                ))
            }
            Solid::Post {
                center_m,
                radius_m,
                height_m,
                texture,
                material,
            } => {
                let z = h + k * t;
                if !(0.0..=height_m).contains(&z) {
                    return None;
                }
                let hit = [origin[0] + dir[0] * t, origin[1] + dir[1] * t];
                let angle = (hit[1] - center_m[1]).atan2(hit[0] - center_m[0]);
                let around = (angle + std::f64::consts::PI) * radius_m;
                Some((
                    t,
                    material_value(
                        material,
                        noise(
                            self.seed,
                            texture,
                            [around, z],
                            footprint(t),
                            Some(std::f64::consts::TAU * radius_m),
                        ),
                    ),
                ))
            }
            Solid::Crown {
                center_m,
                radius_m,
                texture,
            } => {
                // The ball's slice in the column's plane: a circle about (t0, zc).
                let to_centre = [center_m[0] - origin[0], center_m[1] - origin[1]];
                let t0 = to_centre[0] * dir[0] + to_centre[1] * dir[1];
                let off = to_centre[0] * dir[1] - to_centre[1] * dir[0];
                let slice2 = radius_m * radius_m - off * off;
                let dz = h - center_m[2];
                // (s − t0)² + (dz + k s)² = slice², smallest positive s.
                let a = 1.0 + k * k;
                let b = k * dz - t0;
                let c = t0 * t0 + dz * dz - slice2;
                let disc = b * b - a * c;
                if slice2 <= 0.0 || disc < 0.0 {
                    return None;
                }
                let root = disc.sqrt();
                let s = [(-b - root) / a, (-b + root) / a]
                    .into_iter()
                    .find(|&s| s > 0.0)?;
                let point = Vector3::new(
                    origin[0] + dir[0] * s - center_m[0],
                    origin[1] + dir[1] * s - center_m[1],
                    h + k * s - center_m[2],
                );
                let azimuth = (point.y.atan2(point.x) + std::f64::consts::PI) * radius_m;
                let elevation = (point.z / radius_m).clamp(-1.0, 1.0).asin() * radius_m;
                Some((
                    s,
                    material_value(
                        LEAVES,
                        noise(
                            self.seed,
                            texture,
                            [azimuth, elevation],
                            footprint(s),
                            Some(std::f64::consts::TAU * radius_m),
                        ),
                    ),
                ))
            }
        }
    }
}

/// The range at which a column's 2D ray from `origin` along unit `dir` first meets the
/// solid's outline (for a crown, the nearest point of its ball's slice, a lower bound).
/// The walkers as solids to draw.
fn mover_solids(movers: &[Mover]) -> Vec<Solid> {
    movers
        .iter()
        .map(|m| Solid::Post {
            center_m: m.center_m,
            radius_m: m.radius_m,
            height_m: m.height_m,
            texture: MOVER_TEXTURE_BASE + m.id,
            material: CLOTHES,
        })
        .collect()
}

fn entry_range(solid: &Solid, origin: [f64; 2], dir: [f64; 2]) -> Option<f64> {
    match *solid {
        Solid::Wall { a_m, b_m, .. } => Shape::Segment { a_m, b_m }.intersect(origin, dir),
        Solid::Post {
            center_m, radius_m, ..
        } => Shape::Circle { center_m, radius_m }.intersect(origin, dir),
        Solid::Crown {
            center_m, radius_m, ..
        } => {
            let to_centre = [center_m[0] - origin[0], center_m[1] - origin[1]];
            let t0 = to_centre[0] * dir[0] + to_centre[1] * dir[1];
            let off = to_centre[0] * dir[1] - to_centre[1] * dir[0];
            (off.abs() < radius_m && t0 + radius_m > 0.0)
                .then(|| (t0 - (radius_m * radius_m - off * off).sqrt()).max(1e-9))
        }
    }
}

/// A material's grey level for noise `n` in −1 to 1.
fn material_value(material: Material, n: f64) -> f32 {
    (material.mean + material.contrast * n).clamp(0.0, 255.0) as f32
}

/// Cell sizes of the noise's octaves, m.
const OCTAVES_M: [f64; 4] = [0.05, 0.15, 0.45, 1.35];

/// Value noise of surface `texture` at surface coordinates `at` (m), in about −1 to 1, its
/// octaves of equal weight, those finer than two `footprint_m` left out (their mean, zero,
/// instead). With `around_m`, the first coordinate goes round a surface of that
/// circumference: each octave's cells are stretched to fit a whole number of times round,
/// so the texture closes on itself without a seam.
fn noise(seed: u64, texture: u32, at: [f64; 2], footprint_m: f64, around_m: Option<f64>) -> f64 {
    let mut sum = 0.0;
    let mut weights = 0.0;
    for (octave, &cell_m) in OCTAVES_M.iter().enumerate() {
        let weight = 1.0;
        let cells_round = around_m.map(|c| (c / cell_m).round().max(1.0));
        let cell_u_m = match (around_m, cells_round) {
            (Some(c), Some(n)) => c / n,
            _ => cell_m,
        };
        weights += weight;
        // Fades in between two and four pixels per cell.
        let detail = ((cell_m / footprint_m.max(1e-9) - 2.0) / 2.0).clamp(0.0, 1.0);
        if detail == 0.0 {
            continue;
        }
        let (x, y) = (at[0] / cell_u_m, at[1] / cell_m);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (smooth(x - x0), smooth(y - y0));
        let lattice = |dx: i64, dy: i64| {
            let column = x0 as i64 + dx;
            let column = cells_round.map_or(column, |n| column.rem_euclid(n as i64));
            lattice_value(seed, texture, octave as u32, column, y0 as i64 + dy)
        };
        let top = lattice(0, 0) * (1.0 - fx) + lattice(1, 0) * fx;
        let bottom = lattice(0, 1) * (1.0 - fx) + lattice(1, 1) * fx;
        sum += weight * detail * (top * (1.0 - fy) + bottom * fy);
    }
    (2.0 * sum / weights).clamp(-1.0, 1.0)
}

fn smooth(f: f64) -> f64 {
    f * f * (3.0 - 2.0 * f)
}

/// A lattice point's value, −1 to 1, from a 64-bit mix of everything that names it
/// (SplitMix64's finaliser).
fn lattice_value(seed: u64, texture: u32, octave: u32, x: i64, y: i64) -> f64 {
    let mut z = seed
        ^ (u64::from(texture) << 32 | u64::from(octave)).wrapping_mul(0xD6E8_FEB8_6659_FD93)
        ^ (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outdoor() -> Scenario {
        Scenario::generate_for(WorldKind::Outdoor, 3, 20.0)
    }

    #[test]
    fn a_frame_is_the_same_for_the_same_seed_and_differs_with_the_frame() {
        let scenario = outdoor();
        let view = CameraView::new(&scenario, CameraRigOptions::default());
        let state = scenario.pose_at(5.0);
        let a = view.render(&state, &[], 7);
        let b = view.render(&state, &[], 7);
        let c = view.render(&state, &[], 8);
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_eq!(a.dimensions(), (640, 480));
    }

    #[test]
    fn the_sky_is_above_the_horizon_and_the_ground_below() {
        // An ideal camera in an empty corner of the world, looking out of the park.
        let scenario = outdoor();
        let mut options = CameraRigOptions::default();
        options.camera.radial = [0.0; 3];
        options.noise_sigma = 0.0;
        options.gain_sigma = 0.0;
        let view = CameraView::new(&scenario, options);
        let state = RobotState {
            x_m: -5.0,
            y_m: -5.0,
            theta_rad: -2.4,
            speed_mps: 0.0,
            yaw_rate_radps: 0.0,
        };
        let image = view.render(&state, &[], 0);
        // Near the top, the sky's smooth brightness; near the bottom, textured ground.
        let row = |y: u32| {
            (0..640)
                .map(|x| f64::from(image.get_pixel(x, y)[0]))
                .collect::<Vec<_>>()
        };
        let spread = |v: &[f64]| {
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        let sky = row(5);
        let ground = row(470);
        assert!(sky.iter().all(|&v| v >= 205.0), "{sky:?}");
        assert!(spread(&ground) > 5.0 && spread(&sky) < 2.0);
    }

    #[test]
    fn a_wall_ahead_is_drawn_where_its_distance_puts_it() {
        // The camera faces a wall of known height at a known range: its top edge lies at
        // the row the pinhole puts it.
        let scenario = outdoor();
        let mut options = CameraRigOptions::default();
        options.camera.radial = [0.0; 3];
        let mut view = CameraView::new(&scenario, options);
        view.solids = vec![Solid::Wall {
            a_m: [10.0, -20.0],
            b_m: [10.0, 20.0],
            height_m: 3.2,
            texture: 0,
            material: Material {
                mean: 60.0,
                contrast: 0.0,
            },
        }];
        let state = RobotState {
            x_m: 0.0,
            y_m: 0.0,
            theta_rad: 0.0,
            speed_mps: 0.0,
            yaw_rate_radps: 0.0,
        };
        let (image, _) = view.render_ideal(&state, &[]);
        let [cw, _] = view.canvas_size;
        let column = (319.5 - view.canvas_origin[0] as f64).round() as usize;
        // Top edge at v = cy − fy (3.2 − 1.2) / 10 = 139.5; the wall's foot at cy + fy 1.2 / 10.
        let at = |v: f64| image[(v - view.canvas_origin[1] as f64) as usize * cw + column];
        assert_eq!(at(141.0), 60.0);
        assert_ne!(at(138.0), 60.0);
        assert_eq!(at(298.0), 60.0);
        assert_ne!(at(301.0), 60.0);
    }

    /// A walker 0.5 m wide and 1.75 m tall, `distance_m` straight ahead of the robot at
    /// `state`.
    fn walker_ahead(state: &RobotState, distance_m: f64) -> Mover {
        let (sin, cos) = state.theta_rad.sin_cos();
        Mover {
            center_m: [state.x_m + distance_m * cos, state.y_m + distance_m * sin],
            radius_m: 0.25,
            height_m: 1.75,
            id: 3,
        }
    }

    #[test]
    fn the_point_a_pixel_sees_projects_back_onto_it_and_lies_on_what_it_sees() {
        let scenario = outdoor();
        let view = CameraView::new(&scenario, CameraRigOptions::default());
        let state = scenario.pose_at(6.0);
        let (position, world_from_camera) = view.camera_pose(&state);
        let (mut ground, mut solid, mut sky) = (0, 0, 0);
        for v in (10..480).step_by(40) {
            for u in (10..640).step_by(40) {
                let pixel = [f64::from(u) + 0.3, f64::from(v) - 0.2];
                let Some(point) = view.point_seen(&state, &[], pixel) else {
                    sky += 1;
                    continue;
                };
                let in_camera = world_from_camera.inverse() * (point - position);
                let back = view.camera().project(&in_camera).expect("in front");
                assert!(
                    (back[0] - pixel[0]).hypot(back[1] - pixel[1]) < 1e-6,
                    "{pixel:?} came back at {back:?}"
                );
                if point.z.abs() < 1e-9 {
                    ground += 1;
                } else {
                    solid += 1;
                }
            }
        }
        assert!(ground > 0 && solid > 0 && sky > 0, "{ground} {solid} {sky}");
        // A walker right ahead is what the centre pixel sees.
        let point = view
            .point_seen(&state, &[walker_ahead(&state, 3.0)], [319.5, 239.5])
            .expect("the walker");
        assert!(
            ((point - position).xy().norm() - 2.75).abs() < 1e-6,
            "{point}"
        );
    }

    #[test]
    fn a_walker_ahead_hides_what_is_behind_it() {
        let scenario = outdoor();
        let options = CameraRigOptions {
            noise_sigma: 0.0,
            gain_sigma: 0.0,
            ..CameraRigOptions::default()
        };
        let view = CameraView::new(&scenario, options);
        let state = scenario.pose_at(4.0);
        let walker = walker_ahead(&state, 5.0);
        let without = view.render(&state, &[], 0);
        let (with, mask) = view.render_with_movers(&state, &[walker], 0);
        if std::env::var_os("CAMERA_VIEW_PNG").is_some() {
            with.save("/tmp/walker.png").expect("save");
        }
        // The walker is 0.5 m wide at 5 m: 50 px about the centre column, from its feet
        // (1.2 m below the camera: 120 px below the centre) to 0.55 m above the camera.
        let changed = |x: u32, y: u32| with.get_pixel(x, y) != without.get_pixel(x, y);
        let columns = (280..360).filter(|&x| changed(x, 300)).count();
        assert!((35..=60).contains(&columns), "{columns}");
        assert!(changed(320, 350) && changed(320, 200));
        assert!(!changed(320, 380) && !changed(320, 170));
        // The mask marks the walker's pixels and nothing else.
        for (x, y, label) in mask.enumerate_pixels() {
            if label[0] == 255 {
                assert!(
                    (280..360).contains(&x) && (170..380).contains(&y),
                    "{x} {y}"
                );
            }
        }
        assert_eq!(mask.get_pixel(320, 300)[0], 255);
        assert_eq!(mask.get_pixel(100, 300)[0], 0);
    }

    #[test]
    fn a_texture_round_a_trunk_closes_on_itself() {
        let around_m = std::f64::consts::TAU * 0.4;
        for z in [0.3, 1.1, 2.7] {
            let start = noise(5, 9, [0.0, z], 0.001, Some(around_m));
            let end = noise(5, 9, [around_m - 1e-9, z], 0.001, Some(around_m));
            assert!((start - end).abs() < 1e-6, "{start} {end}");
        }
    }
}
