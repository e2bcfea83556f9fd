//! The robot's camera in a run: frames rendered at the true pose of each frame's time, at a
//! set rate, handed straight to the robot computer (a camera plugs into it, not into the
//! board), stamped on its clock.

use std::io;
use std::sync::mpsc::{self, Receiver};
use std::thread;
use std::time::Instant;

use host::camera::{ForwardMotionPrior, LevelPrior, PinholeCamera};
use image::GrayImage;
use nalgebra::{UnitQuaternion, Vector3};

use crate::world::{CameraRigOptions, CameraView, Scenario, Trajectory, Walkers};

/// The camera of a run.
#[derive(Clone, Copy, Debug)]
pub struct CameraRunOptions {
    /// Frames per second.
    pub rate_hz: f64,
    /// Walkers about the route.
    pub movers: usize,
    /// The camera and how it is mounted.
    pub rig: CameraRigOptions,
    /// How the camera method holds the camera level (`None`: it does not).
    pub level: Option<LevelPrior>,
    /// How the camera method holds the camera's motion to its optical axis (`None`: it
    /// does not).
    pub forward_motion: Option<ForwardMotionPrior>,
    /// Whether the camera method fuses the GPS fixes into its filter
    /// ([`host::camera::CameraPipelineOptions::fuse_gps`]).
    pub fuse_gps: bool,
}

impl Default for CameraRunOptions {
    /// 10 frames a second, no walkers, the default rig, held as the robot's camera pipeline
    /// holds it by default.
    fn default() -> Self {
        CameraRunOptions {
            rate_hz: 10.0,
            movers: 0,
            rig: CameraRigOptions::default(),
            level: host::camera::CameraPipelineOptions::default().slam.level,
            forward_motion: host::camera::CameraPipelineOptions::default()
                .slam
                .forward_motion,
            fuse_gps: host::camera::CameraPipelineOptions::default().fuse_gps,
        }
    }
}

/// One frame and the camera's true pose when it was taken.
#[derive(Debug)]
pub struct CameraFrame {
    /// Time of the frame (the run's clock), s.
    pub t_s: f64,
    pub image: GrayImage,
    /// The camera's true position, world frame (east, north, up), m.
    pub position_m: Vector3<f64>,
    /// The camera's true `world_from_camera`.
    pub orientation: UnitQuaternion<f64>,
    /// The wall-clock instant the run took it (its clock reached the frame's time): on a
    /// run paced at the wall clock, when the camera took it.
    pub taken_at: Instant,
}

/// Frames rendered ahead of the run's clock, at most this many.
const RENDERED_AHEAD: usize = 3;

/// The frames of a run, in order. A thread of its own renders them ahead of the run's clock
/// (what a frame shows depends only on the route, the walkers and its time), so rendering
/// runs beside the chain rather than in its steps; the run takes each frame when its clock
/// reaches the frame's time.
#[derive(Debug)]
pub struct CameraFeed {
    camera: PinholeCamera,
    level: Option<LevelPrior>,
    forward_motion: Option<ForwardMotionPrior>,
    fuse_gps: bool,
    period_us: f64,
    next_frame: u64,
    /// The renderer's frames; it stops when this end is dropped.
    frames: Receiver<CameraFrame>,
}

impl CameraFeed {
    /// The camera of `options` in `scenario`'s world, its first frame at time 0.
    ///
    /// # Errors
    /// The renderer's thread cannot be started.
    pub fn new(scenario: &Scenario, options: &CameraRunOptions, seed: u64) -> io::Result<Self> {
        let view = CameraView::new(scenario, options.rig);
        let walkers = Walkers::new(scenario, options.movers, seed);
        let trajectory = scenario.trajectory().clone();
        let camera = *view.camera();
        let period_us = 1e6 / options.rate_hz;
        let (tx, frames) = mpsc::sync_channel(RENDERED_AHEAD);
        thread::Builder::new()
            .name("camera-render".into())
            .spawn(move || {
                for index in 0u64.. {
                    let frame = render(&view, &walkers, &trajectory, index, period_us);
                    if tx.send(frame).is_err() {
                        break;
                    }
                }
            })?;
        Ok(CameraFeed {
            camera,
            level: options.level,
            forward_motion: options.forward_motion,
            fuse_gps: options.fuse_gps,
            period_us,
            next_frame: 0,
            frames,
        })
    }

    /// The camera.
    pub fn camera(&self) -> &host::camera::PinholeCamera {
        &self.camera
    }

    /// How the camera method holds the camera level (`None`: it does not).
    pub fn level(&self) -> Option<LevelPrior> {
        self.level
    }

    /// How the camera method holds the camera's motion to its optical axis (`None`: it
    /// does not).
    pub fn forward_motion(&self) -> Option<ForwardMotionPrior> {
        self.forward_motion
    }

    /// Whether the camera method fuses the GPS fixes into its filter.
    pub fn fuse_gps(&self) -> bool {
        self.fuse_gps
    }

    /// The next frame if its time is at or before `t_us`.
    pub fn due(&mut self, t_us: u64) -> Option<CameraFrame> {
        let at_us = self.next_frame as f64 * self.period_us;
        if at_us > t_us as f64 {
            return None;
        }
        let mut frame = self.frames.recv().ok()?;
        frame.taken_at = Instant::now();
        self.next_frame += 1;
        Some(frame)
    }
}

/// Frame `index` of a camera at `period_us`, the robot moving along `trajectory`.
fn render(
    view: &CameraView,
    walkers: &Walkers,
    trajectory: &Trajectory,
    index: u64,
    period_us: f64,
) -> CameraFrame {
    let t_s = index as f64 * period_us * 1e-6;
    let state = trajectory.pose_at(t_s);
    let image = view.render(&state, &walkers.at(t_s), index);
    let (position_m, orientation) = view.camera_pose(&state);
    CameraFrame {
        t_s,
        image,
        position_m,
        orientation,
        taken_at: Instant::now(),
    }
}
