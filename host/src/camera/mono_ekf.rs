//! The monocular EKF: one camera and its 3D point features in one state with the full
//! covariance (Davison et al. 2007, "MonoSLAM"), features in inverse depth from their first
//! sighting (Civera, Davison and Montiel 2008, "Inverse Depth Parametrization for Monocular
//! SLAM").
//!
//! The state starts with the camera's 13 numbers: position `r` (m) and orientation `q`
//! (`world_from_camera`, a quaternion `w x y z`) in the world frame, linear velocity `v`
//! (m/s, world frame) and angular velocity `ω` (rad/s, camera frame). The world frame is the
//! first frame's camera frame (x right, y down, z forward). Motion is constant velocity, with
//! unknown accelerations as impulses on `v` and `ω` each step.
//!
//! A feature is either six numbers in inverse depth, `(x y z θ φ ρ)`: the camera centre it was
//! first seen from, the azimuth and elevation of its ray in the world frame and the inverse of
//! its depth along that ray, which the first sighting leaves almost unknown and which is nearly
//! Gaussian even so; or, once its depth is well determined (Civera's linearity index below a
//! threshold), three, its Euclidean position.
//!
//! Jacobians are taken by central differences of the exact models: the measurement and motion
//! models are a few lines each, and a difference Jacobian cannot disagree with them.

use nalgebra::{DMatrix, DVector, Matrix2, UnitQuaternion, Vector3};

use super::level_prior::level_frame;
use super::pinhole::PinholeCamera;

/// Numbers in the camera part of the state.
pub const CAMERA_STATE: usize = 13;

/// How the filter models motion, measurements and new features.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MonoEkfOptions {
    /// Standard deviation of the unknown linear acceleration, m/s².
    pub linear_acceleration_sigma: f64,
    /// Standard deviation of the unknown angular acceleration, rad/s².
    pub angular_acceleration_sigma: f64,
    /// Standard deviation of a feature's measured pixel, px.
    pub pixel_sigma_px: f64,
    /// Standard deviation of the camera's velocity at the start: linear (m/s), angular (rad/s).
    pub initial_velocity_sigma: [f64; 2],
    /// A new feature's inverse depth, 1/m, and its standard deviation: the depth prior
    /// reaches from infinity to about a metre.
    pub initial_inverse_depth: [f64; 2],
    /// An inverse-depth feature becomes a Euclidean point once its linearity index falls below
    /// this (Civera et al. 2008 use 0.1).
    pub linearity_threshold: f64,
}

impl Default for MonoEkfOptions {
    fn default() -> Self {
        MonoEkfOptions {
            linear_acceleration_sigma: 6.0,
            angular_acceleration_sigma: 6.0,
            pixel_sigma_px: 1.0,
            initial_velocity_sigma: [0.75, 0.75],
            initial_inverse_depth: [0.1, 0.5],
            linearity_threshold: 0.1,
        }
    }
}

/// How a feature is held in the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FeatureKind {
    /// Six numbers: `(x y z θ φ ρ)`.
    InverseDepth,
    /// Three numbers: the point in the world frame.
    Euclidean,
}

impl FeatureKind {
    /// Numbers of the state this kind takes.
    pub fn size(self) -> usize {
        match self {
            FeatureKind::InverseDepth => 6,
            FeatureKind::Euclidean => 3,
        }
    }
}

/// The camera and its features: mean and covariance. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct MonoEkf {
    options: MonoEkfOptions,
    camera: PinholeCamera,
    x: DVector<f64>,
    p: DMatrix<f64>,
    /// Kind of each feature, in state order.
    kinds: Vec<FeatureKind>,
    /// Offset of each feature in the state.
    offsets: Vec<usize>,
}

/// A feature's predicted measurement: its pixel, the Jacobians of the pixel with respect to
/// the camera state and to the feature, and the innovation covariance.
#[derive(Clone, Debug)]
pub struct Prediction {
    pub pixel: [f64; 2],
    pub jacobian_camera: DMatrix<f64>,
    pub jacobian_feature: DMatrix<f64>,
    pub innovation_covariance: Matrix2<f64>,
}

/// The unit vector of azimuth `theta` and elevation `phi` (camera convention, y down).
fn direction(theta: f64, phi: f64) -> Vector3<f64> {
    Vector3::new(phi.cos() * theta.sin(), -phi.sin(), phi.cos() * theta.cos())
}

fn quaternion(q: &[f64]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// The camera state after `dt_s` of constant velocity with velocity impulses `impulse`
/// (`[Δv; Δω]`).
fn motion(camera: &[f64], impulse: &[f64; 6], dt_s: f64) -> [f64; CAMERA_STATE] {
    let v = Vector3::new(
        camera[7] + impulse[0],
        camera[8] + impulse[1],
        camera[9] + impulse[2],
    );
    let w = Vector3::new(
        camera[10] + impulse[3],
        camera[11] + impulse[4],
        camera[12] + impulse[5],
    );
    let r = Vector3::new(camera[0], camera[1], camera[2]) + v * dt_s;
    // The raw quaternion times the rotation of ω dt: not normalised, so that the Jacobian
    // sees the state's four numbers as they are.
    let q = nalgebra::Quaternion::new(camera[3], camera[4], camera[5], camera[6]);
    let turn = UnitQuaternion::from_scaled_axis(w * dt_s);
    let q = q * turn.into_inner();
    [
        r.x, r.y, r.z, q.w, q.i, q.j, q.k, v.x, v.y, v.z, w.x, w.y, w.z,
    ]
}

/// The feature's point in the camera frame, up to a positive scale for an inverse-depth
/// feature (its direction times ρ).
fn in_camera(camera: &[f64], kind: FeatureKind, feature: &[f64]) -> Vector3<f64> {
    let r = Vector3::new(camera[0], camera[1], camera[2]);
    let q = nalgebra::Quaternion::new(camera[3], camera[4], camera[5], camera[6]);
    // Rotation by the unnormalised quaternion's normalised form.
    let world_from_camera = UnitQuaternion::from_quaternion(q);
    let in_world = match kind {
        FeatureKind::InverseDepth => {
            let anchor = Vector3::new(feature[0], feature[1], feature[2]);
            (anchor - r) * feature[5] + direction(feature[3], feature[4])
        }
        FeatureKind::Euclidean => Vector3::new(feature[0], feature[1], feature[2]) - r,
    };
    world_from_camera.inverse_transform_vector(&in_world)
}

/// A feature's best point estimate (an inverse-depth feature at its mean depth), or `None`
/// for an inverse-depth feature with its depth at infinity.
pub fn feature_point(kind: FeatureKind, f: &[f64]) -> Option<Vector3<f64>> {
    match kind {
        FeatureKind::Euclidean => Some(Vector3::new(f[0], f[1], f[2])),
        FeatureKind::InverseDepth => {
            (f[5] > 1e-6).then(|| Vector3::new(f[0], f[1], f[2]) + direction(f[3], f[4]) / f[5])
        }
    }
}

/// A feature's numbers in another frame, `new_from_old` then `translation` (the old frame's
/// origin in the new one): a point or an anchor moves, a ray's direction turns, an inverse
/// depth stays.
pub fn moved_feature(
    kind: FeatureKind,
    feature: &[f64],
    new_from_old: UnitQuaternion<f64>,
    translation: Vector3<f64>,
) -> Vec<f64> {
    let point = new_from_old * Vector3::new(feature[0], feature[1], feature[2]) + translation;
    let mut out = feature.to_vec();
    out[..3].copy_from_slice(point.as_slice());
    if kind == FeatureKind::InverseDepth {
        let m = new_from_old * direction(feature[3], feature[4]);
        out[3] = m.x.atan2(m.z);
        out[4] = (-m.y).atan2(m.x.hypot(m.z));
    }
    out
}

/// A feature moved to another frame as [`moved_feature`] does, with its covariance carried
/// through the move.
pub fn moved_feature_with_covariance(
    kind: FeatureKind,
    feature: &[f64],
    covariance: &DMatrix<f64>,
    new_from_old: UnitQuaternion<f64>,
    translation: Vector3<f64>,
) -> (Vec<f64>, DMatrix<f64>) {
    let moved = moved_feature(kind, feature, new_from_old, translation);
    let j = jacobian(feature, kind.size(), |f| {
        Some(moved_feature(kind, f, new_from_old, translation))
    })
    .unwrap_or_else(|| DMatrix::identity(kind.size(), kind.size()));
    let covariance = &j * covariance * j.transpose();
    (moved, (&covariance + covariance.transpose()) * 0.5)
}

/// Central-difference Jacobian of `f` at `at` (`rows` outputs).
fn jacobian(
    at: &[f64],
    rows: usize,
    mut f: impl FnMut(&[f64]) -> Option<Vec<f64>>,
) -> Option<DMatrix<f64>> {
    let mut j = DMatrix::zeros(rows, at.len());
    let mut point = at.to_vec();
    for c in 0..at.len() {
        let h = 1e-6 * at[c].abs().max(1.0);
        point[c] = at[c] + h;
        let plus = f(&point)?;
        point[c] = at[c] - h;
        let minus = f(&point)?;
        point[c] = at[c];
        for r in 0..rows {
            j[(r, c)] = (plus[r] - minus[r]) / (2.0 * h);
        }
    }
    Some(j)
}

impl MonoEkf {
    /// A filter with the camera at the world origin, at rest, and no features.
    pub fn new(camera: PinholeCamera, options: MonoEkfOptions) -> Self {
        let mut x = DVector::zeros(CAMERA_STATE);
        x[3] = 1.0;
        let mut p = DMatrix::zeros(CAMERA_STATE, CAMERA_STATE);
        let [sigma_v, sigma_w] = options.initial_velocity_sigma;
        for i in 7..10 {
            p[(i, i)] = sigma_v * sigma_v;
        }
        for i in 10..13 {
            p[(i, i)] = sigma_w * sigma_w;
        }
        MonoEkf {
            options,
            camera,
            x,
            p,
            kinds: Vec::new(),
            offsets: Vec::new(),
        }
    }

    /// The camera model.
    pub fn camera(&self) -> &PinholeCamera {
        &self.camera
    }

    /// The camera's position in the world frame, m.
    pub fn position_m(&self) -> Vector3<f64> {
        Vector3::new(self.x[0], self.x[1], self.x[2])
    }

    /// `world_from_camera`.
    pub fn orientation(&self) -> UnitQuaternion<f64> {
        quaternion(&self.x.as_slice()[3..7])
    }

    /// Number of features in the state.
    pub fn num_features(&self) -> usize {
        self.kinds.len()
    }

    /// How feature `index` is held.
    pub fn kind(&self, index: usize) -> FeatureKind {
        self.kinds[index]
    }

    /// Size of the state.
    pub fn state_size(&self) -> usize {
        self.x.len()
    }

    fn feature(&self, index: usize) -> &[f64] {
        let offset = self.offsets[index];
        &self.x.as_slice()[offset..offset + self.kinds[index].size()]
    }

    /// The feature's best point estimate in the world frame (an inverse-depth feature at its
    /// mean depth), or `None` for an inverse-depth feature with its depth at infinity.
    pub fn point_in_world(&self, index: usize) -> Option<Vector3<f64>> {
        feature_point(self.kinds[index], self.feature(index))
    }

    /// Feature `index`'s numbers and their marginal covariance.
    pub fn feature_with_covariance(&self, index: usize) -> (FeatureKind, Vec<f64>, DMatrix<f64>) {
        let kind = self.kinds[index];
        let offset = self.offsets[index];
        let size = kind.size();
        (
            kind,
            self.feature(index).to_vec(),
            self.p.view((offset, offset), (size, size)).clone_owned(),
        )
    }

    /// The pixel a feature with these numbers would be seen at from the current mean, or
    /// `None` when it lies behind the camera.
    pub fn pixel_of(&self, kind: FeatureKind, feature: &[f64]) -> Option<[f64; 2]> {
        self.camera.project(&in_camera(
            &self.x.as_slice()[..CAMERA_STATE],
            kind,
            feature,
        ))
    }

    /// A filter holding this one's camera (mean and covariance) and no features, its pose's
    /// covariance widened as when a map made elsewhere sees it through frames known only so
    /// well: `position_variance_m2` on each axis; the frame turned about its origin by
    /// `frame_angle_variance_rad2` about each axis, which moves the camera's position with
    /// its lever arm as well as its heading; and the camera turned about itself by
    /// `heading_variance_rad2`.
    pub fn camera_only(
        &self,
        position_variance_m2: f64,
        frame_angle_variance_rad2: f64,
        heading_variance_rad2: f64,
    ) -> MonoEkf {
        let x = self.x.rows(0, CAMERA_STATE).clone_owned();
        let mut p = self
            .p
            .view((0, 0), (CAMERA_STATE, CAMERA_STATE))
            .clone_owned();
        for i in 0..3 {
            p[(i, i)] += position_variance_m2;
        }
        // A small rotation δ about the world axes turns q into exp(δ) q, and a position
        // about the frame's origin into exp(δ) r.
        let q = self.orientation();
        let r = self.position_m();
        for (variance, lever) in [
            (frame_angle_variance_rad2, r),
            (heading_variance_rad2, Vector3::zeros()),
        ] {
            if let Some(j) = jacobian(&[0.0; 3], 7, |d| {
                let turn = UnitQuaternion::from_scaled_axis(Vector3::new(d[0], d[1], d[2]));
                let moved = turn * lever;
                let turned = turn * q;
                Some(vec![
                    moved.x, moved.y, moved.z, turned.w, turned.i, turned.j, turned.k,
                ])
            }) {
                let widened = &j * j.transpose() * variance;
                let mut block = p.view_mut((0, 0), (7, 7));
                block += widened;
            }
        }
        MonoEkf {
            options: self.options,
            camera: self.camera,
            x,
            p,
            kinds: Vec::new(),
            offsets: Vec::new(),
        }
    }

    /// The camera's position and orientation variances, each the mean over its three axes
    /// (m², rad² about the world axes).
    pub fn pose_variances(&self) -> (f64, f64) {
        let position = self.p.view((0, 0), (3, 3)).trace() / 3.0;
        (position, self.orientation_covariance().trace() / 3.0)
    }

    /// The covariance of the camera's orientation as a small rotation `δ` about the world
    /// axes (the true orientation `exp(δ)` times the estimate), rad².
    pub fn orientation_covariance(&self) -> nalgebra::Matrix3<f64> {
        let q = self.orientation();
        jacobian(&[q.w, q.i, q.j, q.k], 3, |c| {
            let turned = quaternion(c) * q.inverse();
            Some(turned.scaled_axis().as_slice().to_vec())
        })
        .map_or_else(nalgebra::Matrix3::zeros, |j| {
            let c = &j * self.p.view((3, 3), (4, 4)) * j.transpose();
            nalgebra::Matrix3::from_fn(|r, k| 0.5 * (c[(r, k)] + c[(k, r)]))
        })
    }

    /// Adds a feature with these numbers and covariance, uncorrelated with the rest (a
    /// feature of another map). Returns its index.
    pub fn add_feature_with(
        &mut self,
        kind: FeatureKind,
        feature: &[f64],
        covariance: &DMatrix<f64>,
    ) -> usize {
        let n = self.x.len();
        let size = kind.size();
        let mut x = DVector::zeros(n + size);
        x.rows_mut(0, n).copy_from(&self.x);
        x.rows_mut(n, size).copy_from_slice(feature);
        let mut p = DMatrix::zeros(n + size, n + size);
        p.view_mut((0, 0), (n, n)).copy_from(&self.p);
        p.view_mut((n, n), (size, size)).copy_from(covariance);
        self.x = x;
        self.p = p;
        self.kinds.push(kind);
        self.offsets.push(n);
        self.kinds.len() - 1
    }

    /// The camera's pose: position and `world_from_camera`.
    pub fn pose(&self) -> (Vector3<f64>, UnitQuaternion<f64>) {
        (self.position_m(), self.orientation())
    }

    /// Propagates the camera by constant velocity over `dt_s`.
    pub fn predict(&mut self, dt_s: f64) {
        if dt_s <= 0.0 {
            return;
        }
        let camera: Vec<f64> = self.x.as_slice()[..CAMERA_STATE].to_vec();
        let zero = [0.0; 6];
        let next = motion(&camera, &zero, dt_s);
        let f = jacobian(&camera, CAMERA_STATE, |c| {
            Some(motion(c, &zero, dt_s).to_vec())
        })
        .unwrap_or_else(|| DMatrix::identity(CAMERA_STATE, CAMERA_STATE));
        let g = jacobian(&zero, CAMERA_STATE, |n| {
            let impulse = [n[0], n[1], n[2], n[3], n[4], n[5]];
            Some(motion(&camera, &impulse, dt_s).to_vec())
        })
        .unwrap_or_else(|| DMatrix::zeros(CAMERA_STATE, 6));
        let (a, alpha) = (
            self.options.linear_acceleration_sigma * dt_s,
            self.options.angular_acceleration_sigma * dt_s,
        );
        let q = DMatrix::from_diagonal(&DVector::from_vec(vec![
            a * a,
            a * a,
            a * a,
            alpha * alpha,
            alpha * alpha,
            alpha * alpha,
        ]));
        let n = self.x.len();
        self.x.as_mut_slice()[..CAMERA_STATE].copy_from_slice(&next);
        let pcc = self
            .p
            .view((0, 0), (CAMERA_STATE, CAMERA_STATE))
            .clone_owned();
        let new_pcc = &f * pcc * f.transpose() + &g * q * g.transpose();
        let rest = n - CAMERA_STATE;
        if rest > 0 {
            let pcf = self
                .p
                .view((0, CAMERA_STATE), (CAMERA_STATE, rest))
                .clone_owned();
            let new_pcf = &f * pcf;
            self.p
                .view_mut((0, CAMERA_STATE), (CAMERA_STATE, rest))
                .copy_from(&new_pcf);
            self.p
                .view_mut((CAMERA_STATE, 0), (rest, CAMERA_STATE))
                .copy_from(&new_pcf.transpose());
        }
        self.p
            .view_mut((0, 0), (CAMERA_STATE, CAMERA_STATE))
            .copy_from(&new_pcc);
        self.normalise_quaternion();
    }

    fn normalise_quaternion(&mut self) {
        let norm = self.x.rows(3, 4).norm();
        if norm > 0.0 {
            for i in 3..7 {
                self.x[i] /= norm;
            }
        }
    }

    /// The pixel of feature `index` seen from the state `x`.
    fn pixel_at(&self, x: &DVector<f64>, index: usize) -> Option<[f64; 2]> {
        let offset = self.offsets[index];
        let kind = self.kinds[index];
        let feature = &x.as_slice()[offset..offset + kind.size()];
        self.camera
            .project(&in_camera(&x.as_slice()[..CAMERA_STATE], kind, feature))
    }

    /// The pixel of feature `index` from the current mean.
    pub fn pixel(&self, index: usize) -> Option<[f64; 2]> {
        self.pixel_at(&self.x, index)
    }

    /// Feature `index`'s predicted measurement, or `None` when it lies behind the camera.
    pub fn predict_measurement(&self, index: usize) -> Option<Prediction> {
        let pixel = self.pixel(index)?;
        let kind = self.kinds[index];
        let offset = self.offsets[index];
        let camera_state = &self.x.as_slice()[..CAMERA_STATE];
        let feature = self.feature(index);
        let project = |c: &[f64], f: &[f64]| {
            self.camera
                .project(&in_camera(c, kind, f))
                .map(|p| p.to_vec())
        };
        let jacobian_camera = jacobian(camera_state, 2, |c| project(c, feature))?;
        let jacobian_feature = jacobian(feature, 2, |f| project(camera_state, f))?;
        let size = kind.size();
        let pcc = self.p.view((0, 0), (CAMERA_STATE, CAMERA_STATE));
        let pcf = self.p.view((0, offset), (CAMERA_STATE, size));
        let pff = self.p.view((offset, offset), (size, size));
        let hc = &jacobian_camera;
        let hf = &jacobian_feature;
        let cross = hc * pcf * hf.transpose();
        let s = hc * pcc * hc.transpose() + &cross + cross.transpose() + hf * pff * hf.transpose();
        let sigma2 = self.options.pixel_sigma_px * self.options.pixel_sigma_px;
        let innovation_covariance =
            Matrix2::new(s[(0, 0)] + sigma2, s[(0, 1)], s[(1, 0)], s[(1, 1)] + sigma2);
        Some(Prediction {
            pixel,
            jacobian_camera,
            jacobian_feature,
            innovation_covariance,
        })
    }

    /// `P Hᵀ` for one feature's measurement (`n × 2`).
    fn p_ht(&self, index: usize, prediction: &Prediction) -> DMatrix<f64> {
        let n = self.x.len();
        let offset = self.offsets[index];
        let size = self.kinds[index].size();
        self.p.view((0, 0), (n, CAMERA_STATE)) * prediction.jacobian_camera.transpose()
            + self.p.view((0, offset), (n, size)) * prediction.jacobian_feature.transpose()
    }

    /// The state mean after updating with feature `index` measured at `pixel` alone (the
    /// covariance untouched): a 1-point RANSAC hypothesis.
    pub fn hypothesis(
        &self,
        index: usize,
        prediction: &Prediction,
        pixel: [f64; 2],
    ) -> Option<DVector<f64>> {
        let s_inv = prediction.innovation_covariance.try_inverse()?;
        let gain = self.p_ht(index, prediction) * s_inv;
        let innovation = nalgebra::Vector2::new(
            pixel[0] - prediction.pixel[0],
            pixel[1] - prediction.pixel[1],
        );
        Some(&self.x + gain * innovation)
    }

    /// The pixel of feature `index` from the state `x` (a hypothesis).
    pub fn pixel_in(&self, x: &DVector<f64>, index: usize) -> Option<[f64; 2]> {
        self.pixel_at(x, index)
    }

    /// Updates with the features `measured` (index and pixel) together. Returns false (and
    /// leaves the state) when the innovation covariance is not positive definite.
    pub fn update(&mut self, measured: &[(usize, [f64; 2])]) -> bool {
        let rows: Vec<(usize, [f64; 2], Prediction)> = measured
            .iter()
            .filter_map(|&(index, pixel)| Some((index, pixel, self.predict_measurement(index)?)))
            .collect();
        if rows.is_empty() {
            return false;
        }
        let n = self.x.len();
        let m = 2 * rows.len();
        let mut h = DMatrix::zeros(m, n);
        let mut innovation = DVector::zeros(m);
        for (k, (index, pixel, prediction)) in rows.iter().enumerate() {
            let offset = self.offsets[*index];
            let size = self.kinds[*index].size();
            h.view_mut((2 * k, 0), (2, CAMERA_STATE))
                .copy_from(&prediction.jacobian_camera);
            h.view_mut((2 * k, offset), (2, size))
                .copy_from(&prediction.jacobian_feature);
            innovation[2 * k] = pixel[0] - prediction.pixel[0];
            innovation[2 * k + 1] = pixel[1] - prediction.pixel[1];
        }
        let p_ht = &self.p * h.transpose();
        let sigma2 = self.options.pixel_sigma_px * self.options.pixel_sigma_px;
        let s = &h * &p_ht + DMatrix::identity(m, m) * sigma2;
        self.apply_update(&p_ht, s, &innovation)
    }

    /// The Kalman update with `P Hᵀ`, the innovation covariance `S` and the innovation;
    /// false (and the state left) when `S` is not positive definite.
    fn apply_update(
        &mut self,
        p_ht: &DMatrix<f64>,
        s: DMatrix<f64>,
        innovation: &DVector<f64>,
    ) -> bool {
        let Some(cholesky) = s.cholesky() else {
            return false;
        };
        // K = P Hᵀ S⁻¹, as the solution of S Kᵀ = H P.
        let gain = cholesky.solve(&p_ht.transpose()).transpose();
        self.x += &gain * innovation;
        self.p -= &gain * p_ht.transpose();
        self.p = (&self.p + self.p.transpose()) * 0.5;
        self.normalise_quaternion();
        true
    }

    /// Holds every inverse-depth feature's inverse depth at or above zero: a point seen lies
    /// in front of the camera that first saw it, at most at infinity. Where the mean has
    /// crossed zero, it is projected onto the constraint along the covariance (the
    /// minimum-variance projection of an equality-constrained Kalman filter, Simon and
    /// Chia 2002): `x -= P Dᵀ (D P Dᵀ)⁻¹ D x` over the violated depths `D x`, so that the
    /// states correlated with them (the velocity, the other depths) move with them. The
    /// covariance is kept: only the mean is projected.
    /// A projection can push another depth below zero; a few passes take those in too.
    pub fn hold_inverse_depths_positive(&mut self) {
        const PASSES: usize = 4;
        for _ in 0..PASSES {
            let rows: Vec<usize> = self
                .kinds
                .iter()
                .zip(&self.offsets)
                .filter(|(k, o)| **k == FeatureKind::InverseDepth && self.x[**o + 5] < 0.0)
                .map(|(_, o)| o + 5)
                .collect();
            if rows.is_empty() {
                return;
            }
            let k = rows.len();
            let d_p_dt = DMatrix::from_fn(k, k, |r, c| self.p[(rows[r], rows[c])]);
            let violation = DVector::from_fn(k, |r, _| self.x[rows[r]]);
            let n = self.x.len();
            let p_dt = DMatrix::from_fn(n, k, |r, c| self.p[(r, rows[c])]);
            if let Some(cholesky) = d_p_dt.cholesky() {
                self.x -= p_dt * cholesky.solve(&violation);
            }
            // Exactly on the bound (rounding, or a depth whose variance is gone).
            for &r in &rows {
                self.x[r] = self.x[r].max(0.0);
            }
        }
    }

    /// Updates with the camera's tilt: a camera mounted level on a ground robot has its x
    /// (right) and z (forward) axes horizontal, up to the ground's slope. `down_in_world` is
    /// the unit vector along gravity in the filter's world frame; the measurement is the
    /// component of that vector along the camera's x and z axes (the sines of roll and pitch),
    /// zero with standard deviation `sigma_rad` each. Returns false (and leaves the state) when
    /// the innovation covariance is not positive definite.
    pub fn update_level(&mut self, down_in_world: &Vector3<f64>, sigma_rad: f64) -> bool {
        let tilt = |q: &[f64]| -> Vec<f64> {
            let down_in_camera = quaternion(q).inverse() * down_in_world;
            vec![down_in_camera.x, down_in_camera.z]
        };
        let q: Vec<f64> = self.x.rows(3, 4).iter().copied().collect();
        let Some(h) = jacobian(&q, 2, |q| Some(tilt(q))) else {
            return false;
        };
        let predicted = tilt(&q);
        let innovation = DVector::from_vec(vec![-predicted[0], -predicted[1]]);
        // Only the orientation's four columns of H are not zero.
        let p_ht = self.p.columns(3, 4) * h.transpose();
        let s = &h * p_ht.rows(3, 4) + DMatrix::identity(2, 2) * (sigma_rad * sigma_rad);
        self.apply_update(&p_ht, s, &innovation)
    }

    /// A camera looking forward from a ground vehicle moves along its optical axis, forwards
    /// ([`super::ForwardMotionPrior`]): the measurement is the camera's velocity along its x
    /// (right) and y (down) axes, zero with a standard deviation of `tan(sideslip_sigma_rad)`
    /// times the estimated speed each; and, while the estimate has the camera moving
    /// backwards, its velocity along z (forward) too, zero with the same deviation (the
    /// inequality `v_z ≥ 0` held where it is violated). A single camera cannot tell a camera
    /// moving forwards past points in front of it from one moving backwards past points at
    /// negative inverse depth; the vehicle can. The other half of that mirror is held too:
    /// every inverse depth stays at or above zero ([`Self::hold_inverse_depths_positive`]).
    /// Holding only the velocity leaves the filter, once noise has sent the depths below
    /// zero while the camera was still at rest, stuck with the camera at rest and the
    /// points behind it. Returns false (and leaves the state but for the depths) when the
    /// innovation covariance is not positive definite, as for a camera exactly at rest.
    pub fn update_forward_motion(&mut self, sideslip_sigma_rad: f64) -> bool {
        // The orientation (3..7) and the velocity (7..10), the only columns of H not zero.
        const FROM: usize = 3;
        const LEN: usize = 7;
        let velocity_in_camera = |qv: &[f64]| -> Vector3<f64> {
            quaternion(&qv[..4]).inverse() * Vector3::new(qv[4], qv[5], qv[6])
        };
        let qv: Vec<f64> = self.x.rows(FROM, LEN).iter().copied().collect();
        let rows = if velocity_in_camera(&qv).z < 0.0 {
            3
        } else {
            2
        };
        let measured =
            |qv: &[f64]| -> Vec<f64> { velocity_in_camera(qv).as_slice()[..rows].to_vec() };
        let Some(h) = jacobian(&qv, rows, |qv| Some(measured(qv))) else {
            return false;
        };
        let innovation = -DVector::from_vec(measured(&qv));
        let sigma = sideslip_sigma_rad.tan() * self.x.rows(7, 3).norm();
        let p_ht = self.p.columns(FROM, LEN) * h.transpose();
        let s = &h * p_ht.rows(FROM, LEN) + DMatrix::identity(rows, rows) * (sigma * sigma);
        let updated = self.apply_update(&p_ht, s, &innovation);
        self.hold_inverse_depths_positive();
        updated
    }

    /// Updates with a measurement of where the camera was on the ground `back_s` seconds
    /// before the state's time: its `x` and `z` (the world frame's horizontal axes, the
    /// world's `y` being along gravity), `measured_xz`, with covariance `covariance` (a GPS
    /// fix put into the map's frame). The position then is taken back from the state's by
    /// its velocity, as the constant-velocity model has it. Returns the measurement's χ²
    /// against its innovation covariance; the state is updated only where that is at most
    /// `max_chi2` (a gate: a measurement further off than the filter and the measurement
    /// together allow is left out). `None` (and the state left) when the measurement or its
    /// covariance is not finite, or the innovation covariance is not positive definite.
    pub fn update_ground_position(
        &mut self,
        measured_xz: [f64; 2],
        covariance: &Matrix2<f64>,
        back_s: f64,
        max_chi2: f64,
    ) -> Option<f64> {
        if !(measured_xz.iter().all(|v| v.is_finite())
            && covariance.iter().all(|v| v.is_finite())
            && back_s.is_finite())
        {
            return None;
        }
        // Only the position (0..3) and the velocity (7..10) columns of H are not zero.
        let mut h = DMatrix::zeros(2, 10);
        h[(0, 0)] = 1.0;
        h[(1, 2)] = 1.0;
        h[(0, 7)] = -back_s;
        h[(1, 9)] = -back_s;
        let innovation = DVector::from_vec(vec![
            measured_xz[0] - (self.x[0] - back_s * self.x[7]),
            measured_xz[1] - (self.x[2] - back_s * self.x[9]),
        ]);
        let p_ht = self.p.columns(0, 10) * h.transpose();
        let mut s = &h * p_ht.rows(0, 10);
        for r in 0..2 {
            for c in 0..2 {
                s[(r, c)] += covariance[(r, c)];
            }
        }
        let chi2 = s
            .clone()
            .cholesky()
            .map(|c| innovation.dot(&c.solve(&innovation)))?;
        if !chi2.is_finite() {
            return None;
        }
        if chi2 > max_chi2 {
            return Some(chi2);
        }
        self.apply_update(&p_ht, s, &innovation).then_some(chi2)
    }

    /// Adds a point of known position (world frame, m), uncorrelated with the rest, each
    /// coordinate with standard deviation `sigma_m`: a known target's corner. Returns its
    /// index.
    pub fn add_known_point(&mut self, position_m: Vector3<f64>, sigma_m: f64) -> usize {
        let covariance = DMatrix::identity(3, 3) * (sigma_m * sigma_m);
        self.add_feature_with(FeatureKind::Euclidean, position_m.as_slice(), &covariance)
    }

    /// Adds a feature first seen at `pixel` from the current camera pose, in inverse depth
    /// with the prior depth (undelayed initialisation). Returns its index, or `None` when the
    /// pixel has no ray (outside the calibrated field).
    pub fn add_feature(&mut self, pixel: [f64; 2]) -> Option<usize> {
        let [rho, sigma_rho] = self.options.initial_inverse_depth;
        let init = |pose: &[f64], pixel: &[f64]| -> Option<Vec<f64>> {
            let ray = self.camera.ray([pixel[0], pixel[1]])?;
            let d = quaternion(&pose[3..7]) * ray;
            let theta = d.x.atan2(d.z);
            let phi = (-d.y).atan2(d.x.hypot(d.z));
            Some(vec![pose[0], pose[1], pose[2], theta, phi])
        };
        let pose: Vec<f64> = self.x.as_slice()[..7].to_vec();
        let feature5 = init(&pose, &pixel)?;
        let j_pose = jacobian(&pose, 5, |p| init(p, &pixel))?;
        let j_pixel = jacobian(&pixel, 5, |px| init(&pose, px))?;
        let n = self.x.len();
        let mut x = DVector::zeros(n + 6);
        x.rows_mut(0, n).copy_from(&self.x);
        for (i, value) in feature5.iter().enumerate() {
            x[n + i] = *value;
        }
        x[n + 5] = rho;
        let mut p = DMatrix::zeros(n + 6, n + 6);
        p.view_mut((0, 0), (n, n)).copy_from(&self.p);
        // Cross-covariance with the rest of the state, through the pose.
        let cross = &j_pose * self.p.view((0, 0), (7, n)); // 5 × n
        p.view_mut((n, 0), (5, n)).copy_from(&cross);
        p.view_mut((0, n), (n, 5)).copy_from(&cross.transpose());
        let sigma2 = self.options.pixel_sigma_px * self.options.pixel_sigma_px;
        let own = &j_pose * self.p.view((0, 0), (7, 7)) * j_pose.transpose()
            + &j_pixel * j_pixel.transpose() * sigma2;
        p.view_mut((n, n), (5, 5)).copy_from(&own);
        p[(n + 5, n + 5)] = sigma_rho * sigma_rho;
        self.x = x;
        self.p = p;
        self.kinds.push(FeatureKind::InverseDepth);
        self.offsets.push(n);
        Some(self.kinds.len() - 1)
    }

    /// Civera's linearity index of inverse-depth feature `index`: how far from linear the
    /// map from inverse depth to point is over its uncertainty (small: convert it).
    pub fn linearity_index(&self, index: usize) -> Option<f64> {
        if self.kinds[index] != FeatureKind::InverseDepth {
            return None;
        }
        let f = self.feature(index);
        let offset = self.offsets[index];
        let rho = f[5];
        if rho <= 1e-6 {
            return None;
        }
        let sigma_rho = self.p[(offset + 5, offset + 5)].max(0.0).sqrt();
        let m = direction(f[3], f[4]);
        let point = Vector3::new(f[0], f[1], f[2]) + m / rho;
        let from_camera = point - self.position_m();
        let distance = from_camera.norm();
        if distance <= 0.0 {
            return None;
        }
        let cos_alpha = m.dot(&from_camera) / distance;
        let sigma_d = sigma_rho / (rho * rho);
        Some(4.0 * sigma_d / distance * cos_alpha.abs())
    }

    /// Turns inverse-depth features whose linearity index is below the threshold into
    /// Euclidean points. Returns how many were converted.
    pub fn convert_linear_features(&mut self) -> usize {
        let mut converted = 0;
        for index in 0..self.kinds.len() {
            if self
                .linearity_index(index)
                .is_some_and(|l| l < self.options.linearity_threshold)
            {
                self.convert(index);
                converted += 1;
            }
        }
        converted
    }

    fn convert(&mut self, index: usize) {
        let offset = self.offsets[index];
        let f: Vec<f64> = self.feature(index).to_vec();
        let to_point = |f: &[f64]| -> Option<Vec<f64>> {
            let p = Vector3::new(f[0], f[1], f[2]) + direction(f[3], f[4]) / f[5];
            Some(vec![p.x, p.y, p.z])
        };
        let Some(point) = to_point(&f) else { return };
        let Some(j) = jacobian(&f, 3, to_point) else {
            return;
        };
        let n = self.x.len();
        // T maps the old state to the new: identity, with the feature's 6 rows replaced by J.
        let mut t = DMatrix::zeros(n - 3, n);
        for i in 0..offset {
            t[(i, i)] = 1.0;
        }
        t.view_mut((offset, offset), (3, 6)).copy_from(&j);
        for i in offset + 6..n {
            t[(i - 3, i)] = 1.0;
        }
        let mut x = DVector::zeros(n - 3);
        x.rows_mut(0, offset).copy_from(&self.x.rows(0, offset));
        for (i, value) in point.iter().enumerate() {
            x[offset + i] = *value;
        }
        x.rows_mut(offset + 3, n - offset - 6)
            .copy_from(&self.x.rows(offset + 6, n - offset - 6));
        self.p = &t * &self.p * t.transpose();
        self.x = x;
        self.kinds[index] = FeatureKind::Euclidean;
        for later in &mut self.offsets[index + 1..] {
            *later -= 3;
        }
    }

    /// Removes feature `index` (later features move down by one).
    pub fn remove_feature(&mut self, index: usize) {
        let offset = self.offsets[index];
        let size = self.kinds[index].size();
        let n = self.x.len();
        let keep: Vec<usize> = (0..n)
            .filter(|&i| i < offset || i >= offset + size)
            .collect();
        self.x = DVector::from_iterator(keep.len(), keep.iter().map(|&i| self.x[i]));
        self.p = DMatrix::from_fn(keep.len(), keep.len(), |r, c| self.p[(keep[r], keep[c])]);
        self.kinds.remove(index);
        self.offsets.remove(index);
        for later in &mut self.offsets[index..] {
            *later -= size;
        }
    }

    /// Moves the state to a new frame at the camera (a new local map starts there): the
    /// camera at the origin with no rotation and an exactly known pose, its velocity and every
    /// feature expressed relative to it, and the covariance carried through the change, so that
    /// each feature keeps its uncertainty relative to the camera. Returns the new frame's
    /// position and orientation in the old one.
    ///
    /// With `level`, the world's y axis is down and stays so: the new frame is turned only
    /// by the camera's heading about it, and the camera keeps its tilt from level, and that
    /// tilt's uncertainty, in the new frame (a level prior, [`Self::update_level`], then holds
    /// the tilt itself, not only its change since the map started).
    pub fn rebase(&mut self, level: bool) -> (Vector3<f64>, UnitQuaternion<f64>) {
        let frame_rotation = |q: UnitQuaternion<f64>| if level { level_frame(q) } else { q };
        let old_from_new = (self.position_m(), frame_rotation(self.orientation()));
        let kinds = self.kinds.clone();
        let offsets = self.offsets.clone();
        let transform = |x: &[f64]| -> Option<Vec<f64>> {
            let r = Vector3::new(x[0], x[1], x[2]);
            let camera = quaternion(&x[3..7]);
            let new_from_old = frame_rotation(camera).inverse();
            let q = (new_from_old * camera).into_inner();
            let mut out = x.to_vec();
            out[..7].copy_from_slice(&[0.0, 0.0, 0.0, q.w, q.i, q.j, q.k]);
            let v = new_from_old * Vector3::new(x[7], x[8], x[9]);
            out[7..10].copy_from_slice(v.as_slice());
            let translation = -(new_from_old * r);
            for (&kind, &offset) in kinds.iter().zip(&offsets) {
                let range = offset..offset + kind.size();
                let moved = moved_feature(kind, &x[range.clone()], new_from_old, translation);
                out[range].copy_from_slice(&moved);
            }
            Some(out)
        };
        let n = self.x.len();
        let (Some(x), Some(j)) = (
            transform(self.x.as_slice()),
            jacobian(self.x.as_slice(), n, transform),
        ) else {
            return old_from_new;
        };
        self.x = DVector::from_vec(x);
        self.p = &j * &self.p * j.transpose();
        self.p = (&self.p + self.p.transpose()) * 0.5;
        old_from_new
    }

    /// The options the filter was made with.
    pub fn options(&self) -> &MonoEkfOptions {
        &self.options
    }

    /// The covariance of the camera's linear velocity (world frame), (m/s)².
    pub fn velocity_covariance(&self) -> nalgebra::Matrix3<f64> {
        self.p.fixed_view::<3, 3>(7, 7).clone_owned()
    }

    /// The covariance of the camera's angular velocity (camera frame), (rad/s)².
    pub fn angular_velocity_covariance(&self) -> nalgebra::Matrix3<f64> {
        self.p.fixed_view::<3, 3>(10, 10).clone_owned()
    }

    /// The camera part of the covariance's position block, m².
    pub fn position_covariance(&self) -> nalgebra::Matrix3<f64> {
        self.p.fixed_view::<3, 3>(0, 0).clone_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> PinholeCamera {
        PinholeCamera::ideal(500.0, 500.0, 320.0, 240.0, [640, 480])
    }

    #[test]
    fn the_forward_motion_prior_turns_the_velocity_onto_the_axis_and_never_backwards() {
        let prior = 3f64.to_radians();
        let velocity_in_camera =
            |filter: &MonoEkf| filter.orientation().inverse() * filter.x.fixed_rows::<3>(7);
        // Sliding sideways and down as it drives forward: pulled onto the optical axis.
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        filter.x.as_mut_slice()[7..10].copy_from_slice(&[0.5, 0.3, 2.0]);
        for _ in 0..3 {
            assert!(filter.update_forward_motion(prior));
        }
        let v = velocity_in_camera(&filter);
        assert!(v.x.hypot(v.y) < 0.05 * v.z, "{v:?}");
        // Backwards along the axis: the forward speed is pulled to at least 0.
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        filter.x.as_mut_slice()[7..10].copy_from_slice(&[0.0, 0.0, -1.0]);
        assert!(filter.update_forward_motion(prior));
        let v = velocity_in_camera(&filter);
        assert!(v.z > -0.05, "{v:?}");
        // At rest and exactly known, there is nothing to update.
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        filter.p.fill(0.0);
        assert!(!filter.update_forward_motion(prior));
    }

    #[test]
    fn a_ground_position_moves_where_the_camera_was_and_a_far_one_is_left_out() {
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        // Driving forward at 2 m/s, its position known to a metre.
        filter.x.as_mut_slice()[7..10].copy_from_slice(&[0.0, 0.0, 2.0]);
        for i in 0..3 {
            filter.p[(i, i)] = 1.0;
        }
        // Half a second ago the camera was at z = −1 by the estimate; measured at (0.5, −0.7).
        let exact = Matrix2::identity() * 1e-6;
        let chi2 = filter
            .update_ground_position([0.5, -0.7], &exact, 0.5, f64::INFINITY)
            .expect("a positive innovation covariance");
        assert!(chi2 > 0.0);
        let then = |f: &MonoEkf| [f.x[0] - 0.5 * f.x[7], f.x[2] - 0.5 * f.x[9]];
        let [x, z] = then(&filter);
        assert!((x - 0.5).abs() < 1e-3 && (z + 0.7).abs() < 1e-3, "{x} {z}");
        // The height is not measured, and nothing correlates it here.
        assert!(filter.x[1].abs() < 1e-12);
        // A fix 100 m off, beyond the gate, leaves the state.
        let before = filter.x.clone();
        let chi2 = filter
            .update_ground_position([100.0, 0.0], &(Matrix2::identity() * 0.25), 0.0, 13.8)
            .expect("a positive innovation covariance");
        assert!(chi2 > 13.8, "{chi2}");
        assert_eq!(filter.x, before);
        // Nor does a measurement that is not a number.
        let p = filter.p.clone();
        let none = filter.update_ground_position([f64::NAN, 0.0], &exact, 0.0, 13.8);
        assert!(none.is_none());
        assert_eq!((&filter.x, &filter.p), (&before, &p));
    }

    #[test]
    fn the_level_prior_pulls_roll_and_pitch_to_level_and_leaves_the_heading() {
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        // Turned 40° about the vertical (y, down), then pitched 6° and rolled 4°.
        let heading = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.7);
        let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 6f64.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 4f64.to_radians());
        let q = heading * tilt;
        filter.x.as_mut_slice()[3..7].copy_from_slice(&[q.w, q.i, q.j, q.k]);
        // The quaternion uncertain by about 10° about every axis.
        let g = jacobian(&[0.0; 3], 4, |d| {
            let turned = UnitQuaternion::from_scaled_axis(Vector3::new(d[0], d[1], d[2])) * q;
            Some(vec![turned.w, turned.i, turned.j, turned.k])
        })
        .unwrap();
        let covariance = &g * (DMatrix::identity(3, 3) * 0.03) * g.transpose();
        filter.p.view_mut((3, 3), (4, 4)).copy_from(&covariance);
        let tilt_of = |filter: &MonoEkf| {
            let down_in_camera = filter.orientation().inverse() * Vector3::y();
            down_in_camera.x.hypot(down_in_camera.z).asin().to_degrees()
        };
        let heading_of = |filter: &MonoEkf| {
            let forward = filter.orientation() * Vector3::z();
            forward.x.atan2(forward.z).to_degrees()
        };
        assert!(tilt_of(&filter) > 7.0);
        for _ in 0..5 {
            assert!(filter.update_level(&Vector3::y(), 0.5f64.to_radians()));
        }
        assert!(tilt_of(&filter) < 0.2, "{:.2}° off level", tilt_of(&filter));
        // The heading of the optical axis stays where the features would leave it.
        let before = q * Vector3::z();
        let heading_before = before.x.atan2(before.z).to_degrees();
        assert!(
            (heading_of(&filter) - heading_before).abs() < 1.0,
            "{:.2}° against {heading_before:.2}°",
            heading_of(&filter)
        );
        // Roll and pitch are now known to about the prior's width, the heading as before.
        let covariance = filter.orientation_covariance();
        assert!(covariance[(0, 0)].sqrt().to_degrees() < 0.5);
        assert!(covariance[(2, 2)].sqrt().to_degrees() < 0.5);
        assert!(covariance[(1, 1)].sqrt() > 0.1, "{covariance}");
    }

    #[test]
    fn the_orientation_covariance_is_that_of_a_small_turn_about_the_world_axes() {
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        let q = UnitQuaternion::from_euler_angles(0.2, -0.4, 1.1);
        filter.x.as_mut_slice()[3..7].copy_from_slice(&[q.w, q.i, q.j, q.k]);
        // The quaternion's covariance for a turn exp(δ) q with δ of this covariance.
        let turn = nalgebra::Matrix3::new(4e-4, 1e-4, 0.0, 1e-4, 1e-4, 0.0, 0.0, 0.0, 9e-4);
        let g = jacobian(&[0.0; 3], 4, |d| {
            let turned = UnitQuaternion::from_scaled_axis(Vector3::new(d[0], d[1], d[2])) * q;
            Some(vec![turned.w, turned.i, turned.j, turned.k])
        })
        .expect("differentiable");
        let block = &g * DMatrix::from_column_slice(3, 3, turn.as_slice()) * g.transpose();
        filter.p.view_mut((3, 3), (4, 4)).copy_from(&block);
        let got = filter.orientation_covariance();
        assert!((got - turn).abs().max() < 1e-8, "{got} against {turn}");
    }

    #[test]
    fn a_turned_frame_moves_the_camera_with_its_lever_arm() {
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        filter.x[0] = 3.0;
        let before = filter.position_covariance();
        let variance = 1e-4;
        // Turning the frame about its origin moves a camera 3 m out along x across x, not
        // along it: by 3 m × the angle about each of the other two axes.
        let grown = filter.camera_only(0.0, variance, 0.0).position_covariance() - before;
        assert!(grown[(0, 0)].abs() < 1e-9, "{grown}");
        for axis in 1..3 {
            assert!(
                (grown[(axis, axis)] - 9.0 * variance).abs() < 1e-6 * variance,
                "{grown}"
            );
        }
        // Turning the camera about itself moves it nowhere.
        let turned = filter.camera_only(0.0, 0.0, variance).position_covariance() - before;
        assert!(turned.abs().max() < 1e-12, "{turned}");
    }

    #[test]
    fn a_new_feature_projects_to_where_it_was_seen() {
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        let index = filter.add_feature([100.0, 300.0]).expect("ray");
        let pixel = filter.pixel(index).expect("in front");
        assert!((pixel[0] - 100.0).abs() < 1e-6 && (pixel[1] - 300.0).abs() < 1e-6);
        assert_eq!(filter.state_size(), CAMERA_STATE + 6);
    }

    /// Two seconds at 30 Hz of the camera moving 1 m/s to the right, measuring `points`
    /// exactly, with features converted to points once their depth is known.
    fn walk_sideways(filter: &mut MonoEkf, points: &[Vector3<f64>]) {
        let cam = *filter.camera();
        let dt = 1.0 / 30.0;
        for frame in 1..=60 {
            filter.predict(dt);
            let position = Vector3::new(frame as f64 * dt, 0.0, 0.0);
            let measured: Vec<(usize, [f64; 2])> = points
                .iter()
                .enumerate()
                .filter_map(|(i, p)| Some((i, cam.project(&(p - position))?)))
                .collect();
            assert!(filter.update(&measured));
            filter.convert_linear_features();
        }
    }

    #[test]
    fn sideways_motion_fixes_the_features_depths_up_to_scale() {
        // A camera moving along x at 1 m/s sees points 4 m ahead; the filter, told nothing
        // of the motion, learns it and the depths from the pixels alone, up to the scale a
        // single camera cannot see (the velocity prior sets it; the test fits it).
        let points = [
            Vector3::new(-1.0, -0.5, 4.0),
            Vector3::new(1.0, 0.3, 4.5),
            Vector3::new(0.2, 0.8, 3.5),
            Vector3::new(-0.6, 0.6, 5.0),
            Vector3::new(0.8, -0.7, 4.2),
            Vector3::new(0.0, 0.0, 6.0),
        ];
        let cam = camera();
        let mut filter = MonoEkf::new(cam, MonoEkfOptions::default());
        for p in &points {
            let pixel = cam.project(p).expect("in front");
            filter.add_feature(pixel);
        }
        walk_sideways(&mut filter, &points);
        // The scale that best takes the estimated points to the true ones.
        let estimates: Vec<Vector3<f64>> = (0..points.len())
            .map(|i| filter.point_in_world(i).expect("a depth"))
            .collect();
        let scale = estimates
            .iter()
            .zip(&points)
            .map(|(e, p)| e.dot(p))
            .sum::<f64>()
            / points.iter().map(|p| p.norm_squared()).sum::<f64>();
        assert!(scale > 0.2, "scale {scale}");
        for (e, p) in estimates.iter().zip(&points) {
            assert!((e / scale - p).norm() < 0.1, "{e} / {scale} against {p}");
        }
        // The camera starts at rest in the filter, so the first frames lag the truth.
        let travelled = filter.position_m() / scale;
        assert!(
            (travelled - Vector3::new(2.0, 0.0, 0.0)).norm() < 0.15,
            "{travelled}"
        );
    }

    /// A filter that walked sideways past four points, and the points.
    fn walked_past_four_points() -> (MonoEkf, [Vector3<f64>; 4]) {
        let cam = camera();
        let mut filter = MonoEkf::new(cam, MonoEkfOptions::default());
        let points = [
            Vector3::new(-1.0, -0.5, 4.0),
            Vector3::new(1.0, 0.3, 4.5),
            Vector3::new(0.2, 0.8, 3.5),
            Vector3::new(-0.6, 0.6, 5.0),
        ];
        for p in &points {
            filter.add_feature(cam.project(p).expect("in front"));
        }
        walk_sideways(&mut filter, &points);
        (filter, points)
    }

    /// Rebases `filter` and checks that no feature's pixel or point moved; returns the new
    /// frame's position and orientation in the old one.
    fn rebase_in_place(filter: &mut MonoEkf, level: bool) -> (Vector3<f64>, UnitQuaternion<f64>) {
        let features = filter.num_features();
        let pixels: Vec<[f64; 2]> = (0..features).map(|i| filter.pixel(i).unwrap()).collect();
        let in_old: Vec<Vector3<f64>> = (0..features)
            .map(|i| filter.point_in_world(i).unwrap())
            .collect();
        let (origin, rotation) = filter.rebase(level);
        assert!(filter.position_m().norm() < 1e-12);
        for i in 0..features {
            let pixel = filter.pixel(i).unwrap();
            assert!((pixel[0] - pixels[i][0]).hypot(pixel[1] - pixels[i][1]) < 1e-6);
            let back = rotation * filter.point_in_world(i).unwrap() + origin;
            assert!(
                (back - in_old[i]).norm() < 1e-9,
                "{back} against {}",
                in_old[i]
            );
        }
        (origin, rotation)
    }

    #[test]
    fn a_new_frame_at_the_camera_changes_no_pixel_and_no_point() {
        let (mut filter, _) = walked_past_four_points();
        rebase_in_place(&mut filter, false);
        assert!(filter.orientation().angle() < 1e-12);
        assert!(filter.p.view((0, 0), (7, 7)).norm() < 1e-9);
        // Each feature keeps its uncertainty relative to the camera: not less than before.
        assert!(filter.p.view((CAMERA_STATE, CAMERA_STATE), (6, 6)).norm() > 0.0);
    }

    #[test]
    fn a_level_frame_turns_with_the_heading_and_leaves_the_camera_its_tilt() {
        let (mut filter, _) = walked_past_four_points();
        // Turned 6° about the vertical and pitched 3°, the orientation uncertain.
        let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 3f64.to_radians());
        let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.1) * tilt;
        filter.x.as_mut_slice()[3..7].copy_from_slice(&[q.w, q.i, q.j, q.k]);
        let orientation = DMatrix::identity(4, 4) * 1e-3;
        filter.p.view_mut((3, 3), (4, 4)).copy_from(&orientation);
        let (_, rotation) = rebase_in_place(&mut filter, true);
        // The frame turned by the heading only; the camera keeps its 3° of pitch.
        assert!((rotation.angle() - 0.1).abs() < 1e-9);
        assert!((rotation.axis().unwrap().y - 1.0).abs() < 1e-9);
        assert!(filter.orientation().angle_to(&tilt) < 1e-9);
        // The tilt stays uncertain; the heading about the new frame's vertical is exact (a
        // turn about the vertical is left only by the pitched camera's turn about its roll
        // axis, sin 3° of it).
        let covariance = filter.orientation_covariance();
        assert!(covariance[(0, 0)] > 1e-4 && covariance[(2, 2)] > 1e-4);
        assert!(
            covariance[(1, 1)] < 0.01 * covariance[(2, 2)],
            "{covariance}"
        );
    }

    #[test]
    fn a_feature_with_a_certain_depth_becomes_a_euclidean_point_in_place() {
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        filter.add_feature([100.0, 100.0]);
        let index = filter.add_feature([400.0, 300.0]).expect("ray");
        filter.add_feature([200.0, 50.0]);
        // Its depth known to a tenth of a percent.
        let rho = filter.offsets[index] + 5;
        for i in 0..filter.state_size() {
            filter.p[(rho, i)] = 0.0;
            filter.p[(i, rho)] = 0.0;
        }
        filter.p[(rho, rho)] = (1e-3 * filter.x[rho]).powi(2);
        let point = filter.point_in_world(index).expect("a depth");
        let pixels: Vec<_> = (0..3).map(|i| filter.pixel(i).expect("in front")).collect();
        assert_eq!(filter.convert_linear_features(), 1);
        assert_eq!(filter.kind(index), FeatureKind::Euclidean);
        assert_eq!(filter.state_size(), CAMERA_STATE + 6 + 3 + 6);
        assert!((filter.point_in_world(index).expect("a point") - point).norm() < 1e-9);
        for (i, before) in pixels.iter().enumerate() {
            let after = filter.pixel(i).expect("in front");
            assert!(
                (after[0] - before[0]).hypot(after[1] - before[1]) < 1e-6,
                "feature {i}"
            );
        }
    }

    #[test]
    fn removing_a_feature_keeps_the_others() {
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        for pixel in [[100.0, 100.0], [200.0, 200.0], [300.0, 300.0]] {
            filter.add_feature(pixel);
        }
        filter.remove_feature(1);
        assert_eq!(filter.num_features(), 2);
        let pixel = filter.pixel(1).expect("in front");
        assert!((pixel[0] - 300.0).abs() < 1e-6);
    }

    #[test]
    fn a_depth_below_zero_is_projected_onto_zero_and_moves_what_it_is_correlated_with() {
        let mut filter = MonoEkf::new(camera(), MonoEkfOptions::default());
        for pixel in [[100.0, 100.0], [300.0, 200.0], [500.0, 300.0]] {
            filter.add_feature(pixel);
        }
        let rho = |filter: &MonoEkf, i: usize| filter.x[filter.offsets[i] + 5];
        let first = filter.offsets[0] + 5;
        // The first depth has crossed zero; the forward velocity is correlated with it
        // (correlation 0.5), the second depth not at all.
        filter.x[first] = -0.1;
        let (sigma_rho, sigma_v) = (filter.p[(first, first)].sqrt(), filter.p[(9, 9)].sqrt());
        filter.p[(first, 9)] = 0.5 * sigma_rho * sigma_v;
        filter.p[(9, first)] = filter.p[(first, 9)];
        let second_before = rho(&filter, 1);
        let p_before = filter.p.clone();
        filter.hold_inverse_depths_positive();
        assert_eq!(rho(&filter, 0), 0.0);
        assert_eq!(rho(&filter, 1), second_before);
        assert!(rho(&filter, 2) >= 0.0);
        // The velocity moves by its regression on the depth: 0.5 σ_v / σ_ρ × 0.1.
        let expected = 0.5 * sigma_v / sigma_rho * 0.1;
        assert!((filter.x[9] - expected).abs() < 1e-12, "{}", filter.x[9]);
        // The covariance is left as it was.
        assert_eq!(filter.p, p_before);
    }
}

#[cfg(test)]
mod ideal_drive {
    use super::*;
    use crate::camera::ForwardMotionPrior;

    /// Points beside a straight road, trees and ground: x 2–17 m to the right (and, with
    /// `both_sides`, as many to the left), y from 2 m below the camera to 1.2 m above it, z
    /// from 5 m behind the start to 75 m ahead.
    fn roadside(count: usize, both_sides: bool) -> Vec<Vector3<f64>> {
        let mut state: u64 = 12345;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..count)
            .map(|_| {
                let side = if both_sides && uniform() < 0.5 {
                    -1.0
                } else {
                    1.0
                };
                Vector3::new(
                    side * (2.0 + 15.0 * uniform()),
                    -2.0 + 3.2 * uniform(),
                    -5.0 + 80.0 * uniform(),
                )
            })
            .collect()
    }

    /// The worst orientation error over a drive, degrees, and the worst NEES of it.
    struct Drive {
        max_error_deg: f64,
        max_nees: f64,
    }

    /// The filter alone, told the true association and given exact pixels of `points`: a
    /// camera starting from rest and driving straight ahead at up to 2 m/s for 10 s at
    /// `rate_hz`, at most 40 features, a point taken as a feature when fewer than 20 are in
    /// view and dropped when it leaves the view.
    fn drive(rate_hz: f64, points: &[Vector3<f64>], forward: Option<ForwardMotionPrior>) -> Drive {
        let cam = PinholeCamera::ideal(500.0, 500.0, 319.5, 239.5, [640, 480]);
        let dt = 1.0 / rate_hz;
        let mut filter = MonoEkf::new(cam, MonoEkfOptions::default());
        let mut worst = Drive {
            max_error_deg: 0.0,
            max_nees: 0.0,
        };
        // The point each feature is.
        let mut features: Vec<usize> = Vec::new();
        let frames = (10.0 * rate_hz).round() as usize;
        for frame in 0..=frames {
            if frame > 0 {
                filter.predict(dt);
                if let Some(forward) = forward {
                    filter.update_forward_motion(forward.sideslip_sigma_rad);
                }
            }
            // From rest, 2 m/s² up to 2 m/s, then on at that speed.
            let t = frame as f64 * dt;
            let position = Vector3::new(0.0, 0.0, if t < 1.0 { t * t } else { 2.0 * t - 1.0 });
            let pixel_of = |p: &Vector3<f64>| {
                cam.project(&(p - position))
                    .filter(|px| cam.contains(*px, 5.0))
            };
            let measured: Vec<(usize, [f64; 2])> = features
                .iter()
                .enumerate()
                .filter_map(|(f, &i)| Some((f, pixel_of(&points[i])?)))
                .collect();
            if !measured.is_empty() {
                assert!(filter.update(&measured));
            }
            filter.convert_linear_features();
            for f in (0..features.len()).rev() {
                if pixel_of(&points[features[f]]).is_none() {
                    filter.remove_feature(f);
                    features.remove(f);
                }
            }
            if features.len() < 20 {
                for (i, p) in points.iter().enumerate() {
                    if features.len() >= 40 {
                        break;
                    }
                    if !features.contains(&i)
                        && let Some(pixel) = pixel_of(p)
                        && filter.add_feature(pixel).is_some()
                    {
                        features.push(i);
                    }
                }
            }
            let error = filter.orientation().scaled_axis();
            worst.max_error_deg = worst.max_error_deg.max(error.norm().to_degrees());
            if let Some(information) = filter.orientation_covariance().try_inverse() {
                worst.max_nees = worst.max_nees.max(error.dot(&(information * error)));
            }
        }
        worst
    }

    /// The orientation must stay true and within what its covariance claims (NEES below
    /// χ²(3) at 99.9 %).
    fn assert_true_and_covered(drive: &Drive) {
        assert!(drive.max_error_deg < 0.2, "{:.3}° off", drive.max_error_deg);
        assert!(drive.max_nees < 16.3, "NEES {:.1}", drive.max_nees);
    }

    #[test]
    fn with_exact_pixels_the_orientation_stays_true_and_covered_at_10_hz() {
        assert_true_and_covered(&drive(10.0, &roadside(400, true), None));
    }

    #[test]
    fn with_exact_pixels_the_orientation_stays_true_and_covered_at_30_hz() {
        assert_true_and_covered(&drive(30.0, &roadside(400, true), None));
    }

    /// With every point on one side, a camera driving straight on and one sliding sideways
    /// while it turns see nearly the same images: exact pixels alone let the heading run
    /// away, and the forward-motion prior holds it.
    #[test]
    fn with_points_on_one_side_only_the_forward_motion_prior_holds_the_heading() {
        let points = roadside(400, false);
        let free = drive(10.0, &points, None);
        assert!(free.max_error_deg > 10.0, "{:.3}° off", free.max_error_deg);
        for rate_hz in [10.0, 30.0] {
            assert_true_and_covered(&drive(
                rate_hz,
                &points,
                Some(ForwardMotionPrior::default()),
            ));
        }
    }
}
