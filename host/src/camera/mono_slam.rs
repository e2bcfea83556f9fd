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

use image::GrayImage;
use nalgebra::{UnitQuaternion, Vector2, Vector3};

use super::appearance::Appearance;
use super::mono_ekf::{MonoEkf, MonoEkfOptions, Prediction};
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
    /// At most this many features in the state; the longest unseen go first.
    pub max_features: usize,
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
}

/// What one frame did.
#[derive(Clone, Copy, Debug, PartialEq)]
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
    pub deleted: usize,
}

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
}

/// A match: feature, where it was found.
type Match = (usize, [f64; 2]);

/// The camera method. See the [module documentation](self).
#[derive(Clone, Debug)]
pub struct MonoSlam {
    options: MonoSlamOptions,
    filter: MonoEkf,
    tracks: Vec<Track>,
    last_time_s: Option<f64>,
    frame: usize,
    stats: MonoSlamStats,
}

impl MonoSlam {
    /// A run with `camera`, starting at the world origin.
    pub fn new(camera: PinholeCamera, options: MonoSlamOptions) -> Self {
        MonoSlam {
            filter: MonoEkf::new(camera, options.ekf),
            options,
            tracks: Vec::new(),
            last_time_s: None,
            frame: 0,
            stats: MonoSlamStats::default(),
        }
    }

    /// The filter.
    pub fn filter(&self) -> &MonoEkf {
        &self.filter
    }

    /// Whole-run counts.
    pub fn stats(&self) -> MonoSlamStats {
        self.stats
    }

    /// The map: every feature with a finite depth, world frame.
    pub fn map_points(&self) -> Vec<Vector3<f64>> {
        (0..self.filter.num_features())
            .filter_map(|i| self.filter.point_in_world(i))
            .collect()
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

    /// Processes the frame taken at `time_s`.
    pub fn process(&mut self, time_s: f64, image: &GrayImage) -> FrameReport {
        if let Some(last) = self.last_time_s {
            self.filter.predict(time_s - last);
        }
        self.last_time_s = Some(time_s);
        let (searched, found) = self.search(image);
        let matches: Vec<Match> = found.iter().map(|(m, _)| *m).collect();
        let predictions: Vec<Prediction> = found.into_iter().map(|(_, p)| p).collect();
        let measured = self.measure(&matches, &predictions);
        for &(index, _) in &measured {
            self.tracks[index].found += 1;
            self.tracks[index].last_seen_frame = self.frame;
        }
        self.stats.rejected_matches += matches.len() - measured.len();
        self.stats.converted_to_euclidean += self.filter.convert_linear_features();
        let deleted = self.delete_poor_features();
        let added = if measured.len() < self.options.target_visible {
            self.add_features(image)
        } else {
            0
        };
        self.stats.frames += 1;
        self.stats.measured += measured.len();
        self.stats.added += added;
        self.stats.deleted += deleted;
        self.frame += 1;
        FrameReport {
            time_s,
            position_m: self.filter.position_m(),
            orientation: self.filter.orientation(),
            searched,
            matched: matches.len(),
            measured: measured.len(),
            added,
            deleted,
        }
    }

    /// Active search: every feature predicted in view, in its innovation ellipse.
    /// Returns how many features were searched for, and each match with the prediction it
    /// was searched at (the state has not changed since, so RANSAC reuses it).
    fn search(&mut self, image: &GrayImage) -> (usize, Vec<(Match, Prediction)>) {
        let margin = f64::from(self.options.patch_half_px);
        let mut searched = 0;
        let mut matches = Vec::new();
        for index in 0..self.filter.num_features() {
            let Some(prediction) = self.filter.predict_measurement(index) else {
                continue;
            };
            if !self.filter.camera().contains(prediction.pixel, margin) {
                continue;
            }
            let s = prediction.innovation_covariance;
            let Some(s_inv) = s.try_inverse() else {
                continue;
            };
            // The ellipse's bounding box, cut to the nearest part of a wide one.
            let reach = self.options.gate_chi2.sqrt();
            let cap = self.options.max_search_half_px;
            let half = [
                (reach * s[(0, 0)].sqrt()).min(cap),
                (reach * s[(1, 1)].sqrt()).min(cap),
            ];
            let centre = prediction.pixel;
            let Some(template) = self.tracks[index].appearance.template(
                self.filter.camera(),
                self.filter.orientation(),
                centre,
                self.options.patch_half_px,
            ) else {
                continue;
            };
            searched += 1;
            self.tracks[index].searched += 1;
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
            let gate = self.options.gate_chi2;
            let inside = |p: [i64; 2]| {
                let d = Vector2::new(p[0] as f64 - centre[0], p[1] as f64 - centre[1]);
                (d.transpose() * s_inv * d)[(0, 0)] <= gate
            };
            if let Some((pixel, score)) = search(&template, image, box_px, inside)
                && score >= self.options.min_correlation
            {
                matches.push(((index, pixel), prediction));
            }
        }
        (searched, matches)
    }

    /// 1-point RANSAC over `matches` (each with its `predictions` entry), the supporters'
    /// update and the rescue. Returns the matches that updated the filter.
    fn measure(&mut self, matches: &[Match], predictions: &[Prediction]) -> Vec<Match> {
        let mut best_support: Vec<Match> = Vec::new();
        for (&(index, pixel), prediction) in matches.iter().zip(predictions) {
            let Some(x) = self.filter.hypothesis(index, prediction, pixel) else {
                continue;
            };
            let support: Vec<Match> = matches
                .iter()
                .filter(|&&(other, seen)| {
                    self.filter.pixel_in(&x, other).is_some_and(|p| {
                        (p[0] - seen[0]).hypot(p[1] - seen[1]) <= self.options.ransac_inlier_px
                    })
                })
                .copied()
                .collect();
            if support.len() > best_support.len() {
                best_support = support;
            }
        }
        if best_support.is_empty() || !self.filter.update(&best_support) {
            return Vec::new();
        }
        let rescued: Vec<Match> = matches
            .iter()
            .filter(|m| !best_support.iter().any(|s| s.0 == m.0))
            .filter(|&&(index, pixel)| {
                self.filter.predict_measurement(index).is_some_and(|p| {
                    let nu = Vector2::new(pixel[0] - p.pixel[0], pixel[1] - p.pixel[1]);
                    p.innovation_covariance.try_inverse().is_some_and(|s_inv| {
                        (nu.transpose() * s_inv * nu)[(0, 0)] < self.options.rescue_chi2
                    })
                })
            })
            .copied()
            .collect();
        let mut measured = best_support;
        if !rescued.is_empty() && self.filter.update(&rescued) {
            measured.extend(rescued);
        }
        measured
    }

    /// Deletes features found in fewer than half of their searches, and the longest unseen
    /// beyond [`MonoSlamOptions::max_features`]. Returns how many went.
    fn delete_poor_features(&mut self) -> usize {
        let mut deleted = 0;
        let mut index = 0;
        while index < self.tracks.len() {
            let t = &self.tracks[index];
            if t.searched >= self.options.min_attempts_to_delete && 2 * t.found < t.searched {
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
        deleted
    }

    fn remove(&mut self, index: usize) {
        self.filter.remove_feature(index);
        self.tracks.remove(index);
    }

    /// New features at FAST corners in the grid cells that hold none. Returns how many.
    fn add_features(&mut self, image: &GrayImage) -> usize {
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
        for corner in imageproc::corners::corners_fast9(image, self.options.fast_threshold) {
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
            // The crop reaches beyond the patch so that a warp turned by up to 45° or
            // scaled by up to half stays inside it.
            let crop_half = 2 * self.options.patch_half_px + 2;
            let orientation = self.filter.orientation();
            let Some(appearance) = Appearance::new(image, centre, crop_half, orientation) else {
                continue;
            };
            if self
                .filter
                .add_feature([corner.x as f64, corner.y as f64])
                .is_some()
            {
                self.tracks.push(Track {
                    appearance,
                    searched: 0,
                    found: 0,
                    last_seen_frame: self.frame,
                });
                added += 1;
            }
        }
        added
    }
}
