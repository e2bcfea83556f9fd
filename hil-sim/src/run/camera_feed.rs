//! The robot's camera in a run: frames rendered at the true pose of each frame's time, at a
//! set rate, handed straight to the robot computer (a camera plugs into it, not into the
//! board), stamped on its clock.

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
}

impl Default for CameraRunOptions {
    /// 10 frames a second, no walkers, the default rig.
    fn default() -> Self {
        CameraRunOptions {
            rate_hz: 10.0,
            movers: 0,
            rig: CameraRigOptions::default(),
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
}

/// Renders the frames as the run's clock reaches their times.
#[derive(Debug)]
pub struct CameraFeed {
    view: CameraView,
    walkers: Walkers,
    period_us: f64,
    next_frame: u64,
}

impl CameraFeed {
    /// The camera of `options` in `scenario`'s world, its first frame at time 0.
    pub fn new(scenario: &Scenario, options: &CameraRunOptions, seed: u64) -> Self {
        CameraFeed {
            view: CameraView::new(scenario, options.rig),
            walkers: Walkers::new(scenario, options.movers, seed),
            period_us: 1e6 / options.rate_hz,
            next_frame: 0,
        }
    }

    /// The camera.
    pub fn camera(&self) -> &host::camera::PinholeCamera {
        self.view.camera()
    }

    /// The next frame if its time is at or before `t_us`, the robot moving along
    /// `trajectory`.
    pub fn due(&mut self, t_us: u64, trajectory: &Trajectory) -> Option<CameraFrame> {
        let at_us = self.next_frame as f64 * self.period_us;
        if at_us > t_us as f64 {
            return None;
        }
        let t_s = at_us * 1e-6;
        let state = trajectory.pose_at(t_s);
        let image = self
            .view
            .render(&state, &self.walkers.at(t_s), self.next_frame);
        let (position_m, orientation) = self.view.camera_pose(&state);
        self.next_frame += 1;
        Some(CameraFrame {
            t_s,
            image,
            position_m,
            orientation,
        })
    }
}
