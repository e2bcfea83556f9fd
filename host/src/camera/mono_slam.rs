//! Method 1 on a single camera, frame by frame: prediction, active search, 1-point RANSAC,
//! feature management.
//!
//! For each frame the [`MonoEkf`] predicts the camera, then every feature that should be in
//! view is searched for where it can be: its patch is correlated ([`super::patch`]) at every
//! pixel inside its innovation ellipse at [`MonoSlamOptions::gate_chi2`] (active search,
//! Davison 2003). The matches go through 1-point RANSAC (Civera et al. 2010, "1-Point RANSAC
//! for EKF Filtering"): each match in turn updates the state alone, and the one that brings
//! most other matches within [`MonoSlamOptions::ransac_inlier_px`] of their predictions wins;
//! its supporters update the filter together, and the remaining matches that then fit the
//! updated prediction within its covariance are rescued in a second update. Every match is
//! tried as a hypothesis (a frame holds tens), so the result does not depend on chance.
//!
//! Features that are found in fewer than half of the frames where they were searched for are
//! deleted after [`MonoSlamOptions::min_attempts_to_delete`] searches. When fewer than
//! [`MonoSlamOptions::target_visible`] features were measured, new ones are taken from FAST
//! corners (Rosten and Drummond 2006, via `imageproc`) in the cells of a coarse image grid
//! that hold no feature. Inverse-depth features whose depth is well determined become
//! Euclidean points.
//!
//! Moving objects are kept out of the map twice over. A new feature's corner is first looked
//! for in the previous frame ([`super::motion_segmentation`]): found off the epipolar segment
//! the camera's estimated motion allows it, it moves on its own and is not taken. And each
//! feature's match is tested the same way against its match in the frame before: a feature
//! off its epipolar segment in [`MonoSlamOptions::max_off_segment_in_a_row`] frames in a row
//! (at the band's 99 %, three in a row happen to a static point once in a million) is deleted
//! as moving.

use std::sync::Arc;

use image::GrayImage;
use nalgebra::{DMatrix, UnitQuaternion, Vector2, Vector3};

use super::appearance::Appearance;
use super::forward_motion_prior::ForwardMotionPrior;
use super::history_memory::{CameraHistory, CameraHistoryOptions};
use super::known_target::{KnownTarget, TargetError};
use super::level_prior::LevelPrior;
use super::mono_ekf::{
    FeatureKind, MonoEkf, MonoEkfOptions, Prediction, moved_feature, moved_feature_with_covariance,
};
use super::motion_segmentation::{
    self, FrameMotion, MotionSegmentationOptions, PointMotion, classify, distance_from_segment,
};
use super::patch::Patch;
use super::patch::search;
use super::pinhole::PinholeCamera;

/// How the camera method searches, rejects and adds features.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MonoSlamOptions {
    pub ekf: MonoEkfOptions,
    /// Half the side of a feature's patch, px (5: 11 × 11).
    pub patch_half_px: u32,
    /// A match must correlate at least this well (NCC, −1 to 1).
    pub min_correlation: f32,
    /// The search region: pixels whose squared Mahalanobis distance from the prediction is
    /// below this (9.21: 99 % for two degrees of freedom).
    pub gate_chi2: f64,
    /// The search region reaches no further than this from the prediction on either axis,
    /// px: a wider ellipse (a new feature's depth, a sudden motion) is searched near its
    /// centre, where most of its probability lies.
    pub max_search_half_px: f64,
    /// A match within this of its prediction after a hypothesis's update supports it, px.
    pub ransac_inlier_px: f64,
    /// A match outside the hypothesis's support is rescued after the first update when its
    /// squared Mahalanobis innovation is below this (5.99: 95 %, two degrees of freedom).
    pub rescue_chi2: f64,
    /// New features are added while fewer than this many were measured.
    pub target_visible: usize,
    /// At most this many new features in one frame.
    pub max_new_per_frame: usize,
    /// The coarse grid new features are spread over: columns, rows.
    pub grid_cells: [u32; 2],
    /// FAST's intensity threshold, grey levels.
    pub fast_threshold: u8,
    /// A feature searched this often and found in fewer than half is deleted.
    pub min_attempts_to_delete: u32,
    /// A local map holds at most this many features: when a frame wants new ones and there is
    /// no room, a new local map starts at the camera with the features measured in that
    /// frame, and the others stay, finished, in the map.
    pub max_features: usize,
    /// A feature whose match leaves the epipolar segment of its match in the frame before in
    /// this many frames in a row is deleted as moving.
    pub max_off_segment_in_a_row: u32,
    /// How new features' corners are tested for motion of their own.
    pub motion_segmentation: MotionSegmentationOptions,
    /// A known target's corners are placed to this standard deviation on each axis, m.
    pub target_sigma_m: f64,
    /// Places seen before, recognised and their features used again.
    pub history: CameraHistoryOptions,
    /// The camera is held level (on a ground robot), and how level; `None` for a camera that
    /// may point anywhere (hand-held, or a recorded sequence).
    pub level: Option<LevelPrior>,
    /// The camera looks forward from a ground vehicle and moves along its optical axis, and
    /// how closely; `None` for a camera that may move in any direction (hand-held).
    pub forward_motion: Option<ForwardMotionPrior>,
}

impl Default for MonoSlamOptions {
    fn default() -> Self {
        MonoSlamOptions {
            ekf: MonoEkfOptions::default(),
            patch_half_px: 5,
            min_correlation: 0.8,
            gate_chi2: 9.21,
            max_search_half_px: 60.0,
            ransac_inlier_px: 2.0,
            rescue_chi2: 5.99,
            target_visible: 25,
            max_new_per_frame: 6,
            grid_cells: [8, 6],
            fast_threshold: 20,
            min_attempts_to_delete: 10,
            max_features: 100,
            max_off_segment_in_a_row: 3,
            motion_segmentation: MotionSegmentationOptions::default(),
            target_sigma_m: 0.005,
            history: CameraHistoryOptions::default(),
            level: None,
            forward_motion: None,
        }
    }
}

impl MonoSlamOptions {
    /// Holds `filter`, just predicted `dt_s` ahead, to the camera's mounting: level
    /// ([`Self::level`], gravity along `down_in_world` in the filter's world frame) and
    /// moving forward ([`Self::forward_motion`]), where they are set.
    pub fn hold_to_priors(&self, filter: &mut MonoEkf, down_in_world: &Vector3<f64>, dt_s: f64) {
        if let Some(level) = self.level {
            filter.update_level(down_in_world, level.sigma_per_frame_rad(dt_s));
        }
        if let Some(forward) = self.forward_motion {
            filter.update_forward_motion(forward.sideslip_sigma_rad);
        }
    }
}

/// A feature's appearance and its record.
#[derive(Clone, Debug)]
struct Track {
    appearance: Appearance,
    searched: u32,
    found: u32,
    last_seen_frame: usize,
    /// The last frame it was matched in, and where.
    last_match: Option<(usize, [f64; 2])>,
    /// Consecutive frames in which its match left the epipolar segment of the one before.
    off_segment_in_a_row: u32,
    /// Its record in the history memory, once it has one.
    history: Option<usize>,
}

impl Track {
    /// A feature first seen in `frame`.
    fn new(appearance: Appearance, frame: usize) -> Self {
        Track {
            appearance,
            searched: 0,
            found: 0,
            last_seen_frame: frame,
            last_match: None,
            off_segment_in_a_row: 0,
            history: None,
        }
    }
}

/// The frame before, for motion segmentation.
#[derive(Clone, Debug)]
struct PreviousFrame {
    image: GrayImage,
    time_s: f64,
    position: Vector3<f64>,
    orientation: UnitQuaternion<f64>,
}

/// What one frame did.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    pub time_s: f64,
    /// The camera's position in the world (first camera) frame.
    pub position_m: Vector3<f64>,
    /// `world_from_camera`.
    pub orientation: UnitQuaternion<f64>,
    /// Features predicted in view and searched for.
    pub searched: usize,
    /// Features whose patch was found in the search region.
    pub matched: usize,
    /// Matches that updated the filter (1-point RANSAC's support and those rescued).
    pub measured: usize,
    pub added: usize,
    /// Where the features added in this frame are, px.
    pub added_pixels: Vec<[f64; 2]>,
    pub deleted: usize,
    /// Features deleted as moving (their matches refused frame after frame).
    pub deleted_as_moving: usize,
    /// Corners not taken as features because they moved on their own.
    pub corners_moving: usize,
    /// The earlier local map whose place the history memory recognised in this frame (its
    /// index, the first map 0): the camera moved into that map's frame, so its position in
    /// the world jumps here.
    pub place_recognised: Option<usize>,
    /// With [`Self::place_recognised`], the jump: the camera's world pose after it is
    /// `rotation * before + translation` (the same for every point of the current local
    /// map), as `(translation, rotation)`.
    pub world_jump: Option<WorldJump>,
    /// The matches that updated the filter, each with the feature's first sighting.
    pub measurements: Vec<MeasuredFeature>,
}

/// A feature found in a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredFeature {
    /// Where the feature was first seen: the frame's number (from 0) and the pixel. A
    /// feature has one first sighting, so this names it across frames.
    pub first_sighting: (usize, [f64; 2]),
    /// Where it was found, px.
    pub pixel: [f64; 2],
}

/// A test every match must pass before the filter sees it, given the frame's number (from
/// 0) and the match (see [`MonoSlam::check_matches_with`]).
type MatchTest = dyn Fn(usize, &MeasuredFeature) -> bool + Send + Sync;

/// A [`MatchTest`], shared by the clones of a run.
#[derive(Clone)]
struct MatchCheck(Arc<MatchTest>);

impl std::fmt::Debug for MatchCheck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("MatchCheck")
    }
}

/// A change of the world frame's coordinates: `after = rotation * before + translation`, as
/// `(translation, rotation)`.
pub type WorldJump = (Vector3<f64>, UnitQuaternion<f64>);

/// Whole-run counts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MonoSlamStats {
    pub frames: usize,
    pub measured: usize,
    pub added: usize,
    pub deleted: usize,
    pub converted_to_euclidean: usize,
    /// Matches 1-point RANSAC and the rescue refused.
    pub rejected_matches: usize,
    /// Features deleted as moving: matched but refused by the consensus frame after frame.
    pub features_rejected_as_moving: usize,
    /// Corners not taken as new features because they moved on their own.
    pub corners_rejected_as_moving: usize,
    /// Local maps started, the first included.
    pub local_maps: usize,
    /// Places of earlier local maps recognised by the history memory.
    pub places_recognised: usize,
    /// Places tested and refused (too few of their features agreed).
    pub places_refused: usize,
    /// Features of earlier local maps taken back into the current one.
    pub features_recalled: usize,
}

/// The motion tests need a consensus to test against: at least this many matches that
/// updated the filter, and as many compared with the frame before.
const MIN_CONSENSUS: usize = 8;

/// A match: feature, where it was found.
type Match = (usize, [f64; 2]);

/// The camera method. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct MonoSlam {
    options: MonoSlamOptions,
    /// See [`MonoSlam::check_matches_with`].
    match_check: Option<MatchCheck>,
    filter: MonoEkf,
    tracks: Vec<Track>,
    last_time_s: Option<f64>,
    previous: Option<PreviousFrame>,
    /// The corners found moving in the last frame: where now, where before.
    moving_corners: Vec<([f64; 2], [f64; 2])>,
    frame: usize,
    stats: MonoSlamStats,
    /// The current local map's frame in the world (the first camera's) frame.
    world_from_local: (Vector3<f64>, UnitQuaternion<f64>),
    /// The finished local maps' features.
    history: CameraHistory,
    /// The local map whose place was recognised in the frame under way, and the jump of the
    /// current map's frame in the world ([`FrameReport::world_jump`]).
    place_recognised: Option<(usize, WorldJump)>,
}

impl MonoSlam {
    /// A run with `camera`, starting at the world origin.
    pub fn new(camera: PinholeCamera, options: MonoSlamOptions) -> Self {
        MonoSlam {
            match_check: None,
            filter: MonoEkf::new(camera, options.ekf),
            options,
            tracks: Vec::new(),
            last_time_s: None,
            previous: None,
            moving_corners: Vec::new(),
            frame: 0,
            stats: MonoSlamStats {
                local_maps: 1,
                ..MonoSlamStats::default()
            },
            world_from_local: (Vector3::zeros(), UnitQuaternion::identity()),
            history: CameraHistory::new(&options.history),
            place_recognised: None,
        }
    }

    /// Refuses every match `check` rejects before the filter sees it, as if the feature had
    /// not been found. For measuring what the front end's errors cost: the simulator refuses
    /// matches its rendered truth contradicts (`hil-sim nees --method camera
    /// --truth-gate-px`).
    pub fn check_matches_with(
        &mut self,
        check: impl Fn(usize, &MeasuredFeature) -> bool + Send + Sync + 'static,
    ) {
        self.match_check = Some(MatchCheck(Arc::new(check)));
    }

    /// The filter.
    pub fn filter(&self) -> &MonoEkf {
        &self.filter
    }

    /// Whole-run counts.
    pub fn stats(&self) -> MonoSlamStats {
        self.stats
    }

    /// The map: every feature with a finite depth, of the finished local maps and the
    /// current one, world frame.
    pub fn map_points(&self) -> Vec<Vector3<f64>> {
        let tracked: Vec<usize> = self.tracks.iter().filter_map(|t| t.history).collect();
        let mut points = self.history.points(&tracked);
        points.extend(self.local_points_in_world(0..self.filter.num_features()));
        points
    }

    /// Where each point of [`MonoSlam::map_points`] was first seen: its frame number and
    /// pixel, in the same order.
    pub fn map_sightings(&self) -> Vec<(usize, [f64; 2])> {
        let tracked: Vec<usize> = self.tracks.iter().filter_map(|t| t.history).collect();
        let mut sightings = self.history.sightings(&tracked);
        sightings.extend(
            (0..self.filter.num_features())
                .filter(|&i| self.filter.point_in_world(i).is_some())
                .map(|i| self.tracks[i].appearance.sighting()),
        );
        sightings
    }

    /// The given features of the current local map with a finite depth, world frame.
    fn local_points_in_world(
        &self,
        features: impl Iterator<Item = usize>,
    ) -> impl Iterator<Item = Vector3<f64>> {
        let (origin, rotation) = self.world_from_local;
        features
            .filter_map(|i| self.filter.point_in_world(i))
            .map(move |p| rotation * p + origin)
    }

    /// Starts the run from a known target seen in `first_image` (the first frame, before it is
    /// processed): each corner becomes a point of known position with its patch from that
    /// image, which gives the run a metric scale. See [`super::known_target`].
    ///
    /// # Errors
    /// A corner too near the image's edge for its patch, or on a flat part of the image.
    pub fn add_target(
        &mut self,
        first_image: &GrayImage,
        target: &KnownTarget,
    ) -> Result<(), TargetError> {
        let crop_half = 2 * self.options.patch_half_px + 2;
        let mut seen = Vec::with_capacity(target.corners.len());
        let surface = target.surface_normal();
        for (corner, c) in target.corners.iter().enumerate() {
            let pixel = [c.pixel[0].round() as i64, c.pixel[1].round() as i64];
            let fail = |what| TargetError::Corner {
                corner: corner + 1,
                u_px: c.pixel[0],
                v_px: c.pixel[1],
                what,
            };
            if Patch::from_image(first_image, pixel, self.options.patch_half_px).is_none() {
                return Err(fail("flat or too near the image's edge for a patch"));
            }
            let appearance = Appearance::new(
                self.frame,
                first_image,
                pixel,
                crop_half,
                self.filter.position_m(),
                self.filter.orientation(),
            )
            .ok_or_else(|| fail("too near the image's edge for a patch"))?;
            // The corners are in the first camera's frame, the filter's world frame.
            let appearance = match surface {
                Some(normal) => appearance.with_normal(normal),
                None => appearance,
            };
            seen.push((appearance, Vector3::from(c.position_m)));
        }
        for (appearance, position_m) in seen {
            self.filter
                .add_known_point(position_m, self.options.target_sigma_m);
            self.tracks.push(Track::new(appearance, self.frame));
        }
        Ok(())
    }

    /// The camera's pose in the world frame: position, `world_from_camera`.
    pub fn pose_in_world(&self) -> (Vector3<f64>, UnitQuaternion<f64>) {
        let (origin, rotation) = self.world_from_local;
        (
            rotation * self.filter.position_m() + origin,
            rotation * self.filter.orientation(),
        )
    }

    /// Updates the filter with where the camera was on the ground at `time_s` (at most a
    /// second before the last frame): `point_xz` in the world (first camera's) frame, its
    /// `x` and `z`, with covariance `covariance_xz`; the state is changed only where the
    /// measurement's χ² is at most `max_chi2`. Returns that χ², or `None` when the
    /// measurement could not be made: no frame yet, a time out of reach, or a camera not held
    /// level (its local map's ground is then not the world's).
    pub fn update_ground_position(
        &mut self,
        time_s: f64,
        point_xz: [f64; 2],
        covariance_xz: &nalgebra::Matrix2<f64>,
        max_chi2: f64,
    ) -> Option<f64> {
        let back_s = self.last_time_s? - time_s;
        if self.options.level.is_none() || !(0.0..=1.0).contains(&back_s) {
            return None;
        }
        let (origin, rotation) = self.world_from_local;
        // A level local map is turned from the world only about the vertical (y).
        let local_from_world = rotation.inverse();
        let turned = local_from_world.to_rotation_matrix();
        let m = turned.matrix();
        let in_local =
            local_from_world * Vector3::new(point_xz[0] - origin.x, 0.0, point_xz[1] - origin.z);
        let xz = nalgebra::Matrix2::new(m[(0, 0)], m[(0, 2)], m[(2, 0)], m[(2, 2)]);
        self.filter.update_ground_position(
            [in_local.x, in_local.z],
            &(xz * covariance_xz * xz.transpose()),
            back_s,
            max_chi2,
        )
    }

    /// Finishes the current local map and starts a new one at the camera, with the features
    /// in view carried over: their estimates relative to the camera, with their covariance,
    /// so the new map keeps the old one's scale.
    fn start_local_map(&mut self) {
        let camera = *self.filter.camera();
        let finished: Vec<usize> = (0..self.tracks.len())
            .filter(|&i| {
                !self
                    .filter
                    .pixel(i)
                    .is_some_and(|p| camera.contains(p, 0.0))
            })
            .collect();
        for &index in &finished {
            let (kind, feature, covariance) = self.filter.feature_with_covariance(index);
            let track = &self.tracks[index];
            let id = self.history.store(
                track.history,
                self.world_from_local,
                kind,
                &feature,
                &covariance,
                track.appearance.clone(),
                track.found,
            );
            self.tracks[index].history = Some(id);
        }
        for &index in finished.iter().rev() {
            self.remove(index);
        }
        let (position_variance, angle_variance) = self.filter.pose_variances();
        self.history.start_map(position_variance, angle_variance);
        let (origin, rotation) = self.filter.rebase(self.options.level.is_some());
        let new_from_old = rotation.inverse();
        let new_from_old_origin = -(new_from_old * origin);
        for track in &mut self.tracks {
            track
                .appearance
                .change_frame(new_from_old, new_from_old_origin);
        }
        let (world_origin, world_rotation) = self.world_from_local;
        self.world_from_local = (
            world_rotation * origin + world_origin,
            world_rotation * rotation,
        );
        self.stats.local_maps += 1;
    }

    /// The features' pixels in the last frame and their innovation covariance, for drawing.
    pub fn feature_ellipses(&self) -> Vec<([f64; 2], nalgebra::Matrix2<f64>)> {
        (0..self.filter.num_features())
            .filter_map(|i| {
                let p = self.filter.predict_measurement(i)?;
                self.filter
                    .camera()
                    .contains(p.pixel, 0.0)
                    .then_some((p.pixel, p.innovation_covariance))
            })
            .collect()
    }

    /// The corners found moving in the last frame, each where it is now and where it was in
    /// the frame before.
    pub fn moving_corners(&self) -> &[([f64; 2], [f64; 2])] {
        &self.moving_corners
    }

    /// Processes the frame taken at `time_s`.
    pub fn process(&mut self, time_s: f64, image: &GrayImage) -> FrameReport {
        if let Some(last) = self.last_time_s {
            let dt_s = time_s - last;
            self.filter.predict(dt_s);
            // Gravity in the current local map's frame (the world frame's y is down).
            let down_in_local = self.world_from_local.1.inverse() * Vector3::y();
            self.options
                .hold_to_priors(&mut self.filter, &down_in_local, dt_s);
        }
        self.last_time_s = Some(time_s);
        self.place_recognised = None;
        let (searched, mut found) = self.search(image);
        if let Some(MatchCheck(check)) = &self.match_check {
            found.retain(|((index, pixel), _, _)| {
                let candidate = MeasuredFeature {
                    first_sighting: self.tracks[*index].appearance.sighting(),
                    pixel: *pixel,
                };
                check(self.frame, &candidate)
            });
        }
        let matches: Vec<Match> = found.iter().map(|(m, _, _)| *m).collect();
        let correlations: Vec<f32> = found.iter().map(|(_, _, c)| *c).collect();
        let predictions: Vec<Prediction> = found.into_iter().map(|(_, p, _)| p).collect();
        let measured = self.measure(&matches, &predictions);
        let measurements: Vec<MeasuredFeature> = measured
            .iter()
            .map(|&(index, pixel)| MeasuredFeature {
                first_sighting: self.tracks[index].appearance.sighting(),
                pixel,
            })
            .collect();
        for &(index, _) in &measured {
            self.tracks[index].found += 1;
            self.tracks[index].last_seen_frame = self.frame;
        }
        self.stats.rejected_matches += matches.len() - measured.len();
        self.stats.converted_to_euclidean += self.filter.convert_linear_features();
        let previous = self.previous.take();
        let motion = previous
            .as_ref()
            .map(|p| (self.frame_motion(p, time_s), &p.image));
        let band = motion.as_ref().and_then(|(motion, _)| {
            self.test_feature_motion(&matches, &correlations, &measured, motion)
        });
        for &(index, pixel) in &matches {
            self.tracks[index].last_match = Some((self.frame, pixel));
        }
        let (deleted, deleted_as_moving) = self.delete_poor_features();
        self.moving_corners.clear();
        let wants_features = measured.len() < self.options.target_visible;
        if wants_features
            && self.tracks.len() + self.options.max_new_per_frame > self.options.max_features
        {
            self.start_local_map();
        }
        if wants_features && self.options.history.enabled {
            self.recall(image);
        }
        let added = if wants_features {
            let tested = motion
                .zip(band)
                .map(|((m, previous), band)| (m, previous, band));
            self.add_features(image, tested)
        } else {
            0
        };
        let corners_moving = self.moving_corners.len();
        self.stats.features_rejected_as_moving += deleted_as_moving;
        self.stats.corners_rejected_as_moving += corners_moving;
        self.previous = Some(PreviousFrame {
            image: image.clone(),
            time_s,
            position: self.filter.position_m(),
            orientation: self.filter.orientation(),
        });
        self.stats.frames += 1;
        self.stats.measured += measured.len();
        self.stats.added += added;
        self.stats.deleted += deleted;
        self.frame += 1;
        let (position_m, orientation) = self.pose_in_world();
        self.history
            .note_view(&position_m, &(orientation * Vector3::z()));
        FrameReport {
            time_s,
            position_m,
            orientation,
            searched,
            matched: matches.len(),
            measured: measured.len(),
            added,
            added_pixels: self.tracks[self.tracks.len() - added..]
                .iter()
                .map(|t| t.appearance.sighting().1)
                .collect(),
            deleted,
            deleted_as_moving,
            corners_moving,
            place_recognised: self.place_recognised.map(|(map, _)| map),
            world_jump: self.place_recognised.map(|(_, jump)| jump),
            measurements,
        }
    }

    /// The per-feature test against moving objects: each match is compared with the
    /// feature's match in the frame before, through the camera's motion between them.
    /// Returns the band it used (see [`Self::band_px`]), `None` when it could not test.
    fn test_feature_motion(
        &mut self,
        matches: &[Match],
        correlations: &[f32],
        measured: &[Match],
        motion: &FrameMotion,
    ) -> Option<f64> {
        if measured.len() < MIN_CONSENSUS {
            return None;
        }
        let camera = *self.filter.camera();
        let previous_frame = self.frame.checked_sub(1);
        let distinct = self.options.motion_segmentation.min_correlation;
        let distances: Vec<(usize, f64, bool)> = matches
            .iter()
            .zip(correlations)
            .filter_map(|(&(index, pixel), &correlation)| {
                let (frame, before) = self.tracks[index].last_match?;
                (Some(frame) == previous_frame).then_some(())?;
                Some((
                    index,
                    distance_from_segment(&camera, pixel, before, motion)?,
                    correlation >= distinct,
                ))
            })
            .collect();
        let band = self.band_px(motion, &distances)?;
        for (index, distance, distinct) in distances {
            let track = &mut self.tracks[index];
            // A match the consensus took fits the camera's motion whatever the band says; one
            // that correlates less than distinctly may be a look-alike, not the feature.
            if distance > band && distinct && !measured.iter().any(|m| m.0 == index) {
                track.off_segment_in_a_row += 1;
            } else {
                track.off_segment_in_a_row = 0;
            }
        }
        Some(band)
    }

    /// The band around the epipolar segments where static points lie: the filter's own
    /// (pixel noise and the motion's uncertainty), widened when the frame's matches spread
    /// further, as they do when the frame's motion is estimated worse than the filter believes.
    /// Their spread is taken robustly, from the median distance (of `|N(0, σ)|`, 0.674 σ), so
    /// that the few moving points do not set it. `None` with too few matches to tell a
    /// moving point from a frame whose motion is poorly estimated: nothing is tested then.
    fn band_px(&self, motion: &FrameMotion, distances: &[(usize, f64, bool)]) -> Option<f64> {
        let options = &self.options.motion_segmentation;
        let model = motion_segmentation::band_px(self.filter.camera(), motion, options);
        if distances.len() < MIN_CONSENSUS {
            return None;
        }
        let mut sorted: Vec<f64> = distances.iter().map(|&(_, d, _)| d).collect();
        sorted.sort_by(f64::total_cmp);
        let sigma = sorted[sorted.len() / 2] / 0.674;
        Some(model.max(options.gate_chi2.sqrt() * sigma))
    }

    /// The camera's motion since the previous frame, as estimated now.
    fn frame_motion(&self, previous: &PreviousFrame, time_s: f64) -> FrameMotion {
        let dt_s = time_s - previous.time_s;
        let inverse = previous.orientation.inverse();
        let largest_sigma =
            |c: nalgebra::Matrix3<f64>| c.symmetric_eigenvalues().max().max(0.0).sqrt();
        let angular_sigma = largest_sigma(self.filter.angular_velocity_covariance());
        let linear_sigma = largest_sigma(self.filter.velocity_covariance());
        let ekf = self.filter.options();
        let [rho, sigma_rho] = ekf.initial_inverse_depth;
        FrameMotion {
            rotation: inverse * self.filter.orientation(),
            translation: inverse * (self.filter.position_m() - previous.position),
            rotation_sigma_rad: angular_sigma * dt_s.abs(),
            translation_sigma: linear_sigma * dt_s.abs(),
            pixel_sigma_px: ekf.pixel_sigma_px,
            // The nearest depth a new feature's prior reaches at two standard deviations.
            min_depth: 1.0 / (rho + 2.0 * sigma_rho),
        }
    }

    /// Active search: every feature predicted in view, in its innovation ellipse.
    /// Returns how many features were searched for, and each match with the prediction it
    /// was searched at (the state has not changed since, so RANSAC reuses it).
    fn search(&mut self, image: &GrayImage) -> (usize, Vec<(Match, Prediction, f32)>) {
        let mut searched = 0;
        let mut matches = Vec::new();
        for index in 0..self.filter.num_features() {
            let appearance = &self.tracks[index].appearance;
            match active_search(&self.filter, index, appearance, image, &self.options) {
                Search::NotInView => continue,
                Search::NotFound => {}
                Search::Found(found) => matches.push(found),
            }
            searched += 1;
            self.tracks[index].searched += 1;
        }
        (searched, matches)
    }

    /// 1-point RANSAC over `matches` (each with its `predictions` entry), the supporters'
    /// update and the rescue. Returns the matches that updated the filter.
    fn measure(&mut self, matches: &[Match], predictions: &[Prediction]) -> Vec<Match> {
        one_point_ransac(&mut self.filter, matches, predictions, &self.options, 2)
    }

    /// The history memory's step (see [`super::history_memory`]): the place of an earlier
    /// local map with most features predicted in view is tested, and when enough of them
    /// agree the current local map is moved onto it and they are tracked again. Returns how
    /// many features were taken back.
    fn recall(&mut self, image: &GrayImage) -> usize {
        let options = self.options.history;
        // A place is only worth testing when its supporters would fit in the map.
        let room = self.options.max_features.saturating_sub(self.tracks.len());
        if room < options.min_support {
            return 0;
        }
        let camera = *self.filter.camera();
        let margin = f64::from(self.options.patch_half_px);
        let (origin, rotation) = self.world_from_local;
        let local_from_world = rotation.inverse();
        let to_local = -(local_from_world * origin);
        let tracked: Vec<usize> = self.tracks.iter().filter_map(|t| t.history).collect();
        let tracked_px: Vec<[f64; 2]> = (0..self.filter.num_features())
            .filter_map(|i| self.filter.pixel(i))
            .collect();
        let apart = 2.0 * margin;
        // Candidates in view, by the local map they were last part of, among the maps whose
        // camera was near and looked this way.
        let (position_in_world, orientation_in_world) = self.pose_in_world();
        let near = self.history.maps_near(
            &position_in_world,
            &(orientation_in_world * Vector3::z()),
            options.max_maps_counted,
        );
        let mut best: Option<(usize, Vec<usize>)> = None;
        for (map, ids) in near {
            let in_view: Vec<usize> = ids
                .into_iter()
                .filter(|id| !tracked.contains(id))
                .filter(|&id| {
                    let stored = &self.history.features()[id];
                    let local = moved_feature(
                        stored.kind,
                        &stored.feature_in_world,
                        local_from_world,
                        to_local,
                    );
                    self.filter
                        .pixel_of(stored.kind, &local)
                        .is_some_and(|pixel| {
                            camera.contains(pixel, margin)
                                && tracked_px
                                    .iter()
                                    .all(|t| (t[0] - pixel[0]).hypot(t[1] - pixel[1]) >= apart)
                        })
                })
                .collect();
            if best.as_ref().is_none_or(|(_, b)| in_view.len() > b.len()) {
                best = Some((map, in_view));
            }
        }
        let Some((map, mut candidates)) = best.filter(|(_, c)| c.len() >= options.min_support)
        else {
            return 0;
        };
        let features = self.history.features();
        candidates.sort_by_key(|&id| std::cmp::Reverse(features[id].found));
        candidates.truncate(options.max_candidates);

        // The camera as the old map sees it, and the candidates in the current map's frame.
        // The chain's angle variance is the filter's, which is surer of itself than it is
        // right after a fast turn, so the camera's heading is widened to what the search box
        // reaches at least.
        let (position_variance, chain_angle_variance) = self.history.chain_variances_since(map);
        let searchable_rad = self.options.max_search_half_px
            / (self.options.gate_chi2.sqrt() * camera.fx_px.max(camera.fy_px));
        let heading_variance = (searchable_rad * searchable_rad - chain_angle_variance).max(0.0);
        let mut place =
            self.filter
                .camera_only(position_variance, chain_angle_variance, heading_variance);
        let mut appearances = Vec::with_capacity(candidates.len());
        let mut covariances = Vec::with_capacity(candidates.len());
        for &id in &candidates {
            let stored = &features[id];
            let (local, covariance) = moved_feature_with_covariance(
                stored.kind,
                &stored.feature_in_world,
                &stored.covariance,
                local_from_world,
                to_local,
            );
            place.add_feature_with(
                stored.kind,
                &local,
                &relative_to_the_map(stored.kind, &covariance),
            );
            covariances.push(covariance);
            let mut appearance = stored.appearance.clone();
            appearance.change_frame(local_from_world, to_local);
            appearances.push(appearance);
        }
        let mut matches = Vec::new();
        for (index, appearance) in appearances.iter().enumerate() {
            if let Search::Found((m, _, _)) =
                active_search(&place, index, appearance, image, &self.options)
            {
                matches.push(m);
            }
        }
        if matches.len() < options.min_support {
            self.stats.places_refused += 1;
            return 0;
        }
        let supported = gated_consensus(
            &mut place,
            &matches,
            self.options.gate_chi2,
            options.min_support,
        );
        if supported.len() < options.min_support {
            self.stats.places_refused += 1;
            return 0;
        }

        // The current map's frame moves so that the camera sits where the old map sees it:
        // `old_from_new` takes the corrected frame's coordinates to the current ones.
        let (position_now, orientation_now) = self.filter.pose();
        let (position_seen, orientation_seen) = place.pose();
        let old_from_new_rotation = orientation_seen * orientation_now.inverse();
        let old_from_new_origin = position_seen - old_from_new_rotation * position_now;
        let before = self.world_from_local;
        self.world_from_local = (
            rotation * old_from_new_origin + origin,
            rotation * old_from_new_rotation,
        );
        // after = R' R⁻¹ (before − o) + o' for every point of the current map.
        let jump_rotation = self.world_from_local.1 * before.1.inverse();
        let jump = (
            self.world_from_local.0 - jump_rotation * before.0,
            jump_rotation,
        );
        let new_from_old = old_from_new_rotation.inverse();
        let new_from_old_origin = -(new_from_old * old_from_new_origin);
        let mut recalled = 0;
        for &(index, _) in supported.iter().take(room) {
            let (kind, feature, _) = place.feature_with_covariance(index);
            let (feature, covariance) = moved_feature_with_covariance(
                kind,
                &feature,
                &covariances[index],
                new_from_old,
                new_from_old_origin,
            );
            self.filter.add_feature_with(kind, &feature, &covariance);
            let mut appearance = appearances[index].clone();
            appearance.change_frame(new_from_old, new_from_old_origin);
            let mut track = Track::new(appearance, self.frame);
            track.history = Some(candidates[index]);
            self.tracks.push(track);
            recalled += 1;
        }
        self.stats.places_recognised += 1;
        self.stats.features_recalled += recalled;
        self.place_recognised = Some((map, jump));
        recalled
    }

    /// Deletes features refused as moving, those found in fewer than half of their searches,
    /// and the longest unseen beyond [`MonoSlamOptions::max_features`]. Returns how many
    /// went, and how many of them as moving.
    fn delete_poor_features(&mut self) -> (usize, usize) {
        let mut deleted = 0;
        let mut moving = 0;
        let mut index = 0;
        while index < self.tracks.len() {
            let t = &self.tracks[index];
            if t.off_segment_in_a_row >= self.options.max_off_segment_in_a_row {
                self.remove(index);
                deleted += 1;
                moving += 1;
            } else if t.searched >= self.options.min_attempts_to_delete && 2 * t.found < t.searched
            {
                self.remove(index);
                deleted += 1;
            } else {
                index += 1;
            }
        }
        while self.tracks.len() > self.options.max_features {
            let oldest = (0..self.tracks.len())
                .min_by_key(|&i| self.tracks[i].last_seen_frame)
                .unwrap_or(0);
            self.remove(oldest);
            deleted += 1;
        }
        (deleted, moving)
    }

    fn remove(&mut self, index: usize) {
        self.filter.remove_feature(index);
        self.tracks.remove(index);
    }

    /// New features at FAST corners in the grid cells that hold none, unless they move on
    /// their own since the previous frame (`motion`). Returns how many.
    fn add_features(
        &mut self,
        image: &GrayImage,
        motion: Option<(FrameMotion, &GrayImage, f64)>,
    ) -> usize {
        let camera = *self.filter.camera();
        let [columns, rows] = self.options.grid_cells;
        let cell_of = |p: [f64; 2]| -> Option<usize> {
            if !camera.contains(p, 0.0) {
                return None;
            }
            let c = (p[0] / f64::from(camera.width_px) * f64::from(columns)) as usize;
            let r = (p[1] / f64::from(camera.height_px) * f64::from(rows)) as usize;
            Some(r.min(rows as usize - 1) * columns as usize + c.min(columns as usize - 1))
        };
        let mut occupied = vec![false; (columns * rows) as usize];
        for index in 0..self.filter.num_features() {
            if let Some(cell) = self.filter.pixel(index).and_then(cell_of) {
                occupied[cell] = true;
            }
        }
        let margin = i64::from(2 * self.options.patch_half_px + 2) + 1;
        let mut best: Vec<Option<imageproc::corners::Corner>> = vec![None; occupied.len()];
        let found = empty_cells_corners(
            image,
            &occupied,
            columns as usize,
            cell_of,
            self.options.fast_threshold,
        );
        for corner in found {
            let (x, y) = (i64::from(corner.x), i64::from(corner.y));
            if x < margin
                || y < margin
                || x >= i64::from(image.width()) - margin
                || y >= i64::from(image.height()) - margin
            {
                continue;
            }
            let Some(cell) = cell_of([x as f64, y as f64]) else {
                continue;
            };
            if !occupied[cell] && best[cell].is_none_or(|b| corner.score > b.score) {
                best[cell] = Some(corner);
            }
        }
        let mut corners: Vec<_> = best.into_iter().flatten().collect();
        corners.sort_by(|a, b| b.score.total_cmp(&a.score));
        let mut added = 0;
        for corner in corners {
            if added >= self.options.max_new_per_frame {
                break;
            }
            let centre = [i64::from(corner.x), i64::from(corner.y)];
            if let Some((motion, previous, band)) = motion
                && let PointMotion::Moving { previous_px } = classify(
                    &camera,
                    [previous, image],
                    centre,
                    &motion,
                    band,
                    self.options.patch_half_px,
                    &self.options.motion_segmentation,
                )
            {
                self.moving_corners
                    .push(([corner.x as f64, corner.y as f64], previous_px));
                continue;
            }
            // The crop reaches beyond the patch so that a warp turned by up to 45° or
            // scaled by up to half stays inside it.
            let crop_half = 2 * self.options.patch_half_px + 2;
            let Some(appearance) = Appearance::new(
                self.frame,
                image,
                centre,
                crop_half,
                self.filter.position_m(),
                self.filter.orientation(),
            ) else {
                continue;
            };
            if self
                .filter
                .add_feature([corner.x as f64, corner.y as f64])
                .is_some()
            {
                self.tracks.push(Track::new(appearance, self.frame));
                added += 1;
            }
        }
        added
    }
}

/// The FAST-9 corners of `image` at `threshold` in the grid cells that `occupied` does not
/// mark (`cell_of` gives a pixel's cell, row-major over `columns` a row), in image
/// coordinates: what detecting over the whole image and keeping those cells finds, found on
/// the empty cells alone, each cell's corners in row-major order. A corner's test reads the
/// circle of radius 3 around it, so each cell is cut out with 3 pixels more on every side
/// (the image's own border of 3 stays out, as it does over the whole image).
fn empty_cells_corners(
    image: &GrayImage,
    occupied: &[bool],
    columns: usize,
    cell_of: impl Fn([f64; 2]) -> Option<usize>,
    threshold: u8,
) -> Vec<imageproc::corners::Corner> {
    const RADIUS: u32 = 3;
    let (width, height) = image.dimensions();
    // Each column's and each row's pixels, by the cell `cell_of` puts them in (the cell of
    // a pixel is its column's and its row's).
    let spans = |length: u32, cell_along: &dyn Fn(u32) -> Option<usize>| {
        let mut spans: Vec<(usize, u32, u32)> = Vec::new();
        for at in 0..length {
            let Some(index) = cell_along(at) else {
                continue;
            };
            match spans.last_mut() {
                Some((last, _, end)) if *last == index && *end == at => *end = at + 1,
                _ => spans.push((index, at, at + 1)),
            }
        }
        spans
    };
    let column_spans = spans(width, &|x| {
        cell_of([f64::from(x), 0.0]).map(|c| c % columns)
    });
    let row_spans = spans(height, &|y| {
        cell_of([0.0, f64::from(y)]).map(|c| c / columns)
    });
    let mut found = Vec::new();
    for &(row, y0, y1) in &row_spans {
        for &(column, x0, x1) in &column_spans {
            if occupied
                .get(row * columns + column)
                .is_none_or(|&taken| taken)
            {
                continue;
            }
            let (left, top) = (x0.saturating_sub(RADIUS), y0.saturating_sub(RADIUS));
            let (right, bottom) = ((x1 + RADIUS).min(width), (y1 + RADIUS).min(height));
            let crop =
                image::imageops::crop_imm(image, left, top, right - left, bottom - top).to_image();
            for mut corner in imageproc::corners::corners_fast9(&crop, threshold) {
                corner.x += left;
                corner.y += top;
                if (x0..x1).contains(&corner.x) && (y0..y1).contains(&corner.y) {
                    found.push(corner);
                }
            }
        }
    }
    found
}

/// The place test's consensus: each match in turn updates a copy of `filter` alone, and
/// the matches then within `gate_chi2` of their prediction (by their innovation covariance
/// after that update, so a feature whose depth the map never fixed keeps its long gate along
/// its epipolar line) support it. With at least `min_support` supporters, the best
/// hypothesis's update `filter` together. Returns them (none when the support fell short).
fn gated_consensus(
    filter: &mut MonoEkf,
    matches: &[Match],
    gate_chi2: f64,
    min_support: usize,
) -> Vec<Match> {
    let mut best: Vec<Match> = Vec::new();
    for &one in matches {
        let mut hypothesis = filter.clone();
        if !hypothesis.update(&[one]) {
            continue;
        }
        let support: Vec<Match> = matches
            .iter()
            .filter(|&&(index, seen)| {
                hypothesis.predict_measurement(index).is_some_and(|p| {
                    let nu = Vector2::new(seen[0] - p.pixel[0], seen[1] - p.pixel[1]);
                    p.innovation_covariance
                        .try_inverse()
                        .is_some_and(|s_inv| (nu.transpose() * s_inv * nu)[(0, 0)] <= gate_chi2)
                })
            })
            .copied()
            .collect();
        if support.len() > best.len() {
            best = support;
        }
    }
    if best.len() >= min_support.max(2) && filter.update(&best) {
        best
    } else {
        Vec::new()
    }
}

/// A stored feature's covariance as the place test uses it: the map's geometry is the
/// reference the camera is placed against (its uncertainty is mostly its frame's, shared by
/// every feature of the map and carried by the camera's widened pose), so only what the map
/// never measured stays uncertain: an inverse-depth feature's depth.
fn relative_to_the_map(kind: FeatureKind, covariance: &DMatrix<f64>) -> DMatrix<f64> {
    let size = kind.size();
    let mut relative = DMatrix::identity(size, size) * 1e-10;
    if kind == FeatureKind::InverseDepth {
        relative[(5, 5)] = covariance[(5, 5)];
    }
    relative
}

/// What an active search gave.
enum Search {
    /// The feature is not predicted in view (or has no template there).
    NotInView,
    NotFound,
    Found((Match, Prediction, f32)),
}

/// Searches for feature `index` of `filter`, whose first sighting is `appearance`, in its
/// innovation ellipse at [`MonoSlamOptions::gate_chi2`] cut to
/// [`MonoSlamOptions::max_search_half_px`], with its patch warped to the camera's view.
fn active_search(
    filter: &MonoEkf,
    index: usize,
    appearance: &Appearance,
    image: &GrayImage,
    options: &MonoSlamOptions,
) -> Search {
    let margin = f64::from(options.patch_half_px);
    let Some(prediction) = filter.predict_measurement(index) else {
        return Search::NotInView;
    };
    if !filter.camera().contains(prediction.pixel, margin) {
        return Search::NotInView;
    }
    let s = prediction.innovation_covariance;
    let Some(s_inv) = s.try_inverse() else {
        return Search::NotInView;
    };
    // The ellipse's bounding box, cut to the nearest part of a wide one.
    let reach = options.gate_chi2.sqrt();
    let cap = options.max_search_half_px;
    let half = [
        (reach * s[(0, 0)].sqrt()).min(cap),
        (reach * s[(1, 1)].sqrt()).min(cap),
    ];
    let centre = prediction.pixel;
    // The planar warp leaves the crop when the camera came much closer than at the first
    // sighting or the plane is seen edge-on; the rotation's warp alone is tried then. A
    // feature whose template cannot be made at all counts as searched and not found, so
    // that it is deleted in time.
    let warped = |point: Option<&Vector3<f64>>| {
        appearance.template(
            filter.camera(),
            &filter.position_m(),
            filter.orientation(),
            point,
            centre,
            options.patch_half_px,
        )
    };
    let Some(template) = warped(filter.point_in_world(index).as_ref()).or_else(|| warped(None))
    else {
        return Search::NotFound;
    };
    let box_px = [
        [
            (centre[0] - half[0]).floor() as i64,
            (centre[1] - half[1]).floor() as i64,
        ],
        [
            (centre[0] + half[0]).ceil() as i64,
            (centre[1] + half[1]).ceil() as i64,
        ],
    ];
    let gate = options.gate_chi2;
    let inside = |p: [i64; 2]| {
        let d = Vector2::new(p[0] as f64 - centre[0], p[1] as f64 - centre[1]);
        (d.transpose() * s_inv * d)[(0, 0)] <= gate
    };
    match search(&template, image, box_px, inside) {
        Some((pixel, score)) if score >= options.min_correlation => {
            Search::Found(((index, pixel), prediction, score))
        }
        _ => Search::NotFound,
    }
}

/// 1-point RANSAC over `matches` (each with its `predictions` entry): each match in turn
/// updates the state alone, and the one that brings most matches within
/// [`MonoSlamOptions::ransac_inlier_px`] of their predictions wins. With at least
/// `min_support` supporters (and never fewer than two) they update `filter` together, and the
/// other matches that then fit within [`MonoSlamOptions::rescue_chi2`] are rescued in a second
/// update. Returns the matches that updated the filter (none when the support fell short).
fn one_point_ransac(
    filter: &mut MonoEkf,
    matches: &[Match],
    predictions: &[Prediction],
    options: &MonoSlamOptions,
    min_support: usize,
) -> Vec<Match> {
    let support_of = |x: &nalgebra::DVector<f64>| -> Vec<Match> {
        matches
            .iter()
            .filter(|&&(other, seen)| {
                filter.pixel_in(x, other).is_some_and(|p| {
                    (p[0] - seen[0]).hypot(p[1] - seen[1]) <= options.ransac_inlier_px
                })
            })
            .copied()
            .collect()
    };
    let mut best_support: Vec<Match> = Vec::new();
    for (&(index, pixel), prediction) in matches.iter().zip(predictions) {
        let Some(x) = filter.hypothesis(index, prediction, pixel) else {
            continue;
        };
        let support = support_of(&x);
        if support.len() > best_support.len() {
            best_support = support;
        }
    }
    if best_support.len() < min_support.max(2) || !filter.update(&best_support) {
        return Vec::new();
    }
    let rescued: Vec<Match> = matches
        .iter()
        .filter(|m| !best_support.iter().any(|s| s.0 == m.0))
        .filter(|&&(index, pixel)| {
            filter.predict_measurement(index).is_some_and(|p| {
                let nu = Vector2::new(pixel[0] - p.pixel[0], pixel[1] - p.pixel[1]);
                p.innovation_covariance.try_inverse().is_some_and(|s_inv| {
                    (nu.transpose() * s_inv * nu)[(0, 0)] < options.rescue_chi2
                })
            })
        })
        .copied()
        .collect();
    let mut measured = best_support;
    if !rescued.is_empty() && filter.update(&rescued) {
        measured.extend(rescued);
    }
    measured
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::known_target::TargetCorner;

    #[test]
    fn a_ground_position_in_the_world_frame_is_measured_in_the_local_maps() {
        let camera = PinholeCamera::ideal(500.0, 500.0, 320.0, 240.0, [640, 480]);
        let options = MonoSlamOptions {
            level: Some(LevelPrior::default()),
            ..MonoSlamOptions::default()
        };
        let mut slam = MonoSlam::new(camera, options);
        slam.last_time_s = Some(10.0);
        // The local map starts 3 m right and 4 m ahead of the first camera, turned 90° about
        // the vertical (y, down): its z axis is the world's x.
        let turn = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
        slam.world_from_local = (Vector3::new(3.0, 0.0, 4.0), turn);
        slam.filter = slam.filter.camera_only(100.0, 0.0, 0.0);
        // A fix at the last frame's time of the world's (5, 4) is 2 m along the map's z.
        let exact = nalgebra::Matrix2::identity() * 1e-8;
        let chi2 = slam.update_ground_position(10.0, [5.0, 4.0], &exact, f64::INFINITY);
        assert!(chi2.is_some());
        let position = slam.filter.position_m();
        assert!(
            (position.x).abs() < 1e-3 && (position.z - 2.0).abs() < 1e-3,
            "{position:?}"
        );
        let (in_world, _) = slam.pose_in_world();
        assert!((in_world.x - 5.0).abs() < 1e-3 && (in_world.z - 4.0).abs() < 1e-3);
        // A fix from before the last second, or from the future, is not measured.
        assert!(
            slam.update_ground_position(8.5, [5.0, 4.0], &exact, f64::INFINITY)
                .is_none()
        );
        assert!(
            slam.update_ground_position(10.5, [5.0, 4.0], &exact, f64::INFINITY)
                .is_none()
        );
        // Nor is one where the camera is not held level.
        let mut free = MonoSlam::new(camera, MonoSlamOptions::default());
        free.last_time_s = Some(10.0);
        assert!(
            free.update_ground_position(10.0, [5.0, 4.0], &exact, f64::INFINITY)
                .is_none()
        );
    }

    #[test]
    fn corners_of_the_empty_cells_are_those_of_the_whole_image_there() {
        // Blocks of pseudo-random grey, so that FAST finds corners everywhere, on an image
        // whose size the grid does not divide.
        let (width, height) = (203u32, 151u32);
        let mut state = 12_345u32;
        let block: Vec<u8> = (0..(width / 3 + 1) * (height / 3 + 1))
            .map(|_| {
                state = state.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                (state >> 24) as u8
            })
            .collect();
        let image = GrayImage::from_fn(width, height, |x, y| {
            image::Luma([block[((y / 3) * (width / 3 + 1) + x / 3) as usize]])
        });
        let [columns, rows] = [8usize, 6usize];
        let cell_of = |p: [f64; 2]| -> Option<usize> {
            let c = (p[0] / f64::from(width) * columns as f64) as usize;
            let r = (p[1] / f64::from(height) * rows as f64) as usize;
            Some(r.min(rows - 1) * columns + c.min(columns - 1))
        };
        let occupied: Vec<bool> = (0..columns * rows).map(|cell| cell % 3 == 1).collect();
        let key = |c: &imageproc::corners::Corner| (c.x, c.y, c.score.to_bits());
        let mut expected: Vec<_> = imageproc::corners::corners_fast9(&image, 20)
            .iter()
            .filter(|c| {
                cell_of([f64::from(c.x), f64::from(c.y)]).is_some_and(|cell| !occupied[cell])
            })
            .map(key)
            .collect();
        let mut found: Vec<_> = empty_cells_corners(&image, &occupied, columns, cell_of, 20)
            .iter()
            .map(key)
            .collect();
        assert!(expected.len() > 100, "{}", expected.len());
        expected.sort_unstable();
        found.sort_unstable();
        assert_eq!(found, expected);
    }

    /// Random grey blocks of 6 cm, blended at their edges: a textured wall.
    fn wall(x_m: f64, y_m: f64) -> f64 {
        let block = |bx: i64, by: i64| -> f64 {
            let mut h = (bx as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
                ^ (by as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f);
            h ^= h >> 29;
            h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
            h ^= h >> 32;
            (h % 200) as f64 + 28.0
        };
        let (u, v) = (x_m / 0.06, y_m / 0.06);
        let (bx, by) = (u.floor() as i64, v.floor() as i64);
        let (fx, fy) = (u - u.floor(), v - v.floor());
        let top = block(bx, by) * (1.0 - fx) + block(bx + 1, by) * fx;
        let bottom = block(bx, by + 1) * (1.0 - fx) + block(bx + 1, by + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    const WALL_DEPTH_M: f64 = 3.0;

    fn camera() -> PinholeCamera {
        PinholeCamera::ideal(300.0, 300.0, 160.0, 120.0, [320, 240])
    }

    /// The wall `WALL_DEPTH_M` ahead, seen by [`camera`] moved `x_m` to the right.
    fn view(x_m: f64) -> GrayImage {
        let c = camera();
        GrayImage::from_fn(c.width_px, c.height_px, |u, v| {
            let x = x_m + WALL_DEPTH_M * (f64::from(u) - c.cx_px) / c.fx_px;
            let y = WALL_DEPTH_M * (f64::from(v) - c.cy_px) / c.fy_px;
            image::Luma([wall(x, y).clamp(0.0, 255.0) as u8])
        })
    }

    #[test]
    fn each_measurement_names_its_feature_and_a_refused_match_never_reaches_the_filter() {
        let mut free = MonoSlam::new(camera(), MonoSlamOptions::default());
        let mut refused = MonoSlam::new(camera(), MonoSlamOptions::default());
        refused.check_matches_with(|_, _| false);
        let mut first_sightings = std::collections::HashSet::new();
        for frame in 0..10 {
            let time_s = f64::from(frame) / 30.0;
            let image = view(0.5 * time_s);
            let report = free.process(time_s, &image);
            assert_eq!(report.measurements.len(), report.measured);
            for found in &report.measurements {
                // Named by a sighting from an earlier frame, where it was added.
                let key = (
                    found.first_sighting.0,
                    found.first_sighting.1.map(f64::to_bits),
                );
                assert!(first_sightings.contains(&key), "{found:?} in frame {frame}");
            }
            for pixel in &report.added_pixels {
                first_sightings.insert((frame as usize, pixel.map(f64::to_bits)));
            }
            let report = refused.process(time_s, &image);
            assert_eq!((report.measured, report.matched), (0, 0));
            assert!(report.measurements.is_empty());
        }
        assert!(free.stats().measured > 100, "{:?}", free.stats());
    }

    #[test]
    fn a_known_target_gives_the_run_its_scale() {
        let c = camera();
        let target = KnownTarget {
            corners: [[70.0, 50.0], [250.0, 50.0], [70.0, 190.0], [250.0, 190.0]]
                .iter()
                .map(|&[u, v]| TargetCorner {
                    pixel: [u, v],
                    position_m: [
                        WALL_DEPTH_M * (u - c.cx_px) / c.fx_px,
                        WALL_DEPTH_M * (v - c.cy_px) / c.fy_px,
                        WALL_DEPTH_M,
                    ],
                })
                .collect(),
        };
        let speed_m_s = 0.5;
        let frames = 45;
        let mut slam = MonoSlam::new(c, MonoSlamOptions::default());
        slam.add_target(&view(0.0), &target)
            .expect("textured corners");
        let mut last = None;
        for frame in 0..frames {
            let time_s = f64::from(frame) / 30.0;
            last = Some(slam.process(time_s, &view(speed_m_s * time_s)));
        }
        let travelled_m = speed_m_s * f64::from(frames - 1) / 30.0;
        let position = last.expect("frames").position_m;
        assert!(
            (position.x - travelled_m).abs() < 0.1 * travelled_m,
            "{position} against {travelled_m} m"
        );
        assert!(position.yz().norm() < 0.1 * travelled_m, "{position}");
    }

    #[test]
    fn a_target_corner_on_a_flat_image_is_refused_by_number() {
        let target = KnownTarget {
            corners: vec![
                TargetCorner {
                    pixel: [100.0, 100.0],
                    position_m: [0.0, 0.0, 1.0],
                },
                TargetCorner {
                    pixel: [318.0, 100.0],
                    position_m: [0.5, 0.0, 1.0],
                },
            ],
        };
        let mut slam = MonoSlam::new(camera(), MonoSlamOptions::default());
        let error = slam.add_target(&view(0.0), &target).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("corner 2 at pixel (318, 100)"),
            "{error}"
        );
        assert_eq!(slam.filter().num_features(), 0, "nothing added on an error");
    }
}
