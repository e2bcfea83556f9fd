//! A closed loop of waypoints for a robot to drive, measured by arc length.
//!
//! The loop runs from the first waypoint through the others and back to the first. Positions
//! along it are arc lengths `s_m` in metres from the first waypoint; every query takes `s_m`
//! modulo [`Route::length_m`], so a robot going round several times keeps counting up.

/// A closed polyline through free space, world frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    /// Corners of the loop, metres.
    waypoints_m: Vec<[f64; 2]>,
    /// Arc length at each waypoint, then the total length: `waypoints_m.len() + 1` values.
    cumulative_m: Vec<f64>,
}

impl Route {
    /// The loop through `waypoints_m` and back to the first one.
    ///
    /// # Panics
    ///
    /// If there are fewer than two waypoints, or two consecutive ones (including the last and
    /// the first) coincide.
    pub fn closed(waypoints_m: Vec<[f64; 2]>) -> Route {
        assert!(waypoints_m.len() >= 2, "a route needs two waypoints");
        let mut cumulative_m = vec![0.0];
        for i in 0..waypoints_m.len() {
            let (a, b) = leg_ends(&waypoints_m, i);
            let len_m = (b[0] - a[0]).hypot(b[1] - a[1]);
            assert!(len_m > 0.0, "consecutive waypoints coincide");
            cumulative_m.push(cumulative_m[i] + len_m);
        }
        Route {
            waypoints_m,
            cumulative_m,
        }
    }

    /// The corners of the loop, starting point first.
    pub fn waypoints_m(&self) -> &[[f64; 2]] {
        &self.waypoints_m
    }

    /// Length of one lap, metres.
    pub fn length_m(&self) -> f64 {
        self.cumulative_m[self.waypoints_m.len()]
    }

    /// The point at arc length `s_m` (any value; taken modulo the lap length).
    pub fn point_at(&self, s_m: f64) -> [f64; 2] {
        let (leg, along_m) = self.locate(s_m);
        let (a, b) = leg_ends(&self.waypoints_m, leg);
        let f = along_m / self.leg_length_m(leg);
        [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]
    }

    /// Unit direction of travel at arc length `s_m`.
    pub fn direction_at(&self, s_m: f64) -> [f64; 2] {
        let (leg, _) = self.locate(s_m);
        let (a, b) = leg_ends(&self.waypoints_m, leg);
        let len_m = self.leg_length_m(leg);
        [(b[0] - a[0]) / len_m, (b[1] - a[1]) / len_m]
    }

    /// Distance in metres from `point_m` to the nearest point of the loop.
    pub fn distance_m(&self, point_m: [f64; 2]) -> f64 {
        (0..self.waypoints_m.len())
            .map(|leg| {
                let (a, b) = leg_ends(&self.waypoints_m, leg);
                super::shape_world::distance_to_segment_m(point_m, a, b)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The arc length in `[from_m, from_m + window_m]` of the loop point nearest to
    /// `point_m` (the smallest such arc length on ties). Searching a window rather than the
    /// whole loop keeps a robot on its own lap where the loop passes a place twice.
    pub fn project_forward(&self, point_m: [f64; 2], from_m: f64, window_m: f64) -> f64 {
        let lap_m = self.length_m();
        let window_m = window_m.clamp(0.0, lap_m);
        let to_m = from_m + window_m;
        let first_lap = (from_m / lap_m).floor();
        let mut best = (f64::INFINITY, from_m);
        for lap in [first_lap, first_lap + 1.0] {
            for leg in 0..self.waypoints_m.len() {
                let leg_start_m = lap * lap_m + self.cumulative_m[leg];
                let lo_m = from_m.max(leg_start_m);
                let hi_m = to_m.min(leg_start_m + self.leg_length_m(leg));
                if lo_m > hi_m {
                    continue;
                }
                let (a, b) = leg_ends(&self.waypoints_m, leg);
                let len_m = self.leg_length_m(leg);
                let dir = [(b[0] - a[0]) / len_m, (b[1] - a[1]) / len_m];
                let along_m = (point_m[0] - a[0]) * dir[0] + (point_m[1] - a[1]) * dir[1];
                let s_m = (leg_start_m + along_m).clamp(lo_m, hi_m);
                let on_m = [
                    a[0] + (s_m - leg_start_m) * dir[0],
                    a[1] + (s_m - leg_start_m) * dir[1],
                ];
                let d_m = (point_m[0] - on_m[0]).hypot(point_m[1] - on_m[1]);
                if d_m < best.0 {
                    best = (d_m, s_m);
                }
            }
        }
        best.1
    }

    /// The leg holding arc length `s_m`, and the distance along that leg.
    fn locate(&self, s_m: f64) -> (usize, f64) {
        let n = self.waypoints_m.len();
        let s_m = s_m.rem_euclid(self.length_m());
        // The last waypoint with cumulative length <= s; `rem_euclid` keeps s below the total.
        let leg = self.cumulative_m[..n]
            .partition_point(|&c| c <= s_m)
            .saturating_sub(1);
        (
            leg,
            (s_m - self.cumulative_m[leg]).min(self.leg_length_m(leg)),
        )
    }

    fn leg_length_m(&self, leg: usize) -> f64 {
        self.cumulative_m[leg + 1] - self.cumulative_m[leg]
    }
}

/// Start and end of leg `i` (the last leg closes the loop).
fn leg_ends(waypoints_m: &[[f64; 2]], i: usize) -> ([f64; 2], [f64; 2]) {
    (waypoints_m[i], waypoints_m[(i + 1) % waypoints_m.len()])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Route {
        Route::closed(vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    }

    #[test]
    fn arc_length_wraps() {
        let route = square();
        assert_eq!(route.length_m(), 16.0);
        assert_eq!(route.point_at(0.0), [0.0, 0.0]);
        assert_eq!(route.point_at(6.0), [4.0, 2.0]);
        assert_eq!(route.point_at(16.0 + 6.0), [4.0, 2.0]);
        assert_eq!(route.point_at(-2.0), [0.0, 2.0]);
        assert_eq!(route.direction_at(13.0), [0.0, -1.0]);
    }

    #[test]
    fn projection_stays_in_its_window() {
        let route = square();
        assert!((route.project_forward([1.0, 0.3], 0.0, 3.0) - 1.0).abs() < 1e-12);
        // Near the start again, second lap.
        let s = route.project_forward([0.2, 0.1], 15.0, 3.0);
        assert!((s - 16.2).abs() < 1e-12);
        // A point beyond the window projects onto its end.
        assert_eq!(route.project_forward([4.0, 3.0], 0.0, 2.0), 2.0);
        assert!((route.distance_m([2.0, 1.0]) - 1.0).abs() < 1e-12);
    }
}
