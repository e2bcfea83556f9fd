//! Method 1 as one type: time-ordered drive inputs, landmark observations and GPS fixes in;
//! the EKF with local maps and the history memory ([`SubmapSlam`]), the map aligned to GPS and
//! then updated by it ([`GpsAnchor`]), and at the end the trajectory estimated again against
//! the finished map ([`MapSmoother`]); poses, trajectory and landmarks out.
//!
//! Every adapter drives this type: the board link's events through [`super::EkfPipeline`]
//! (trees found in each scan, no odometry: [`super::ConstantVelocityModel`]) in the daemon,
//! its replays and the seeded runs, and the Victoria Park logs (tree detections and car
//! odometry: [`super::AckermannModel`]) in `hil-sim replay-victoria`.
//!
//! Each event first moves the filter to its time with the latest drive input (a step longer
//! than [`LandmarkSlamOptions::max_predict_s`] is cut to it: a gap in the data is not driven
//! through blind), then applies itself. An event older than the last is not used.

use nalgebra::{Matrix2, Matrix3};

use super::frames::compose_pose;
use super::{
    GpsAnchor, GpsAnchorOptions, GpsOutcome, LandmarkObservation, MapSmoother, MapSmootherOptions,
    MapSmootherStats, MappedLandmark, MotionModel, RangeBearingModel, SubmapSlam,
    SubmapSlamOptions,
};
use crate::geometry::Pose2;

/// How the method runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkSlamOptions {
    /// The filter, its local maps and the history memory.
    pub slam: SubmapSlamOptions,
    /// GPS alignment and fusion.
    pub gps: GpsAnchorOptions,
    /// The GPS antenna's position on the robot, `[x_m, y_m]`.
    pub antenna_in_robot: [f64; 2],
    /// The longest step predicted at once, seconds.
    pub max_predict_s: f64,
    /// The pose the trajectory reports, in the robot frame (e.g. the laser's); the robot's own
    /// when `None`.
    pub reported_in_robot: Option<Pose2>,
    /// Estimate the trajectory again against the finished map when the run ends. The pass
    /// holds the motion model's own entries at their final values, so it suits a model whose
    /// entries are constants (odometry calibration), not one whose entries move (velocity).
    pub smooth: bool,
    /// The smoothing pass.
    pub smoother: MapSmootherOptions,
    /// Keep the pose of every observation batch ([`LandmarkSlam::online_trajectory`]). Off
    /// where the caller keeps the poses itself, bounded, as a run without an end needs
    /// ([`super::EkfPipeline`] with [`super::PoseHistory`]); smoothing keeps it regardless.
    pub keep_trajectory: bool,
}

impl Default for LandmarkSlamOptions {
    fn default() -> Self {
        LandmarkSlamOptions {
            slam: SubmapSlamOptions::default(),
            gps: GpsAnchorOptions::default(),
            antenna_in_robot: [0.0; 2],
            max_predict_s: f64::INFINITY,
            reported_in_robot: None,
            smooth: true,
            smoother: MapSmootherOptions::default(),
            keep_trajectory: true,
        }
    }
}

/// A reported pose at a time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedPose {
    /// The event's time, seconds.
    pub t_s: f64,
    /// The reported pose in the map frame.
    pub pose_in_map: Pose2,
}

/// An event as the smoothing pass replays it.
#[derive(Debug, Clone)]
enum Kept<I> {
    Input(I),
    Observations(Vec<LandmarkObservation>),
    Fix([f64; 2], Matrix2<f64>),
}

/// Method 1 over time-ordered events. See the [module documentation](self).
#[derive(Debug)]
pub struct LandmarkSlam<M: MotionModel> {
    slam: SubmapSlam<M>,
    anchor: GpsAnchor,
    motion: M,
    sensor: RangeBearingModel,
    options: LandmarkSlamOptions,
    input: M::Input,
    last_t_s: Option<f64>,
    /// Every event used, for the smoothing pass.
    kept: Vec<(f64, Kept<M::Input>)>,
    /// The pose at each observation batch as estimated at the time.
    online: Vec<TimedPose>,
    /// The same poses estimated again, once [`LandmarkSlam::finish`] ran.
    smoothed: Option<(Vec<TimedPose>, MapSmootherStats)>,
}

impl<M: MotionModel + Clone> LandmarkSlam<M>
where
    M::Input: Default,
{
    /// The method with `motion` and `sensor` models, the robot at the map's origin.
    pub fn new(motion: M, sensor: RangeBearingModel, options: LandmarkSlamOptions) -> Self {
        LandmarkSlam {
            slam: SubmapSlam::new(motion.clone(), sensor, options.slam, Pose2::IDENTITY),
            anchor: GpsAnchor::new(options.gps),
            motion,
            sensor,
            options,
            input: M::Input::default(),
            last_t_s: None,
            kept: Vec::new(),
            online: Vec::new(),
            smoothed: None,
        }
    }

    /// Sets the run's start time: the first event is predicted from it. Without it, the first
    /// event's time starts the run.
    pub fn start_at(&mut self, t_s: f64) {
        if self.last_t_s.is_none() {
            self.last_t_s = Some(t_s);
        }
    }

    /// A drive input at `t_s`, held until the next one. Whether it was used (not older than
    /// the last event).
    pub fn on_input(&mut self, t_s: f64, input: M::Input) -> bool {
        if !self.advance(t_s) {
            return false;
        }
        if self.options.smooth {
            self.kept.push((t_s, Kept::Input(input)));
        }
        self.input = input;
        true
    }

    /// One batch of landmark observations (one scan) at `t_s`. Whether it was used.
    pub fn on_observations(&mut self, t_s: f64, observations: &[LandmarkObservation]) -> bool {
        if !self.advance(t_s) {
            return false;
        }
        self.slam.observe(observations);
        if self.options.smooth {
            self.kept
                .push((t_s, Kept::Observations(observations.to_vec())));
        }
        if self.options.keep_trajectory || self.options.smooth {
            self.online.push(TimedPose {
                t_s,
                pose_in_map: self.reported_pose(),
            });
        }
        true
    }

    /// A GPS fix at `t_s`: `fix_in_enu` (metres in the local frame at the datum) with
    /// covariance `noise_m2`. `None` when it is older than the last event.
    pub fn on_fix(
        &mut self,
        t_s: f64,
        fix_in_enu: [f64; 2],
        noise_m2: &Matrix2<f64>,
    ) -> Option<GpsOutcome> {
        if !self.advance(t_s) {
            return None;
        }
        let outcome = self.anchor.on_fix(
            &mut self.slam,
            fix_in_enu,
            noise_m2,
            self.options.antenna_in_robot,
        );
        if let GpsOutcome::Aligned(enu_from_map) = outcome {
            for timed in &mut self.online {
                timed.pose_in_map = compose_pose(enu_from_map, timed.pose_in_map).0;
            }
        }
        if self.options.smooth {
            self.kept.push((t_s, Kept::Fix(fix_in_enu, *noise_m2)));
        }
        Some(outcome)
    }

    /// Ends the run: the last local map is joined, and the trajectory is estimated again
    /// against the finished map when [`LandmarkSlamOptions::smooth`]. Later events are still
    /// filtered, but the trajectory stays the finished one.
    pub fn finish(&mut self) {
        if self.smoothed.is_some() {
            return;
        }
        self.slam.close_last_local_map();
        if self.options.smooth {
            self.smoothed = Some(self.smoothed_trajectory());
        }
    }

    /// The trajectory: one pose per observation batch, smoothed once the run is finished (if
    /// smoothing is on), else as estimated at the time.
    pub fn trajectory(&self) -> &[TimedPose] {
        match &self.smoothed {
            Some((smoothed, _)) => smoothed,
            None => &self.online,
        }
    }

    /// The trajectory as estimated at each batch (re-expressed once aligned to GPS).
    pub fn online_trajectory(&self) -> &[TimedPose] {
        &self.online
    }

    /// What the smoothing pass did, once it ran.
    pub fn smoother_stats(&self) -> Option<MapSmootherStats> {
        self.smoothed.as_ref().map(|(_, stats)| *stats)
    }

    /// The robot's pose in the map frame and its covariance.
    pub fn pose(&self) -> (Pose2, Matrix3<f64>) {
        self.slam.pose_in_map()
    }

    /// The pose the trajectory reports now (the robot's, or that of
    /// [`LandmarkSlamOptions::reported_in_robot`]) in the map frame.
    pub fn reported_pose(&self) -> Pose2 {
        self.reported(self.slam.pose_in_map().0)
    }

    /// Whether the map frame is the local frame at the GPS datum.
    pub fn is_aligned(&self) -> bool {
        self.anchor.is_aligned()
    }

    /// The mapped landmarks (global map and current local map) in the map frame.
    pub fn landmarks_in_map(&self) -> Vec<MappedLandmark> {
        self.slam.landmarks_in_map()
    }

    /// The filter, for its counters and maps.
    pub fn slam(&self) -> &SubmapSlam<M> {
        &self.slam
    }

    /// The GPS alignment and fusion, for its counters.
    pub fn anchor(&self) -> &GpsAnchor {
        &self.anchor
    }

    /// Moves the filter to `t_s` with the held input, for an event that brings nothing else
    /// (a fix without a usable position); false if `t_s` is older than the last event.
    pub fn advance_to(&mut self, t_s: f64) -> bool {
        self.advance(t_s)
    }

    /// Predicts to `t_s` with the held input; false if `t_s` is older than the last event.
    fn advance(&mut self, t_s: f64) -> bool {
        if let Some(last) = self.last_t_s {
            let dt_s = t_s - last;
            if dt_s < 0.0 {
                return false;
            }
            self.slam
                .predict(&self.input, dt_s.min(self.options.max_predict_s));
        }
        self.last_t_s = Some(t_s);
        true
    }

    /// `robot_in_map` as the trajectory reports it.
    fn reported(&self, robot_in_map: Pose2) -> Pose2 {
        match self.options.reported_in_robot {
            Some(in_robot) => compose_pose(robot_in_map, in_robot).0,
            None => robot_in_map,
        }
    }

    /// The pose at each observation batch, estimated again against the finished map,
    /// forwards and backwards ([`MapSmoother`]). The start is the first local map's base,
    /// fitted to where the final map puts its landmarks.
    fn smoothed_trajectory(&self) -> (Vec<TimedPose>, MapSmootherStats) {
        let slam = &self.slam;
        let landmarks = slam.landmarks_in_map();
        let start = slam
            .first_local_map_base_in_map()
            .or_else(|| slam.global_map().bases_in_map().first().copied())
            .unwrap_or_default();
        let mut robot = slam.robot_in_local_map();
        robot.as_mut_slice()[..3].copy_from_slice(&[start.x_m, start.y_m, start.theta_rad]);
        let mut smoother = MapSmoother::new(
            &self.motion,
            self.sensor,
            self.options.smoother,
            &landmarks,
            robot,
            Matrix3::identity() * 1e-6,
        );
        // The fixes are in the `enu` frame; the map is too once they aligned it.
        let use_fixes = self.anchor.is_aligned();
        let mut input = M::Input::default();
        let mut last_t_s = self.kept.first().map_or(0.0, |e| e.0);
        let mut epochs = Vec::with_capacity(self.online.len());
        for (t_s, event) in &self.kept {
            smoother.predict(&input, (t_s - last_t_s).min(self.options.max_predict_s));
            last_t_s = *t_s;
            match event {
                Kept::Input(held) => input = *held,
                Kept::Observations(observations) => {
                    epochs.push((*t_s, smoother.observe(observations)));
                }
                Kept::Fix(fix_in_enu, noise_m2) if use_fixes => {
                    smoother.observe_position(
                        *fix_in_enu,
                        self.options.antenna_in_robot,
                        noise_m2,
                        self.options.gps.gate_distance2,
                    );
                }
                Kept::Fix(..) => {}
            }
        }
        let poses = smoother.smooth();
        let trajectory = epochs
            .into_iter()
            .map(|(t_s, epoch)| TimedPose {
                t_s,
                pose_in_map: self.reported(poses[epoch]),
            })
            .collect();
        (trajectory, smoother.stats())
    }
}
