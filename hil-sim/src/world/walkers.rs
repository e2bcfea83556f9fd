//! People walking about a seeded world, for a camera to see: each paces a straight line
//! near the robot's route, back and forth, at a walking pace.

use core::f64::consts::TAU;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::Scenario;
use super::camera_view::Mover;

/// A walker's shoulders' half width and height, m.
const WALKER_RADIUS_M: f64 = 0.25;
const WALKER_HEIGHT_M: f64 = 1.75;

/// One walker's beat: from `start_m` along `direction` for `length_m` and back.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Beat {
    start_m: [f64; 2],
    direction: [f64; 2],
    length_m: f64,
    speed_mps: f64,
    phase_m: f64,
}

/// The walkers of a world. Deterministic: the same scenario, count and seed give the same
/// walkers.
#[derive(Clone, Debug, PartialEq)]
pub struct Walkers {
    beats: Vec<Beat>,
}

impl Walkers {
    /// `count` walkers whose beats start 3–10 m to either side of `scenario`'s route.
    pub fn new(scenario: &Scenario, count: usize, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5741_4C4B_4552_5321);
        let route = scenario.route();
        let beats = (0..count)
            .map(|_| {
                let s_m = rng.random_range(0.0..route.length_m());
                let on_route = route.point_at(s_m);
                let along = route.direction_at(s_m);
                let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let offset_m = side * rng.random_range(3.0..10.0);
                let heading: f64 = rng.random_range(0.0..TAU);
                Beat {
                    start_m: [
                        on_route[0] - along[1] * offset_m,
                        on_route[1] + along[0] * offset_m,
                    ],
                    direction: [heading.cos(), heading.sin()],
                    length_m: rng.random_range(8.0..25.0),
                    speed_mps: rng.random_range(1.0..1.6),
                    phase_m: rng.random_range(0.0..50.0),
                }
            })
            .collect();
        Walkers { beats }
    }

    /// Where every walker is at `t_s`.
    pub fn at(&self, t_s: f64) -> Vec<Mover> {
        self.beats
            .iter()
            .enumerate()
            .map(|(id, beat)| {
                // Back and forth: the distance walked, folded into the beat.
                let walked = (beat.phase_m + beat.speed_mps * t_s).rem_euclid(2.0 * beat.length_m);
                let along = if walked > beat.length_m {
                    2.0 * beat.length_m - walked
                } else {
                    walked
                };
                Mover {
                    center_m: [
                        beat.start_m[0] + beat.direction[0] * along,
                        beat.start_m[1] + beat.direction[1] * along,
                    ],
                    radius_m: WALKER_RADIUS_M,
                    height_m: WALKER_HEIGHT_M,
                    id: id as u32,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::WorldKind;

    #[test]
    fn walkers_pace_their_beat_at_a_walking_pace() {
        let scenario = Scenario::generate_for(WorldKind::Outdoor, 2, 10.0);
        let walkers = Walkers::new(&scenario, 5, 9);
        assert_eq!(walkers, Walkers::new(&scenario, 5, 9));
        let (now, later) = (walkers.at(3.0), walkers.at(3.5));
        assert_eq!(now.len(), 5);
        for (a, b) in now.iter().zip(&later) {
            let moved = (a.center_m[0] - b.center_m[0]).hypot(a.center_m[1] - b.center_m[1]);
            assert!(moved <= 0.8 + 1e-9, "{moved}");
        }
        assert!(
            now.iter()
                .zip(&later)
                .any(|(a, b)| a.center_m != b.center_m)
        );
    }
}
