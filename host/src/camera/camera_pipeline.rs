//! The camera method as the robot runs it: frames from the camera (on the robot computer's
//! clock) and GPS fixes from the board, in the order they come, into one estimate of the
//! robot in the GPS's metric frame.
//!
//! [`MonoSlam`] estimates the camera up to a scale it cannot observe, in the frame of the
//! first camera (x right, y down, z forward). The camera is mounted level, so that frame's
//! ground plane is its x–z plane; a point there, taken as `(z, −x)` (forward, left), is the
//! `map` frame of this pipeline, a right-handed frame as the `enu` one is. Each fix is paired
//! with the camera's map position at the fix's time (interpolated between the frames either
//! side of it), and the pairs fix the similarity `enu_from_map` ([`SimilarityFit2d`]):
//! rotation, translation and the map's scale in metres, by least squares weighted with each
//! fix's covariance. The fit keeps only its sums, so a fix costs the same at any hour.
//!
//! A receiver reports each epoch in several sentences (GGA, RMC, …); one report per epoch is
//! used (the first that makes a measurement), so that no fix counts twice.
//!
//! Once the fixes span [`CameraPipelineOptions::alignment_span_m`], the estimate is in the
//! `enu` frame at the datum (given, or the first fix); before that it is in the `map` frame
//! without a scale. The fit of all the fixes gives the map its scale
//! ([`CameraPipeline::alignment`]). A single camera's heading and scale drift over a long
//! run, so the path is cut into segments, each put into the `enu` frame by a fit of its
//! own. A segment is a local map of the camera method, or the part of one after a place
//! was recognised. Segments that share a frame are linked: a new local map with the one
//! before it (the path runs on), and the part after a recognised place with the earlier
//! map's segment (the history memory moved the camera into that map's frame, so the path
//! jumps there, and from there on agrees with the earlier map). A segment's fit is that of
//! its fixes and, while they span less than the alignment span, those of the segments
//! linked to it, nearest links first (at most [`MAX_SEGMENTS_PER_FIT`]), each taken in only
//! where its fixes agree with the fit so far ([`SimilarityFit2d::agrees_with`], within
//! [`LINK_AGREEMENT_CHI2`]): a place recognised in the wrong spot, or a map whose frame
//! drifted since, puts the camera where the fixes say it was not. The segment before a
//! recognised place is linked to the one after it too, through the jump
//! ([`SimilarityFit2d::moved`]), so that the path's own continuation serves where the
//! recognised map's segment contradicts the fixes. The fits keep only
//! their sums (about one origin, so that they add up), so a segment costs a few hundred
//! bytes and a fix the same at any hour. By default the fixes are not fused into the
//! filter: the camera's path within a segment is its own.
//!
//! With [`CameraPipelineOptions::fuse_gps`], each fix after the map is aligned is also a
//! measurement for the filter: put into the map's frame by its segment's similarity, it says
//! where the camera was on the ground at the fix's time
//! ([`MonoSlam::update_ground_position`]). A fix further from the filter's estimate than the
//! two covariances allow (beyond [`FUSION_GATE_CHI2`]) is left out.

use std::collections::{HashSet, VecDeque};

use image::GrayImage;
use nalgebra::{UnitQuaternion, Vector3};

use super::mono_slam::WorldJump;
use super::{FrameReport, LevelPrior, MonoSlam, MonoSlamOptions, MonoSlamStats, PinholeCamera};
use crate::geometry::Pose2;
use crate::georef::{
    AlignmentPair, GpsMeasurement, GpsMeasurementOptions, LocalFrame, MapFrameChange,
    SimilarityAlignment2d, SimilarityFit2d,
};
use crate::link::SensorEvent;

/// The most segments one segment's fit takes in (when the fixes are too few to span the
/// alignment span, as in a GPS outage, the fit of those taken serves, or the fit of all
/// fixes where those fix no similarity).
pub const MAX_SEGMENTS_PER_FIT: usize = 64;

/// The χ² (four degrees of freedom: the similarity) beyond which a linked segment's fixes
/// are taken to contradict a segment's fit, and are not taken into it: 99.9 % of segments
/// that do share one similarity with it lie within it.
pub const LINK_AGREEMENT_CHI2: f64 = 18.47;

/// The χ² (two degrees of freedom) beyond which a fix is not fused: 99.9 % of right fixes
/// lie within it.
pub const FUSION_GATE_CHI2: f64 = 13.8;

/// How the camera pipeline runs.
#[derive(Clone, Copy, Debug)]
pub struct CameraPipelineOptions {
    /// The camera method.
    pub slam: MonoSlamOptions,
    /// How a fix's covariance is made.
    pub gps: GpsMeasurementOptions,
    /// The `enu` frame's datum (latitude, longitude, degrees); `None`: the first fix.
    pub datum_lat_lon_deg: Option<[f64; 2]>,
    /// The map is put into the `enu` frame once the paired fixes span this far (the larger
    /// side of their bounding box), m.
    pub alignment_span_m: f64,
    /// A fix is paired only with a frame at most this far from it in time, s (a fix in a
    /// gap of the camera's frames has no position to pair with).
    pub max_frame_gap_s: f64,
    /// Fuse the fixes into the camera method's filter: once the map is aligned, each fix,
    /// put into the map's frame by its segment's similarity, measures where the camera was,
    /// and corrects its position, velocity and, through them, its map and its scale.
    /// Otherwise the fixes only place the camera's path.
    pub fuse_gps: bool,
}

impl Default for CameraPipelineOptions {
    /// The camera method's defaults held level as a camera on a ground robot is
    /// ([`LevelPrior`]'s default; not held to move forward, [`super::ForwardMotionPrior`]), the GPS
    /// defaults, the datum at the first fix, aligned over 20 m, fixes paired within 0.5 s of
    /// a frame.
    fn default() -> Self {
        CameraPipelineOptions {
            slam: MonoSlamOptions {
                level: Some(LevelPrior::default()),
                ..MonoSlamOptions::default()
            },
            gps: GpsMeasurementOptions::default(),
            datum_lat_lon_deg: None,
            alignment_span_m: 20.0,
            max_frame_gap_s: 0.5,
            fuse_gps: false,
        }
    }
}

/// The camera at one frame, in the first camera's frame (no metric scale).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPose {
    /// Host time of the frame, s.
    pub time_s: f64,
    /// The camera's position.
    pub position: Vector3<f64>,
    /// `world_from_camera`.
    pub orientation: UnitQuaternion<f64>,
}

impl CameraPose {
    /// The camera's ground position in the pipeline's `map` frame (forward, left of the first
    /// camera).
    pub fn in_map(&self) -> [f64; 2] {
        [self.position.z, -self.position.x]
    }

    /// The heading of the camera's optical axis in the `map` frame, radians.
    pub fn heading_in_map_rad(&self) -> f64 {
        let forward = self.orientation * Vector3::z();
        (-forward.x).atan2(forward.z)
    }
}

/// What the pipeline did with its inputs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraPipelineStats {
    /// Fixes that made a measurement.
    pub fixes: usize,
    /// Fixes paired with the camera.
    pub fixes_paired: usize,
    /// Fixes that made a measurement but were not paired: in a gap of the frames, or where
    /// the camera's position is not a finite number.
    pub fixes_not_paired: usize,
    /// Reports refused: no position, or not convertible to the `enu` frame.
    pub fixes_refused: usize,
    /// Reports of an epoch already used (another sentence of it).
    pub reports_of_used_epochs: usize,
    /// Fixes fused into the filter ([`CameraPipelineOptions::fuse_gps`]).
    pub fixes_fused: usize,
    /// Fixes not fused because they lay further from the filter's estimate than the two
    /// covariances allow (χ² beyond [`FUSION_GATE_CHI2`]).
    pub fixes_gated: usize,
}

/// A stretch of the path that one similarity puts into the `enu` frame.
#[derive(Clone, Debug)]
struct Segment {
    /// Its fixes' fit, once it has one.
    fit: Option<SimilarityFit2d>,
    /// Its fixes' bounding box in the `enu` frame, `[min_e, min_n, max_e, max_n]`.
    span: Option<[f64; 4]>,
    /// The segments linked to it: in the same frame, the one before it along the path, or
    /// the recognised map's segment it jumped into, and those linked to it in turn; across a
    /// recognised place, the segment before the jump and the one after, through the jump.
    links: Vec<Link>,
}

/// A segment linked to another, and how its `map` coordinates go into the other's.
#[derive(Clone, Copy, Debug)]
struct Link {
    segment: usize,
    /// The linked segment's `map` coordinates into those of the segment holding the link:
    /// no change for segments in one frame, the jump for the segment before a recognised
    /// place (the path itself runs on there, in the frame it had).
    change: MapFrameChange,
}

impl Link {
    fn same_frame(segment: usize) -> Link {
        Link {
            segment,
            change: MapFrameChange::IDENTITY,
        }
    }
}

/// The world jump of a recognised place (`after = rotation * before + translation`) as a
/// change of the `map` frame (forward and left of the first camera).
fn map_frame_change(jump: &WorldJump) -> MapFrameChange {
    let (translation, rotation) = jump;
    let moved = |[forward, left]: [f64; 2]| {
        let p = rotation * Vector3::new(-left, 0.0, forward) + translation;
        [p.z, -p.x]
    };
    let shift = moved([0.0, 0.0]);
    let unit = moved([1.0, 0.0]);
    MapFrameChange {
        turn_scale: [unit[0] - shift[0], unit[1] - shift[1]],
        shift,
    }
}

/// The camera method with GPS. See the [module documentation](self).
#[derive(Debug)]
pub struct CameraPipeline {
    options: CameraPipelineOptions,
    slam: MonoSlam,
    frame: Option<LocalFrame>,
    poses: Vec<CameraPose>,
    /// Fixes newer than the last frame: host time, measurement.
    pending: VecDeque<(f64, GpsMeasurement)>,
    fit: SimilarityFit2d,
    /// The paired fixes' bounding box in the `enu` frame, `[min_e, min_n, max_e, max_n]`.
    span: Option<[f64; 4]>,
    /// The fit as of the last pair, once the fixes span far enough.
    alignment: Option<SimilarityAlignment2d>,
    /// Each frame's segment.
    pose_segments: Vec<u32>,
    /// Each segment's fit, its fixes' bounding box and the segments it shares a frame with.
    segments: Vec<Segment>,
    /// Each local map's latest segment.
    local_map_segments: Vec<u32>,
    stats: CameraPipelineStats,
    /// UTC time of the last epoch used.
    last_epoch_s: Option<f64>,
}

impl CameraPipeline {
    /// A pipeline for `camera`, with nothing seen yet.
    ///
    /// # Errors
    /// A datum that is not a latitude and longitude.
    pub fn new(
        camera: PinholeCamera,
        options: CameraPipelineOptions,
    ) -> Result<Self, crate::georef::GeoRefError> {
        let frame = options
            .datum_lat_lon_deg
            .map(|[lat, lon]| LocalFrame::new(lat, lon, 0.0))
            .transpose()?;
        Ok(CameraPipeline {
            options,
            slam: MonoSlam::new(camera, options.slam),
            frame,
            poses: Vec::new(),
            pending: VecDeque::new(),
            fit: SimilarityFit2d::new(),
            span: None,
            alignment: None,
            pose_segments: Vec::new(),
            segments: Vec::new(),
            local_map_segments: Vec::new(),
            stats: CameraPipelineStats::default(),
            last_epoch_s: None,
        })
    }

    /// The camera method.
    pub fn slam(&self) -> &MonoSlam {
        &self.slam
    }

    /// The camera method's counts.
    pub fn slam_stats(&self) -> MonoSlamStats {
        self.slam.stats()
    }

    /// What was done with the fixes.
    pub fn stats(&self) -> CameraPipelineStats {
        self.stats
    }

    /// The `enu` frame, once there is a datum.
    pub fn local_frame(&self) -> Option<&LocalFrame> {
        self.frame.as_ref()
    }

    /// Every frame's camera pose, in order.
    pub fn poses(&self) -> &[CameraPose] {
        &self.poses
    }

    /// `enu_from_map`, once the fixes span far enough.
    pub fn alignment(&self) -> Option<&SimilarityAlignment2d> {
        self.alignment.as_ref()
    }

    /// One frame, taken at host time `time_s`. Frames must come in time order; one that does
    /// not come after the last, or whose time is not a finite number, is not used (`None`),
    /// so no two frames share a time.
    pub fn on_frame(&mut self, time_s: f64, image: &GrayImage) -> Option<FrameReport> {
        if !time_s.is_finite() || self.poses.last().is_some_and(|last| time_s <= last.time_s) {
            return None;
        }
        let before = self.slam.stats();
        let report = self.slam.process(time_s, image);
        let after = self.slam.stats();
        self.poses.push(CameraPose {
            time_s,
            position: report.position_m,
            orientation: report.orientation,
        });
        if self.segments.is_empty()
            || report.place_recognised.is_some()
            || after.local_maps != before.local_maps
        {
            // The path runs on from the segment before, or jumps into the frame of the
            // recognised map's latest segment.
            let linked = match report.place_recognised {
                Some(map) => self.local_map_segments.get(map).map(|&s| s as usize),
                None => self.segments.len().checked_sub(1),
            };
            let new = self.segments.len();
            let mut links: Vec<Link> = linked.into_iter().map(Link::same_frame).collect();
            if let Some(linked) = linked {
                self.segments[linked].links.push(Link::same_frame(new));
            }
            // Across a recognised place the path runs on: the segment before, in the frame
            // it had, is linked through the jump (after the recognised map's segment, so that
            // it serves where that one contradicts the fixes).
            let jump = report.world_jump.as_ref().map(map_frame_change);
            if let (Some(jump), Some(before)) = (jump, new.checked_sub(1))
                && let Some(back) = jump.inverse()
                && report.place_recognised.is_some()
            {
                links.push(Link {
                    segment: before,
                    change: jump,
                });
                self.segments[before].links.push(Link {
                    segment: new,
                    change: back,
                });
            }
            self.segments.push(Segment {
                fit: None,
                span: None,
                links,
            });
            let local_map = after.local_maps.saturating_sub(1);
            if local_map >= self.local_map_segments.len() {
                self.local_map_segments.resize(local_map + 1, 0);
            }
            self.local_map_segments[local_map] = u32::try_from(new).unwrap_or(u32::MAX);
        }
        let segment = self.segments.len() - 1;
        self.pose_segments
            .push(u32::try_from(segment).unwrap_or(u32::MAX));
        self.pair_pending();
        Some(report)
    }

    /// A sensor event from the board: fixes are kept for pairing, scans are not used.
    pub fn on_event(&mut self, event: &SensorEvent) {
        let SensorEvent::Fix {
            host_time_s, fix, ..
        } = event
        else {
            return;
        };
        if fix.utc_time_s.is_some() && fix.utc_time_s == self.last_epoch_s {
            self.stats.reports_of_used_epochs += 1;
            return;
        }
        match GpsMeasurement::in_frame_or_first(fix, &mut self.frame, &self.options.gps) {
            Ok(measurement) => {
                self.stats.fixes += 1;
                self.last_epoch_s = fix.utc_time_s;
                if self.poses.first().is_some_and(|p| *host_time_s >= p.time_s) {
                    self.pending.push_back((*host_time_s, measurement));
                    self.pair_pending();
                }
            }
            Err(_) => self.stats.fixes_refused += 1,
        }
    }

    /// Pairs the fixes that now have a frame at or after them, and refits.
    fn pair_pending(&mut self) {
        let Some(last) = self.poses.last().map(|p| p.time_s) else {
            return;
        };
        let mut paired = false;
        while let Some(&(time_s, measurement)) = self.pending.front() {
            if time_s > last {
                break;
            }
            self.pending.pop_front();
            let Some((point_in_map, segment)) = self.map_position_at(time_s) else {
                self.stats.fixes_not_paired += 1;
                continue;
            };
            let pair = AlignmentPair::new(point_in_map, &measurement);
            // The run's fit first: its first pair sets the origin every segment's fit shares.
            if self.fit.add(&pair).is_err() {
                self.stats.fixes_not_paired += 1;
                continue;
            }
            let Some(origin) = self.fit.origin() else {
                continue;
            };
            let Segment { fit, span, .. } = &mut self.segments[segment];
            let fit = fit.get_or_insert_with(|| SimilarityFit2d::with_origin(origin.0, origin.1));
            // The same pair the run's fit took: it cannot be refused here.
            let _ = fit.add(&pair);
            self.stats.fixes_paired += 1;
            let [e, n] = measurement.position_in_enu_m;
            for span in [&mut self.span, span] {
                let span = span.get_or_insert([e, n, e, n]);
                *span = [
                    span[0].min(e),
                    span[1].min(n),
                    span[2].max(e),
                    span[3].max(n),
                ];
            }
            if self.options.fuse_gps {
                self.fuse(time_s, &measurement, segment);
            }
            paired = true;
        }
        if paired
            && self.spans_enough(self.span)
            && let Ok(alignment) = self.fit.solve()
        {
            self.alignment = Some(alignment);
        }
    }

    /// Fuses the fix `measurement`, taken at `time_s` and paired in `segment`, into the
    /// filter, where the filter is still in that segment and the map has been aligned.
    fn fuse(&mut self, time_s: f64, measurement: &GpsMeasurement, segment: usize) {
        if segment + 1 != self.segments.len() || self.alignment.is_none() {
            return;
        }
        let Some(alignment) = self.segment_alignment(segment) else {
            return;
        };
        if alignment.scale <= 0.0 || !alignment.scale.is_finite() {
            return;
        }
        // enu = s R(θ) map + t, so map = R(−θ) (enu − t) / s.
        let (sin, cos) = (-alignment.rotation_rad).sin_cos();
        let to_map = nalgebra::Matrix2::new(cos, -sin, sin, cos) / alignment.scale;
        let [e, n] = measurement.position_in_enu_m;
        let [te, tn] = alignment.translation_m;
        let in_map = to_map * nalgebra::Vector2::new(e - te, n - tn);
        // The map's (forward, left) is the first camera's (z, −x).
        let to_world_xz = nalgebra::Matrix2::new(0.0, -1.0, 1.0, 0.0);
        let point_xz = to_world_xz * in_map;
        let transform = to_world_xz * to_map;
        let covariance = transform * measurement.covariance_in_enu_m2 * transform.transpose();
        let point_xz = [point_xz.x, point_xz.y];
        // A degenerate segment fit gives no point to measure.
        if !(point_xz.iter().all(|v| v.is_finite()) && covariance.iter().all(|v| v.is_finite())) {
            return;
        }
        match self
            .slam
            .update_ground_position(time_s, point_xz, &covariance, FUSION_GATE_CHI2)
        {
            Some(chi2) if chi2 <= FUSION_GATE_CHI2 => self.stats.fixes_fused += 1,
            Some(_) => self.stats.fixes_gated += 1,
            None => {}
        }
    }

    /// Whether fixes with the bounding box `span` fix a similarity.
    fn spans_enough(&self, span: Option<[f64; 4]>) -> bool {
        span.is_some_and(|[e0, n0, e1, n1]| (e1 - e0).max(n1 - n0) >= self.options.alignment_span_m)
    }

    /// `enu_from_map` for segment `segment`: the fit of its fixes and those of the segments
    /// linked to it that agree with them, nearest links first, taken in until they span far
    /// enough; the fit of those taken where even all of them do not, and the fit of all
    /// fixes where those fix no similarity.
    pub fn segment_alignment(&self, segment: usize) -> Option<SimilarityAlignment2d> {
        let global = self.alignment?;
        if segment >= self.segments.len() {
            return Some(global);
        }
        let mut fit = SimilarityFit2d::default();
        let mut span: Option<[f64; 4]> = None;
        // Each segment with the change of its `map` coordinates into `segment`'s.
        let mut queue = VecDeque::from([(segment, MapFrameChange::IDENTITY)]);
        let mut seen = HashSet::from([segment]);
        let mut taken = 0;
        while !self.spans_enough(span) {
            taken += 1;
            let Some((next, change)) = queue.pop_front().filter(|_| taken <= MAX_SEGMENTS_PER_FIT)
            else {
                // Every segment in its frame taken or contradicting it, or as many as one fit
                // takes: the fit of those taken, where it fixes a similarity.
                return Some(fit.solve().unwrap_or(global));
            };
            let other = &self.segments[next];
            if let Some(other_fit) = &other.fit {
                let other_fit = if change == MapFrameChange::IDENTITY {
                    *other_fit
                } else {
                    other_fit.moved(&change)
                };
                // A segment joined through a recognised place whose frame its fixes
                // contradict: the recognition put the camera where GPS says it was not.
                if next != segment && !fit.agrees_with(&other_fit, LINK_AGREEMENT_CHI2) {
                    continue;
                }
                if fit.add_fit(&other_fit).is_err() {
                    return Some(global);
                }
            }
            if let Some([e0, n0, e1, n1]) = other.span {
                let s = span.get_or_insert([e0, n0, e1, n1]);
                *s = [s[0].min(e0), s[1].min(n0), s[2].max(e1), s[3].max(n1)];
            }
            for link in &other.links {
                if seen.insert(link.segment) {
                    queue.push_back((link.segment, change.after(&link.change)));
                }
            }
        }
        Some(fit.solve().unwrap_or(global))
    }

    /// The camera's `map` position at `time_s`, interpolated between the frames about it,
    /// and the segment of the earlier frame.
    fn map_position_at(&self, time_s: f64) -> Option<([f64; 2], usize)> {
        let (a, b, w) = self.bracket(time_s)?;
        let (pa, pb) = (self.poses[a].in_map(), self.poses[b].in_map());
        Some((
            [pa[0] + w * (pb[0] - pa[0]), pa[1] + w * (pb[1] - pa[1])],
            self.pose_segments[a] as usize,
        ))
    }

    /// The indices of the frames about `time_s` and the weight of the later one; the first
    /// or last frame alone outside them, and the earlier frame alone where the two lie in
    /// different segments (the path may jump between them). `None` without a frame within
    /// [`CameraPipelineOptions::max_frame_gap_s`] of `time_s`.
    fn bracket(&self, time_s: f64) -> Option<(usize, usize, f64)> {
        let after = self.poses.partition_point(|p| p.time_s <= time_s);
        let last = self.poses.len().checked_sub(1)?;
        let (a, b, w) = match after {
            0 => (0, 0, 0.0),
            _ if after > last => (last, last, 0.0),
            _ if self.pose_segments[after - 1] != self.pose_segments[after] => {
                (after - 1, after - 1, 0.0)
            }
            _ => {
                let (a, b) = (&self.poses[after - 1], &self.poses[after]);
                (
                    after - 1,
                    after,
                    (time_s - a.time_s) / (b.time_s - a.time_s),
                )
            }
        };
        let gap_s = (time_s - self.poses[a].time_s)
            .abs()
            .min((self.poses[b].time_s - time_s).abs());
        (gap_s <= self.options.max_frame_gap_s).then_some((a, b, w))
    }

    /// Whether poses are in the `enu` frame (the map aligned to GPS).
    pub fn is_geo_referenced(&self) -> bool {
        self.alignment.is_some()
    }

    /// The robot's pose at `time_s` (the camera's ground position and the heading of its
    /// optical axis, interpolated), in the `enu` frame once aligned, else in the `map` frame.
    pub fn pose_at(&self, time_s: f64) -> Option<Pose2> {
        let (a, b, w) = self.bracket(time_s)?;
        let ([x, y], segment) = self.map_position_at(time_s)?;
        let (ha, hb) = (
            self.poses[a].heading_in_map_rad(),
            self.poses[b].heading_in_map_rad(),
        );
        let turn = (hb - ha + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        let heading = ha + w * turn;
        Some(match &self.segment_alignment(segment) {
            Some(alignment) => {
                let [e, n] = alignment.to_enu([x, y]);
                Pose2::new(e, n, heading + alignment.rotation_rad)
            }
            None => Pose2::new(x, y, heading),
        })
    }

    /// The camera method's map points in the `enu` frame (east, north, up), each put there
    /// by the alignment of the segment whose camera came nearest to it (every tenth frame
    /// looked at), once aligned.
    pub fn map_points_in_enu(&self) -> Option<Vec<Vector3<f64>>> {
        let global = self.alignment?;
        let near: Vec<(Vector3<f64>, usize)> = self
            .poses
            .iter()
            .zip(&self.pose_segments)
            .step_by(10)
            .map(|(pose, &segment)| (pose.position, segment as usize))
            .collect();
        let mut alignments: Vec<Option<SimilarityAlignment2d>> = vec![None; self.segments.len()];
        let points = self
            .slam
            .map_points()
            .into_iter()
            .map(|point| {
                let segment = near
                    .iter()
                    .min_by(|a, b| {
                        (a.0 - point)
                            .norm_squared()
                            .total_cmp(&(b.0 - point).norm_squared())
                    })
                    .map(|&(_, segment)| segment);
                let alignment = match segment.and_then(|s| alignments.get_mut(s)) {
                    Some(slot) => *slot.get_or_insert_with(|| {
                        segment
                            .and_then(|s| self.segment_alignment(s))
                            .unwrap_or(global)
                    }),
                    None => global,
                };
                let ground = [point.z, -point.x];
                let [e, n] = alignment.to_enu(ground);
                Vector3::new(e, n, -point.y * alignment.scale)
            })
            .collect();
        Some(points)
    }

    /// Every frame's camera pose in the `enu` frame (east, north, and up from the first
    /// camera's height), each by its segment's alignment, once aligned.
    pub fn trajectory_in_enu(&self) -> Option<Vec<CameraPose>> {
        let global = self.alignment?;
        // The first camera's axes (right, down, forward) to the map's (forward, left, up),
        // then turned about up into east and north.
        let map_from_camera =
            UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(
                nalgebra::Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
            ));
        let mut alignments: Vec<Option<SimilarityAlignment2d>> = Vec::new();
        let mut poses = Vec::with_capacity(self.poses.len());
        for (pose, &segment) in self.poses.iter().zip(&self.pose_segments) {
            let segment = segment as usize;
            if segment >= alignments.len() {
                alignments.resize(segment + 1, None);
            }
            let alignment = *alignments[segment]
                .get_or_insert_with(|| self.segment_alignment(segment).unwrap_or(global));
            let enu_from_camera =
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), alignment.rotation_rad)
                    * map_from_camera;
            let [e, n] = alignment.to_enu(pose.in_map());
            poses.push(CameraPose {
                time_s: pose.time_s,
                position: Vector3::new(e, n, -pose.position.y * alignment.scale),
                orientation: enu_from_camera * pose.orientation,
            });
        }
        Some(poses)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_frame_is_forward_and_left_of_the_first_camera() {
        // A camera 2 forward and 1 to the right of the first, turned 90° to its left (about
        // the camera's −y axis, which points up).
        let pose = CameraPose {
            time_s: 0.0,
            position: Vector3::new(1.0, 0.0, 2.0),
            orientation: UnitQuaternion::from_axis_angle(
                &-Vector3::y_axis(),
                std::f64::consts::FRAC_PI_2,
            ),
        };
        assert_eq!(pose.in_map(), [2.0, -1.0]);
        assert!((pose.heading_in_map_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn a_recognised_place_s_jump_moves_the_map_frame_as_it_moves_the_camera() {
        // The map frame turned 30° to the left about the vertical and shifted: the camera's
        // pose before the jump, taken through it, is its pose after, in the map frame too.
        let rotation = UnitQuaternion::from_axis_angle(&-Vector3::y_axis(), 30f64.to_radians());
        let jump = (Vector3::new(0.5, 0.0, -2.0), rotation);
        let before = CameraPose {
            time_s: 0.0,
            position: Vector3::new(-3.0, 0.0, 7.0),
            orientation: UnitQuaternion::from_axis_angle(&-Vector3::y_axis(), 0.2),
        };
        let after = CameraPose {
            time_s: 0.0,
            position: jump.1 * before.position + jump.0,
            orientation: jump.1 * before.orientation,
        };
        let change = map_frame_change(&jump);
        let moved = change.apply(before.in_map());
        let expected = after.in_map();
        assert!((moved[0] - expected[0]).abs() < 1e-12 && (moved[1] - expected[1]).abs() < 1e-12);
        let turn = change.turn_scale[1].atan2(change.turn_scale[0]);
        let heading_change = after.heading_in_map_rad() - before.heading_in_map_rad();
        assert!(
            (turn - heading_change).abs() < 1e-12,
            "{turn} {heading_change}"
        );
        assert!((change.turn_scale[0].hypot(change.turn_scale[1]) - 1.0).abs() < 1e-12);
    }
}
