//! A complete seeded simulation: a generated world, its landmarks, a geodetic datum, and the
//! robot's true trajectory round the world's route.
//!
//! [`Scenario::generate`] is deterministic: the same kind and seed give the same shapes,
//! landmarks, datum and trajectory, bit for bit (on one platform and build). The layout
//! comes from [`super::indoor`] or [`super::outdoor`]; the robot drives its route with
//! [`PurePursuit::indoor`] or [`PurePursuit::outdoor`], lap after lap, for
//! [`DEFAULT_DURATION_S`] (ten minutes, several laps); [`Scenario::pose_at`] holds the last
//! state after that.
//!
//! Text exports, tab-separated, numbers in Rust's shortest round-trip notation (metres),
//! header lines starting with `#`:
//!
//! * [`Scenario::write_landmarks_tsv`]: `id  x_m  y_m  radius_m`, one landmark per line;
//! * [`Scenario::write_world_tsv`]: one shape per line, either
//!   `segment  ax_m  ay_m  bx_m  by_m` or `circle  x_m  y_m  radius_m`;
//! * [`Scenario::write_trajectory_tsv`]: `t_s  x_m  y_m  theta_rad  speed_mps  yaw_rate_radps`.

use core::fmt;
use core::str::FromStr;
use std::io::{self, Write};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::geo::GeoDatum;
use super::landmark::Landmark;
use super::pose::SensorPose;
use super::pure_pursuit::PurePursuit;
use super::robot_state::RobotState;
use super::route::Route;
use super::shape::Shape;
use super::shape_world::ShapeWorld;
use super::trajectory::Trajectory;
use super::{indoor, outdoor};

/// Length of the trajectory [`Scenario::generate`] computes, seconds.
pub const DEFAULT_DURATION_S: f64 = 600.0;

/// Seed offset of the random stream that picks the datum, so the datum and the layout do not
/// share random numbers.
const DATUM_STREAM: u64 = 0x6765_6f64_6174_756d;

/// Which world generator to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum WorldKind {
    /// An office floor with a corridor loop ([`super::indoor`]); written `indoor`.
    Indoor,
    /// A park with trees along a looping path ([`super::outdoor`]); written `outdoor`.
    Outdoor,
}

impl fmt::Display for WorldKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            WorldKind::Indoor => "indoor",
            WorldKind::Outdoor => "outdoor",
        })
    }
}

impl FromStr for WorldKind {
    type Err = ParseWorldKindError;

    /// Parses `indoor` or `outdoor` (exactly, lower case).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "indoor" => Ok(WorldKind::Indoor),
            "outdoor" => Ok(WorldKind::Outdoor),
            _ => Err(ParseWorldKindError {
                input: s.to_owned(),
            }),
        }
    }
}

/// A string that names no [`WorldKind`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseWorldKindError {
    input: String,
}

impl fmt::Display for ParseWorldKindError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown world kind {:?}: expected \"indoor\" or \"outdoor\"",
            self.input
        )
    }
}

impl std::error::Error for ParseWorldKindError {}

/// A generated world and the robot's true motion through it. See the
/// [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    kind: WorldKind,
    seed: u64,
    world: ShapeWorld,
    heights_m: Vec<f64>,
    landmarks: Vec<Landmark>,
    datum: GeoDatum,
    route: Route,
    trajectory: Trajectory,
}

impl Scenario {
    /// The scenario of `kind` for `seed`, with a ten-minute trajectory.
    pub fn generate(kind: WorldKind, seed: u64) -> Scenario {
        Scenario::generate_for(kind, seed, DEFAULT_DURATION_S)
    }

    /// The scenario of `kind` for `seed`, with a trajectory of `duration_s` seconds.
    pub fn generate_for(kind: WorldKind, seed: u64, duration_s: f64) -> Scenario {
        let (layout, controller) = match kind {
            WorldKind::Indoor => (indoor::generate(seed), PurePursuit::indoor()),
            WorldKind::Outdoor => (outdoor::generate(seed), PurePursuit::outdoor()),
        };
        let trajectory = controller.drive(&layout.route, duration_s);
        Scenario {
            kind,
            seed,
            world: ShapeWorld::new(layout.shapes),
            heights_m: layout.heights_m,
            landmarks: layout.landmarks,
            datum: datum(kind, seed),
            route: layout.route,
            trajectory,
        }
    }

    /// The generator used.
    pub fn kind(&self) -> WorldKind {
        self.kind
    }

    /// The seed used.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The obstacles, ready for ray casting.
    pub fn world(&self) -> &ShapeWorld {
        &self.world
    }

    /// Each obstacle's height, metres, in the order of [`ShapeWorld::shapes`].
    pub fn heights_m(&self) -> &[f64] {
        &self.heights_m
    }

    /// The landmarks (trees outdoors, pillars indoors), by id.
    pub fn landmarks(&self) -> &[Landmark] {
        &self.landmarks
    }

    /// Where the world frame's origin lies on the Earth.
    pub fn datum(&self) -> GeoDatum {
        self.datum
    }

    /// The loop the robot drives.
    pub fn route(&self) -> &Route {
        &self.route
    }

    /// The robot's true motion, sampled at a fixed step.
    pub fn trajectory(&self) -> &Trajectory {
        &self.trajectory
    }

    /// Time covered by the trajectory, seconds.
    pub fn duration_s(&self) -> f64 {
        self.trajectory.duration_s()
    }

    /// The robot's true state at `t_s` seconds (see [`Trajectory::pose_at`]).
    pub fn pose_at(&self, t_s: f64) -> RobotState {
        self.trajectory.pose_at(t_s)
    }

    /// The laser's true pose at `t_s` seconds: at the robot origin, facing forward.
    pub fn sensor_pose_at(&self, t_s: f64) -> SensorPose {
        self.pose_at(t_s).sensor_pose()
    }

    /// Writes the landmarks as `id x_m y_m radius_m` lines (see the
    /// [module documentation](self)).
    ///
    /// # Errors
    ///
    /// Any error of `w`.
    pub fn write_landmarks_tsv(&self, mut w: impl Write) -> io::Result<()> {
        writeln!(w, "# {} world, seed {}", self.kind, self.seed)?;
        writeln!(w, "# id\tx_m\ty_m\tradius_m")?;
        for l in &self.landmarks {
            writeln!(
                w,
                "{}\t{}\t{}\t{}",
                l.id, l.center_m[0], l.center_m[1], l.radius_m
            )?;
        }
        Ok(())
    }

    /// Writes the shapes, one per line (see the [module documentation](self)).
    ///
    /// # Errors
    ///
    /// Any error of `w`.
    pub fn write_world_tsv(&self, mut w: impl Write) -> io::Result<()> {
        writeln!(w, "# {} world, seed {}", self.kind, self.seed)?;
        writeln!(w, "# segment\tax_m\tay_m\tbx_m\tby_m")?;
        writeln!(w, "# circle\tx_m\ty_m\tradius_m")?;
        for shape in self.world.shapes() {
            match *shape {
                Shape::Segment { a_m, b_m } => {
                    writeln!(w, "segment\t{}\t{}\t{}\t{}", a_m[0], a_m[1], b_m[0], b_m[1])?
                }
                Shape::Circle { center_m, radius_m } => {
                    writeln!(w, "circle\t{}\t{}\t{}", center_m[0], center_m[1], radius_m)?
                }
            }
        }
        Ok(())
    }

    /// Writes the true state every `period_s` seconds from 0 to the end of the trajectory
    /// (see the [module documentation](self)).
    ///
    /// # Errors
    ///
    /// Any error of `w`.
    ///
    /// # Panics
    ///
    /// If `period_s` is not positive.
    pub fn write_trajectory_tsv(&self, mut w: impl Write, period_s: f64) -> io::Result<()> {
        assert!(period_s > 0.0, "period must be positive");
        writeln!(w, "# {} world, seed {}", self.kind, self.seed)?;
        writeln!(w, "# t_s\tx_m\ty_m\ttheta_rad\tspeed_mps\tyaw_rate_radps")?;
        let samples = (self.duration_s() / period_s).floor() as u64;
        for i in 0..=samples {
            let t_s = i as f64 * period_s;
            let s = self.pose_at(t_s);
            writeln!(
                w,
                "{t_s}\t{}\t{}\t{}\t{}\t{}",
                s.x_m, s.y_m, s.theta_rad, s.speed_mps, s.yaw_rate_radps
            )?;
        }
        Ok(())
    }
}

/// The datum for `kind` and `seed`: indoors the default datum; outdoors a park near Munich,
/// moved by up to about a kilometre and 10 m of altitude by the seed.
fn datum(kind: WorldKind, seed: u64) -> GeoDatum {
    match kind {
        WorldKind::Indoor => GeoDatum::default(),
        WorldKind::Outdoor => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ DATUM_STREAM);
            GeoDatum {
                lat_deg: 48.150_0 + rng.random_range(-0.01..0.01),
                lon_deg: 11.570_0 + rng.random_range(-0.015..0.015),
                alt_m: 520.0 + rng.random_range(-10.0..10.0),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::range_model::beam_bearing_rad;
    use crate::world::{Room, World};
    use rand::RngExt;

    const INDOOR_CLEARANCE_M: f64 = 0.6;
    const OUTDOOR_CLEARANCE_M: f64 = 1.5;

    /// Arc length driven by the end of each sample, metres.
    fn odometer_m(trajectory: &Trajectory) -> Vec<f64> {
        let states = trajectory.states();
        let mut total_m = 0.0;
        let mut out = vec![0.0];
        for pair in states.windows(2) {
            total_m += (pair[1].x_m - pair[0].x_m).hypot(pair[1].y_m - pair[0].y_m);
            out.push(total_m);
        }
        out
    }

    #[test]
    fn kind_names() {
        for kind in [WorldKind::Indoor, WorldKind::Outdoor] {
            assert_eq!(kind.to_string().parse::<WorldKind>(), Ok(kind));
        }
        let err = "Outdoors".parse::<WorldKind>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown world kind \"Outdoors\": expected \"indoor\" or \"outdoor\""
        );
    }

    #[test]
    fn same_seed_same_scenario_other_seed_differs() {
        for kind in [WorldKind::Indoor, WorldKind::Outdoor] {
            let a = Scenario::generate_for(kind, 42, 60.0);
            let b = Scenario::generate_for(kind, 42, 60.0);
            let c = Scenario::generate_for(kind, 43, 60.0);
            assert_eq!(a, b);
            assert_ne!(a.world().shapes(), c.world().shapes());
            assert_ne!(a.trajectory(), c.trajectory());
            assert_ne!(a.route(), c.route());
        }
    }

    #[test]
    fn route_keeps_clear_of_every_shape() {
        let cases = (0..12)
            .map(|seed| (WorldKind::Indoor, seed, INDOOR_CLEARANCE_M))
            .chain((0..6).map(|seed| (WorldKind::Outdoor, seed, OUTDOOR_CLEARANCE_M)));
        for (kind, seed, min_m) in cases {
            let scenario = Scenario::generate(kind, seed);
            let trajectory = scenario.trajectory();
            // Every 0.05 s: 4 cm apart at the top outdoor speed.
            for state in trajectory.states().iter().step_by(5) {
                let clearance_m = scenario.world().clearance_m(state.position_m());
                assert!(
                    clearance_m >= min_m,
                    "{kind} seed {seed}: {clearance_m:.3} m at {state:?}"
                );
            }
        }
    }

    #[test]
    fn drives_whole_laps_and_comes_back_to_the_start() {
        for kind in [WorldKind::Indoor, WorldKind::Outdoor] {
            for seed in 0..4 {
                let scenario = Scenario::generate(kind, seed);
                let states = scenario.trajectory().states();
                let odometer_m = odometer_m(scenario.trajectory());
                let lap_m = scenario.route().length_m();
                let total_m = odometer_m[odometer_m.len() - 1];
                assert!(total_m >= 2.0 * lap_m, "{kind} seed {seed}: {total_m} m");
                let start = states[0].position_m();
                let back = states.iter().zip(&odometer_m).any(|(s, &driven_m)| {
                    driven_m > lap_m / 2.0 && (s.x_m - start[0]).hypot(s.y_m - start[1]) < 1.0
                });
                assert!(back, "{kind} seed {seed}");
            }
        }
    }

    #[test]
    fn ray_cast_matches_brute_force_in_generated_worlds() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for kind in [WorldKind::Indoor, WorldKind::Outdoor] {
            let scenario = Scenario::generate_for(kind, 5, 300.0);
            let brute = scenario
                .world()
                .shapes()
                .iter()
                .fold(Room::empty(), |room, &shape| room.with_shape(shape));
            let (min_m, max_m) = scenario.world().bounds_m();
            for i in 0..3000 {
                let origin = if i % 2 == 0 {
                    scenario.pose_at(rng.random_range(0.0..300.0)).position_m()
                } else {
                    [
                        rng.random_range(min_m[0] - 5.0..max_m[0] + 5.0),
                        rng.random_range(min_m[1] - 5.0..max_m[1] + 5.0),
                    ]
                };
                let angle = rng.random_range(-4.0..4.0);
                assert_eq!(
                    scenario.world().ray_cast(origin, angle, 80.0),
                    brute.ray_cast(origin, angle, 80.0),
                    "{kind}: origin {origin:?} angle {angle}"
                );
            }
        }
    }

    #[test]
    fn indoor_laser_sees_walls_nearby() {
        for seed in 0..6 {
            let scenario = Scenario::generate(WorldKind::Indoor, seed);
            let mut t_s = 0.0;
            while t_s <= scenario.duration_s() {
                let pose = scenario.sensor_pose_at(t_s);
                let seen = (0..361)
                    .filter(|i| {
                        let angle = pose.world_angle_rad(beam_bearing_rad(i * 50));
                        scenario
                            .world()
                            .ray_cast(pose.position_m(), angle, 30.0)
                            .is_some()
                    })
                    .count();
                assert!(seen >= 330, "seed {seed} t {t_s}: {seen} of 361 beams");
                t_s += 5.0;
            }
        }
    }

    #[test]
    fn outdoor_landmarks_and_geodetic_datum() {
        let scenario = Scenario::generate_for(WorldKind::Outdoor, 9, 10.0);
        assert!(scenario.landmarks().len() >= 150);
        let datum = scenario.datum();
        assert!((47.0..49.0).contains(&datum.lat_deg) && (11.0..12.0).contains(&datum.lon_deg));
        let [x_m, y_m] = scenario.pose_at(0.0).position_m();
        let (lat_deg, lon_deg, _) = datum.to_geodetic(x_m, y_m, 0.0);
        assert!(lat_deg > datum.lat_deg && lon_deg > datum.lon_deg);
    }

    #[test]
    fn text_exports() {
        let scenario = Scenario::generate_for(WorldKind::Outdoor, 1, 20.0);
        let mut out = Vec::new();
        scenario.write_landmarks_tsv(&mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(rows.len(), scenario.landmarks().len());
        let first: Vec<f64> = rows[0].split('\t').map(|v| v.parse().unwrap()).collect();
        let l = scenario.landmarks()[0];
        assert_eq!(
            first,
            [f64::from(l.id), l.center_m[0], l.center_m[1], l.radius_m]
        );

        let mut out = Vec::new();
        scenario.write_world_tsv(&mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(rows.len(), scenario.world().shapes().len());
        assert!(rows.iter().all(|r| {
            let fields = r.split('\t').count();
            (r.starts_with("segment\t") && fields == 5)
                || (r.starts_with("circle\t") && fields == 4)
        }));

        let mut out = Vec::new();
        scenario.write_trajectory_tsv(&mut out, 1.0).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(text.lines().filter(|l| !l.starts_with('#')).count(), 21);
    }

    /// Times full 361-beam scans in the park; run with
    /// `cargo test --release -p hil-sim scan_timing -- --ignored --nocapture`.
    #[test]
    #[ignore = "timing; meaningful in release builds only"]
    fn scan_timing() {
        let scenario = Scenario::generate(WorldKind::Outdoor, 1);
        let scans = 1000;
        let start = std::time::Instant::now();
        let mut hits = 0usize;
        for k in 0..scans {
            let pose = scenario.sensor_pose_at(f64::from(k) * 0.5);
            for i in 0..361 {
                let angle = pose.world_angle_rad(beam_bearing_rad(i * 50));
                hits += usize::from(
                    scenario
                        .world()
                        .ray_cast(pose.position_m(), angle, 80.0)
                        .is_some(),
                );
            }
        }
        let per_scan = start.elapsed() / scans;
        println!(
            "{} shapes: {per_scan:?} per 361-beam scan, {hits} hits",
            scenario.world().shapes().len()
        );
        assert!(per_scan < std::time::Duration::from_millis(1));
    }
}
