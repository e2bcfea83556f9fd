//! The global map and map joining (Tardós et al. 2002): finished local maps are transformed
//! into the global frame and joined, with the covariance propagated through the linearised
//! join, and landmarks seen in both are fused by an exact equality constraint.
//!
//! The global state is `[robot pose (3), landmarks...]` where the robot pose is the base frame
//! of the local map being built. Joining local map `L` (robot `r`, landmarks `l_i` in its
//! base frame `B`) gives `[B ⊕ r, global landmarks, B ⊕ l_i]`, with
//! `P⁺ = J_G P_G J_Gᵀ + J_L P_L J_Lᵀ` (the two maps are independent). Its landmarks are then
//! paired with the global ones by the individual gate and JCBB on `l_new − l_old`, each pair
//! is imposed as the measurement `l_new − l_old = 0` and the duplicate is removed. Only the
//! pairing update touches the whole covariance (O(N² p) for `p` pairs). The joined state is
//! read in place while pairing ([`JoinedState`]) and the duplicates are never formed, so the
//! covariance grows only by the landmarks that stay.
//!
//! A local map that measured its base in the map frame (GPS) carries its own estimate `b_L`
//! of the base, started from the global one and independent of the rest given the base.
//! Joining it first moves the global map onto that estimate: the base's marginal becomes
//! `b_L`'s and every global entry moves by its regression on the base
//! ([`EkfState`]'s `set_pose_marginal`); the local map's entries are then composed with `b_L`,
//! their covariance with the global map passing through the base:
//! `Cov(new, global) = J P_{L,b} P_{b_L}⁻¹ Cov(b, global)`.

use nalgebra::{DMatrix, DVector, Matrix2, Matrix3};

use super::covariance_store::CovarianceStore;
use super::ekf_state::{EkfError, EkfState};
use super::frames::{compose_pose, transform_point};
use super::jcbb::{
    CovarianceEntries, JacobianBlock, PairingCandidate, chi_square_quantile, cross_covariance, jcbb,
};
use super::joined_state::{CrossCovariance, JoinedState};
use super::landmark_info::LandmarkInfo;
use super::local_map::LocalMap;
use super::options::AssociationOptions;
use super::packed_covariance::PackedCovariance;
use crate::geometry::Pose2;

/// Noise of the equality constraint between two records of one landmark, metres (tiny: it
/// only keeps the innovation covariance invertible).
const FUSION_SIGMA_M: f64 = 1e-3;

/// Confidence of the test that a recognised place agrees with the map's covariance.
const PLACE_CONFIDENCE: f64 = 0.999;

/// Standard deviations of their distance by which two records' trunks must overlap for the
/// records to be taken as one trunk ([`GlobalMap::join`]).
const OVERLAP_SIGMAS: f64 = 3.0;

/// Confidence of the test that two records of one trunk estimate the same point, so that
/// they are fused rather than the weaker one dropped.
const SAME_POINT_CONFIDENCE: f64 = 0.999;

/// What one join did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct JoinReport {
    /// Landmarks of the local map fused with global ones.
    pub fused: usize,
    /// Landmarks of the local map added as new global landmarks (some may then be merged
    /// into an older record of their trunk, and count in `merged_records` too).
    pub added: usize,
    /// Fused landmarks first mapped at least two local maps earlier: the robot is back in a
    /// place it left before (a loop closed), not just overlapping the previous local map.
    pub revisited: usize,
    /// A place the history memory recognised was turned down: the map found it implausible
    /// and too few trees backed it ([`GlobalMap::join`]).
    pub place_rejected: bool,
    /// Records found to be of one trunk with another record and merged into it
    /// ([`GlobalMap::join`]).
    pub merged_records: usize,
}

/// The joined map. See the [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct GlobalMap {
    /// The map's state; its covariance, the method's largest structure, as one triangle.
    state: EkfState<PackedCovariance>,
    info: Vec<LandmarkInfo>,
    /// The local map (index into `bases_in_map`) each landmark was first mapped in.
    origin_map: Vec<usize>,
    bases_in_map: Vec<Pose2>,
    /// A number for each landmark that stays with it while others are fused away, in state
    /// order. Numbers are handed out in join order and fusions only remove entries, so they
    /// ascend.
    ids: Vec<usize>,
    /// The number the next joined landmark gets.
    next_id: usize,
    /// For each landmark of the last joined local map, in its order, the number of the
    /// landmark it stands as: its own, or the one it was fused into or dropped for since.
    /// Only the last join is kept, so the bookkeeping does not grow with the run.
    last_joined_ids: Vec<usize>,
    /// The numbers that stopped standing when the last join fused records of one trunk, each
    /// with the number it was fused into (`(from, to)`); only the last join's are kept.
    last_merged_ids: Vec<(usize, usize)>,
}

impl GlobalMap {
    /// An empty map whose first local map starts at `pose_in_map` with covariance
    /// `pose_covariance`.
    pub fn new(pose_in_map: Pose2, pose_covariance: Matrix3<f64>) -> GlobalMap {
        GlobalMap {
            state: EkfState::with_covariance_store(
                DVector::from_row_slice(&[pose_in_map.x_m, pose_in_map.y_m, pose_in_map.theta_rad]),
                DMatrix::from_column_slice(3, 3, pose_covariance.as_slice()),
            ),
            info: Vec::new(),
            origin_map: Vec::new(),
            bases_in_map: vec![pose_in_map],
            ids: Vec::new(),
            next_id: 0,
            last_joined_ids: Vec::new(),
            last_merged_ids: Vec::new(),
        }
    }

    /// The number the next joined landmark gets: a join numbers the local map's landmarks
    /// from it in their order.
    pub fn next_landmark_id(&self) -> usize {
        self.next_id
    }

    /// For each landmark of the last joined local map, in its order, the number of the
    /// landmark it now stands as: its own number, or that of the landmark it was fused into.
    /// A later join may merge a record of one trunk into another ([`GlobalMap::join`]); whoever
    /// keeps these numbers follows [`GlobalMap::last_merged_ids`] after each join.
    pub fn last_joined_ids(&self) -> &[usize] {
        &self.last_joined_ids
    }

    /// The numbers that stopped standing when the last join fused records of one trunk, as
    /// `(from, to)`: what stood as `from` stands as `to`. A record dropped as biased is not
    /// listed; its number no longer stands.
    pub fn last_merged_ids(&self) -> &[(usize, usize)] {
        &self.last_merged_ids
    }

    /// Where the map now puts each landmark numbered in `ids`; `None` for numbers that do not
    /// stand (never handed out, or fused into another: see [`GlobalMap::last_joined_ids`]).
    pub fn positions_by_id(&self, ids: &[usize]) -> Vec<Option<[f64; 2]>> {
        ids.iter()
            .map(|id| {
                let index = self.ids.binary_search(id).ok()?;
                Some(self.state.landmark(index))
            })
            .collect()
    }

    /// The joined state: robot pose (the current base frame), then landmarks.
    pub fn state(&self) -> &EkfState<PackedCovariance> {
        &self.state
    }

    /// Bookkeeping of each landmark, in state order.
    pub fn landmark_info(&self) -> &[LandmarkInfo] {
        &self.info
    }

    /// The base frame of every local map so far, in the global frame (the base of the local
    /// map being built last), as estimated when each was started.
    pub fn bases_in_map(&self) -> &[Pose2] {
        &self.bases_in_map
    }

    /// Indices of the landmarks first mapped before local map `before` (for place recognition
    /// against the older part of the map).
    pub fn landmarks_older_than(&self, before: usize) -> Vec<usize> {
        (0..self.origin_map.len())
            .filter(|&i| self.origin_map[i] < before)
            .collect()
    }

    /// The base frame of the local map being built.
    pub fn current_base(&self) -> Pose2 {
        self.state.pose()
    }

    /// Re-expresses the whole map in another frame: `new_from_old` maps the current map frame
    /// into the new one (for example `enu_from_map` once GPS has fixed the alignment).
    pub fn transform(&mut self, new_from_old: Pose2) {
        self.state.transform_rigid(new_from_old);
        for base in &mut self.bases_in_map {
            *base = compose_pose(new_from_old, *base).0;
        }
    }

    /// Joins `local` (built in the current base frame) and fuses the landmarks found in both:
    /// those the gate and JCBB pair, plus `recognised` pairs `(local landmark, global
    /// landmark)` from place recognition.
    ///
    /// # Errors
    /// [`EkfError`] when the fusion update fails; the local map is then joined without fusion.
    pub fn join(
        &mut self,
        local: LocalMap,
        options: &AssociationOptions,
        recognised: &[(usize, usize)],
    ) -> Result<JoinReport, EkfError> {
        let parts = local.into_parts();
        let (local_state, local_info) = (parts.state, parts.info);
        // What the local map learnt about its base flows into the global map first; if the
        // global base has no uncertainty to regress on, the local estimate is not used.
        let base_offset = parts.base_offset.filter(|&offset| {
            let mean = local_state.mean();
            let base = Pose2 {
                x_m: mean[offset],
                y_m: mean[offset + 1],
                theta_rad: mean[offset + 2],
            };
            let covariance = local_state
                .covariance()
                .fixed_view::<3, 3>(offset, offset)
                .into_owned();
            self.state.set_pose_marginal(base, &covariance).is_ok()
        });
        let base = self.state.pose();
        let n_local = local_state.dim();
        let local_robot_dim = local_state.robot_dim();
        let count = local_state.landmark_count();
        let k = 3 + 2 * count;

        // The new entries (robot, then landmarks) and their Jacobians with respect to the
        // base (global entries 0..3) and to the local state.
        let mut mean = DVector::zeros(k);
        let mut d_base = DMatrix::zeros(k, 3);
        let mut d_local = DMatrix::zeros(k, n_local);
        let (robot, d_b, d_r) = compose_pose(base, local_state.pose());
        mean.rows_mut(0, 3)
            .copy_from_slice(&[robot.x_m, robot.y_m, robot.theta_rad]);
        d_base.view_mut((0, 0), (3, 3)).copy_from(&d_b);
        d_local.view_mut((0, 0), (3, 3)).copy_from(&d_r);
        for i in 0..count {
            let (point, d_b, d_l) = transform_point(base, local_state.landmark(i));
            let row = 3 + 2 * i;
            mean.rows_mut(row, 2).copy_from_slice(&point);
            d_base.view_mut((row, 0), (2, 3)).copy_from(&d_b);
            d_local
                .view_mut((row, local_robot_dim + 2 * i), (2, 2))
                .copy_from(&d_l);
        }
        let p_base_all = self.state.covariance().rows(0, 3);
        let p_base = self.state.covariance().block(0, 3);
        let (cross, own) = match base_offset {
            Some(offset) => {
                // The base is a local entry: J covers it, and the new entries see the global
                // map through their regression on it.
                d_local.view_mut((0, offset), (k, 3)).copy_from(&d_base);
                let p_local = local_state.covariance();
                let own = &d_local * p_local * d_local.transpose();
                let local_with_base = &d_local * p_local.columns(offset, 3);
                let through_base = match p_base.clone().cholesky() {
                    Some(cholesky) => cholesky.solve(&local_with_base.transpose()).transpose(),
                    None => d_base.clone(),
                };
                (CrossCovariance::new(through_base, p_base_all), own)
            }
            None => {
                let own = &d_base * p_base * d_base.transpose()
                    + &d_local * local_state.covariance() * d_local.transpose();
                (CrossCovariance::new(d_base, p_base_all), own)
            }
        };
        // The new robot takes the old base's place, [r', M, L'], and the local landmarks
        // found in the map are fused into it at once: pairing reads the joined state in
        // place, so the covariance never holds the landmarks that are fused away.
        let old_count = self.info.len();
        let joined_map = self.bases_in_map.len() - 1;
        let (pairs, place_rejected) = {
            let joined = JoinedState::new(&self.state, &mean, &cross, &own);
            let mut pairs = self.pair(&joined, &local_info, options);
            // Pairings a place recognised by the history memory adds, for landmarks the gate
            // in the drifted global frame could not pair.
            let place: Vec<(usize, usize)> = recognised
                .iter()
                .map(|&(local, old)| (old_count + local, old))
                .filter(|&(new, old)| new < old_count + count && old < old_count)
                .collect();
            let place_rejected = !place.is_empty() && !place_is_credible(&joined, &place, options);
            if !place_rejected {
                for (new, old) in place {
                    if pairs.iter().all(|&(n, o)| n != new && o != old) {
                        pairs.push((new, old));
                    }
                }
            }
            (pairs, place_rejected)
        };
        let revisited = pairs
            .iter()
            .filter(|&&(_, old)| self.origin_map[old] + 1 < joined_map)
            .count();
        // `(local landmark, global landmark)`.
        let fused: Vec<(usize, usize)> = pairs
            .iter()
            .map(|&(new, old)| (new - old_count, old))
            .collect();
        let fusion =
            self.state
                .replace_pose_append_and_fuse(&mean, &cross, &own, &fused, FUSION_SIGMA_M);
        let mut fused_into = vec![None; count];
        match fusion {
            Ok(()) => fused
                .iter()
                .for_each(|&(local, old)| fused_into[local] = Some(old)),
            // The local map is joined without fusion.
            Err(_) => self.state.replace_pose_and_append(&mean, &cross, &own),
        }
        // Every local landmark is numbered, in order; a fused one stands as its global
        // landmark from the start.
        let first_id = self.next_id;
        self.next_id += count;
        self.last_joined_ids.clear();
        for (i, (record, into)) in local_info.into_iter().zip(fused_into).enumerate() {
            match into {
                Some(old) => {
                    self.info[old].merge(&record);
                    self.last_joined_ids.push(self.ids[old]);
                }
                None => {
                    self.info.push(record);
                    self.origin_map.push(joined_map);
                    self.ids.push(first_id + i);
                    self.last_joined_ids.push(first_id + i);
                }
            }
        }
        self.bases_in_map.push(robot);
        fusion?;
        // A merge that fails leaves the map as it was (the fusion update changes nothing when
        // it fails), and the join stands.
        self.last_merged_ids.clear();
        let merged_records = self.merge_records_of_one_trunk().unwrap_or(0);
        Ok(JoinReport {
            fused: pairs.len(),
            added: count - pairs.len(),
            revisited,
            place_rejected,
            merged_records,
        })
    }

    /// Merges records of one trunk that the joins kept apart, and returns how many records
    /// went.
    ///
    /// A join pairs the new landmarks with the old ones only, so two records of a tree, once
    /// both in the map, would stay apart for good: a thick trunk whose front edge was once
    /// taken for a thin tree, or a thin one whose first sightings measured it too thick for
    /// the diameter test. Two trunks cannot stand inside each other, so two records whose
    /// circles overlap beyond doubt (their distance plus [`OVERLAP_SIGMAS`] standard
    /// deviations of it, from the map's covariance, short of the sum of their radii) are of
    /// one trunk. When their difference is within the covariance (the
    /// [`SAME_POINT_CONFIDENCE`] chi-square gate), they are fused as one point; otherwise
    /// one of them is biased (a part of the trunk fitted as a whole one), and the record
    /// with fewer observations is dropped (marginalised out). Records without a diameter
    /// (features other than trunks) are left alone.
    fn merge_records_of_one_trunk(&mut self) -> Result<usize, EkfError> {
        let count = self.info.len();
        let same_point_gate = chi_square_quantile(2, SAME_POINT_CONFIDENCE);
        // (distance, a, b, same point) for every overlapping pair.
        let mut overlapping = Vec::new();
        for a in 0..count {
            let Some(diameter_a) = self.info[a].diameter_m else {
                continue;
            };
            let la = self.state.landmark(a);
            for b in a + 1..count {
                let Some(diameter_b) = self.info[b].diameter_m else {
                    continue;
                };
                let lb = self.state.landmark(b);
                let difference = nalgebra::Vector2::new(la[0] - lb[0], la[1] - lb[1]);
                let distance_m = difference.norm();
                let radii_m = 0.5 * (diameter_a + diameter_b);
                if distance_m >= radii_m {
                    continue;
                }
                let covariance = self.difference_covariance(a, b);
                let direction = if distance_m > 1e-9 {
                    difference / distance_m
                } else {
                    nalgebra::Vector2::x()
                };
                let sigma_m = direction.dot(&(covariance * direction)).max(0.0).sqrt();
                if distance_m + OVERLAP_SIGMAS * sigma_m >= radii_m {
                    continue;
                }
                let noise = Matrix2::identity() * FUSION_SIGMA_M.powi(2);
                let same_point = (covariance + noise).try_inverse().is_some_and(|inverse| {
                    difference.dot(&(inverse * difference)) <= same_point_gate
                });
                overlapping.push((distance_m, a, b, same_point));
            }
        }
        overlapping.sort_by(|x, y| x.0.total_cmp(&y.0));
        // Each record in at most one merge per join; `(removed, kept)` pairs.
        let mut taken = vec![false; count];
        let (mut fused, mut dropped) = (Vec::new(), Vec::new());
        for (_, a, b, same_point) in overlapping {
            if taken[a] || taken[b] {
                continue;
            }
            taken[a] = true;
            taken[b] = true;
            let (removed, kept) = if self.info[a].observations >= self.info[b].observations {
                (b, a)
            } else {
                (a, b)
            };
            if same_point {
                fused.push((removed, kept));
            } else {
                dropped.push((removed, kept));
            }
        }
        let merged = fused.len() + dropped.len();
        // Fusing removes records, so the dropped pairs are renumbered after it.
        let mut gone: Vec<usize> = fused.iter().map(|&(removed, _)| removed).collect();
        gone.sort_unstable();
        let merged_ids: Vec<(usize, usize)> = fused
            .iter()
            .map(|&(removed, kept)| (self.ids[removed], self.ids[kept]))
            .collect();
        self.fuse(&fused)?;
        self.last_merged_ids = merged_ids;
        let renumbered = |index: usize| index - gone.partition_point(|&g| g < index);
        let dropped: Vec<(usize, usize)> = dropped
            .iter()
            .map(|&(removed, kept)| (renumbered(removed), renumbered(kept)))
            .collect();
        self.drop_records(&dropped);
        Ok(merged)
    }

    /// Covariance of `l_a − l_b`.
    fn difference_covariance(&self, a: usize, b: usize) -> Matrix2<f64> {
        let jacobian =
            difference_jacobian(self.state.landmark_offset(a), self.state.landmark_offset(b));
        cross_covariance(self.state.covariance(), &jacobian, &jacobian)
    }

    /// Pairs the new landmarks of `joined` (records `new_info`) with the map's: `(new, old)`
    /// indices in the joined state.
    fn pair(
        &self,
        joined: &JoinedState<'_, PackedCovariance>,
        new_info: &[LandmarkInfo],
        options: &AssociationOptions,
    ) -> Vec<(usize, usize)> {
        let gate = chi_square_quantile(2, options.individual_confidence);
        let covariance = joined;
        let noise = Matrix2::identity() * FUSION_SIGMA_M.powi(2);
        let first_new = self.info.len();
        let total = joined.landmark_count();
        let mut candidates = Vec::with_capacity(total - first_new);
        for new in first_new..total {
            let position = joined.landmark(new);
            let mut list = Vec::new();
            for old in 0..first_new {
                let other = joined.landmark(old);
                let innovation =
                    nalgebra::Vector2::new(other[0] - position[0], other[1] - position[1]);
                // Cheap rejection: no two records of a trunk lie 20 m apart after a join.
                if innovation.norm() > 20.0 {
                    continue;
                }
                // Exact cheap rejection: νᵀ S⁻¹ ν ≥ |ν|² / λ_max(S) ≥ |ν|² / trace(S), and the
                // trace takes six entries of the covariance where S takes sixteen.
                let (cn, co) = (joined.landmark_offset(new), joined.landmark_offset(old));
                let trace = (0..2)
                    .map(|d| {
                        covariance.entry(cn + d, cn + d) + covariance.entry(co + d, co + d)
                            - 2.0 * covariance.entry(cn + d, co + d)
                    })
                    .sum::<f64>()
                    + noise.trace();
                if innovation.norm_squared() > gate * trace {
                    continue;
                }
                if !self.info[old].diameter_compatible(
                    new_info[new - first_new].diameter_m,
                    options.diameter_tolerance_m,
                    options.diameter_tolerance_fraction,
                ) {
                    continue;
                }
                let jacobian = difference_jacobian(cn, co);
                let candidate =
                    PairingCandidate::new(old, innovation, jacobian, covariance, &noise);
                if let Some(candidate) = candidate.filter(|c| c.distance2 < gate) {
                    list.push(candidate);
                }
            }
            list.sort_by(|a, b| a.distance2.total_cmp(&b.distance2));
            candidates.push(list);
        }
        let noises = vec![noise; candidates.len()];
        jcbb(&candidates, &noises, covariance, &options.jcbb)
            .into_iter()
            .enumerate()
            .filter_map(|(i, old)| old.map(|old| (first_new + i, old)))
            .collect()
    }

    /// Imposes `l_removed = l_kept` for every pair `(removed, kept)` and removes the first
    /// record of each.
    fn fuse(&mut self, pairs: &[(usize, usize)]) -> Result<(), EkfError> {
        if pairs.is_empty() {
            return Ok(());
        }
        self.state.merge_landmarks(pairs, FUSION_SIGMA_M)?;
        for &(removed, kept) in pairs {
            let record = self.info[removed];
            self.info[kept].merge(&record);
        }
        self.forget(pairs);
        Ok(())
    }

    /// Removes (marginalises out) the first record of every pair `(removed, kept)`, the
    /// second standing for it from then on.
    fn drop_records(&mut self, pairs: &[(usize, usize)]) {
        if pairs.is_empty() {
            return;
        }
        let removed: Vec<usize> = pairs.iter().map(|&(removed, _)| removed).collect();
        self.state.remove_landmarks(&removed);
        self.forget(pairs);
    }

    /// The bookkeeping of records `(removed, kept)` whose state entries are gone: what stood
    /// as the removed one stands as the kept one, which counts as first mapped at the earlier
    /// of the two.
    fn forget(&mut self, pairs: &[(usize, usize)]) {
        for &(removed, kept) in pairs {
            let (from, to) = (self.ids[removed], self.ids[kept]);
            for id in self.last_joined_ids.iter_mut().filter(|id| **id == from) {
                *id = to;
            }
            self.origin_map[kept] = self.origin_map[kept].min(self.origin_map[removed]);
        }
        let mut removed: Vec<usize> = pairs.iter().map(|&(removed, _)| removed).collect();
        removed.sort_unstable();
        let keep = |index: usize| removed.binary_search(&index).is_err();
        self.info = (0..self.info.len())
            .filter(|&i| keep(i))
            .map(|i| self.info[i])
            .collect();
        self.origin_map = (0..self.origin_map.len())
            .filter(|&i| keep(i))
            .map(|i| self.origin_map[i])
            .collect();
        self.ids = (0..self.ids.len())
            .filter(|&i| keep(i))
            .map(|i| self.ids[i])
            .collect();
    }
}

/// Whether the pairs `(new, old)` of a recognised place may be fused: always when the joined
/// state's covariance finds them jointly plausible (their stacked innovation within the
/// [`PLACE_CONFIDENCE`] chi-square quantile), otherwise only with at least
/// `options.min_pairs_against_the_map` pairs. A revisit after a long drift moves the map
/// further than its (over-confident) covariance allows and is backed by many trees; a
/// look-alike place found by a well-localised robot contradicts the map by orders of
/// magnitude more and is backed by few.
fn place_is_credible(
    joined: &JoinedState<'_, PackedCovariance>,
    pairs: &[(usize, usize)],
    options: &AssociationOptions,
) -> bool {
    if pairs.len() >= options.min_pairs_against_the_map {
        return true;
    }
    let m = 2 * pairs.len();
    let jacobians: Vec<Vec<JacobianBlock>> = pairs
        .iter()
        .map(|&(new, old)| {
            difference_jacobian(joined.landmark_offset(new), joined.landmark_offset(old))
        })
        .collect();
    // S = H P Hᵀ + R and ν = l_old − l_new, stacked over the pairs.
    let mut s = DMatrix::identity(m, m) * FUSION_SIGMA_M.powi(2);
    let mut innovation = DVector::zeros(m);
    for (a, (&(new, old), jacobian_a)) in pairs.iter().zip(&jacobians).enumerate() {
        let (l_new, l_old) = (joined.landmark(new), joined.landmark(old));
        innovation[2 * a] = l_old[0] - l_new[0];
        innovation[2 * a + 1] = l_old[1] - l_new[1];
        for (b, jacobian_b) in jacobians.iter().enumerate() {
            let mut block = s.fixed_view_mut::<2, 2>(2 * a, 2 * b);
            block += cross_covariance(joined, jacobian_a, jacobian_b);
        }
    }
    s.cholesky().is_some_and(|cholesky| {
        innovation.dot(&cholesky.solve(&innovation)) <= chi_square_quantile(m, PLACE_CONFIDENCE)
    })
}

/// The Jacobian of `l_a − l_b` for landmarks whose entries start at `offset_a` and
/// `offset_b` (the difference a fusion drives to zero).
fn difference_jacobian(offset_a: usize, offset_b: usize) -> Vec<JacobianBlock> {
    vec![
        JacobianBlock {
            column: offset_a,
            matrix: DMatrix::identity(2, 2),
        },
        JacobianBlock {
            column: offset_b,
            matrix: -DMatrix::identity(2, 2),
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ekf_slam::local_map::seen_once;
    use crate::ekf_slam::{LandmarkObservation, RangeBearingModel};

    const TREES: [[f64; 2]; 6] = [
        [8.0, 3.0],
        [12.0, -4.0],
        [15.0, 6.0],
        [20.0, -1.0],
        [6.0, -7.0],
        [18.0, 9.0],
    ];

    /// A local map at the origin of its base that saw `trees` shifted by `shift_m`.
    fn local_map(shift_m: [f64; 2]) -> LocalMap {
        let shifted = TREES.map(|[x, y]| [x + shift_m[0], y + shift_m[1]]);
        seen_once(&shifted)
    }

    /// A global map holding the trees, and the join of a second local map that saw them
    /// shifted, told by place recognition that they are the same trees.
    fn join_recognised(shift_m: [f64; 2], min_pairs: usize) -> (JoinReport, usize) {
        let mut global = GlobalMap::new(Pose2::IDENTITY, Matrix3::zeros());
        let options = AssociationOptions {
            new_landmark_distance2: 0.0,
            min_pairs_against_the_map: min_pairs,
            ..AssociationOptions::default()
        };
        global
            .join(local_map([0.0, 0.0]), &options, &[])
            .expect("first join");
        let recognised: Vec<(usize, usize)> = (0..TREES.len()).map(|i| (i, i)).collect();
        let report = global
            .join(local_map(shift_m), &options, &recognised)
            .expect("second join");
        (report, global.state().landmark_count())
    }

    #[test]
    fn a_joined_landmark_is_numbered_as_the_landmark_it_was_fused_into() {
        let mut global = GlobalMap::new(Pose2::IDENTITY, Matrix3::zeros());
        let options = AssociationOptions {
            new_landmark_distance2: 0.0,
            ..AssociationOptions::default()
        };
        assert_eq!(global.next_landmark_id(), 0);
        global
            .join(local_map([0.0, 0.0]), &options, &[])
            .expect("first join");
        assert_eq!(global.next_landmark_id(), 6);
        let recognised: Vec<(usize, usize)> = (0..TREES.len()).map(|i| (i, i)).collect();
        global
            .join(local_map([0.0, 0.0]), &options, &recognised)
            .expect("second join");
        assert_eq!(global.next_landmark_id(), 12);
        assert_eq!(global.state().landmark_count(), 6);
        // The second local map's trees were fused into the first one's.
        assert_eq!(global.last_joined_ids(), &[0, 1, 2, 3, 4, 5]);
        let found = global.positions_by_id(&[0, 5, 6, 12]);
        assert_eq!(found[0], Some(global.state().landmark(0)));
        assert_eq!(found[1], Some(global.state().landmark(5)));
        assert_eq!(found[2..], [None, None]);
    }

    /// A local map at the origin of its base that saw each trunk `(position, diameter)` once,
    /// with a laser's precision (3 cm, 0.25°).
    fn trunks_seen_once(trunks: &[([f64; 2], f64)]) -> LocalMap {
        let observations: Vec<LandmarkObservation> = trunks
            .iter()
            .map(|&([x, y], diameter_m)| LandmarkObservation {
                range_m: x.hypot(y),
                bearing_rad: y.atan2(x),
                diameter_m: Some(diameter_m),
            })
            .collect();
        let mut local = LocalMap::new(DVector::zeros(3), DMatrix::zeros(3, 3));
        local
            .observe(
                &observations,
                &RangeBearingModel {
                    sigma_range_m: 0.03,
                    sigma_bearing_rad: 0.25f64.to_radians(),
                    ..RangeBearingModel::default()
                },
                &AssociationOptions::default(),
            )
            .expect("first observations");
        local
    }

    /// Two thick trunks side by side (their bark 0.1 m apart) and two thin trees.
    const TRUNKS: [([f64; 2], f64); 4] = [
        ([10.0, 0.0], 1.0),
        ([10.0, 1.1], 1.0),
        ([15.0, -5.0], 0.4),
        ([12.0, 6.0], 0.3),
    ];

    /// The global map after joining `TRUNKS`, then a local map that saw `TRUNKS` but the one
    /// numbered `unseen` (a local map drops an observation that close to a landmark it holds
    /// as ambiguous), and `extra`.
    fn joined_with(extra: ([f64; 2], f64), unseen: Option<usize>) -> (GlobalMap, JoinReport) {
        let mut global = GlobalMap::new(Pose2::IDENTITY, Matrix3::zeros());
        let options = AssociationOptions::default();
        global
            .join(trunks_seen_once(&TRUNKS), &options, &[])
            .expect("first join");
        let mut second: Vec<([f64; 2], f64)> = (0..TRUNKS.len())
            .filter(|&i| Some(i) != unseen)
            .map(|i| TRUNKS[i])
            .collect();
        second.push(extra);
        let report = global
            .join(trunks_seen_once(&second), &options, &[])
            .expect("second join");
        (global, report)
    }

    #[test]
    fn the_front_of_a_thick_trunk_taken_for_a_thin_tree_is_dropped() {
        // The front 0.4 m of the first trunk, fitted as a trunk of its own.
        let (global, report) = joined_with(([9.6, 0.0], 0.5), Some(0));
        assert_eq!(report.merged_records, 1);
        assert_eq!(global.state().landmark_count(), TRUNKS.len());
        for (i, &(position, _)) in TRUNKS.iter().enumerate() {
            let found = global.state().landmark(i);
            assert!((found[0] - position[0]).hypot(found[1] - position[1]) < 1e-6);
        }
        assert_eq!(global.landmark_info()[0].diameter_m, Some(1.0));
    }

    #[test]
    fn two_records_of_a_trunk_that_agree_on_its_place_are_fused() {
        // The last tree again, 3 cm off and measured too thick to pass the diameter test.
        let (global, report) = joined_with(([12.03, 6.0], 0.8), Some(3));
        assert_eq!(report.merged_records, 1);
        assert_eq!(global.state().landmark_count(), TRUNKS.len());
        let found = global.state().landmark(3);
        assert!(found[0] > 12.0 && found[0] < 12.03, "{found:?}");
        let info = global.landmark_info()[3];
        assert_eq!(info.observations, 2);
        // The second record (numbered 7, the last of the second join) stands as the first.
        assert_eq!(global.last_merged_ids(), &[(7, 3)]);
        assert_eq!(global.last_joined_ids(), &[0, 1, 2, 3]);
        assert_eq!(global.positions_by_id(&[7]), vec![None]);
        assert!(info.diameter_m.is_some_and(|d| d > 0.3 && d < 0.8));
    }

    #[test]
    fn trunks_that_stand_apart_stay_apart() {
        // A thin tree just beyond the second trunk's bark.
        let (global, report) = joined_with(([10.0, 1.95], 0.3), None);
        assert_eq!(report.merged_records, 0);
        assert_eq!(global.state().landmark_count(), TRUNKS.len() + 1);
    }

    #[test]
    fn a_place_the_map_finds_plausible_is_fused() {
        let (report, landmarks) = join_recognised([0.0, 0.0], 15);
        assert!(!report.place_rejected);
        assert_eq!((report.fused, landmarks), (6, 6));
    }

    #[test]
    fn an_implausible_place_backed_by_few_trees_is_turned_down() {
        let (report, landmarks) = join_recognised([30.0, 0.0], 15);
        assert!(report.place_rejected);
        assert_eq!((report.fused, landmarks), (0, 12));
    }

    #[test]
    fn an_implausible_place_backed_by_enough_trees_is_fused() {
        let (report, landmarks) = join_recognised([30.0, 0.0], 6);
        assert!(!report.place_rejected);
        assert_eq!((report.fused, landmarks), (6, 6));
    }
}
