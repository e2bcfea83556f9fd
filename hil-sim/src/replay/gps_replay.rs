//! Recorded GPS positions fed to the NMEA receiver emulator ([`GpsEmulator`]), e.g.
//! Victoria Park's `gps.dat` (local metres, x used as east and y as north).
//!
//! The log's clock is mapped onto the emulator's: the first fix is at `start_us`, later ones
//! at `start_us` plus their time after the first. The receiver keeps its own epoch rate and
//! noise (set `horizontal_sigma_m` to 0 in [`GpsEmulatorOptions`] to print the recorded
//! positions unchanged); each epoch reports the latest fix at or before its time, with speed
//! and course from that fix and the one before it. Two ways to connect it:
//!
//! * [`GpsReplay::trajectory`]: a trajectory function for [`GpsEmulator::set_trajectory`];
//!   it holds the last fix through the recording's gaps and after its end.
//! * [`GpsReplay::apply`], called before each poll (at least at every
//!   [`GpsReplay::next_change_us`]): sets the truth with [`GpsEmulator::set_truth`], and
//!   drops the fix ([`GpsEmulator::set_fix`]) while the latest recorded fix is older than
//!   [`GpsReplayOptions::max_gap_s`], as over the recording's outages and after its end.
//!
//! [`GpsEmulatorOptions`]: crate::emulators::GpsEmulatorOptions

use super::victoria::LocalGpsFix;
use crate::emulators::{GpsEmulator, GpsTruth};

/// How recorded fixes are fed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpsReplayOptions {
    /// Emulator time of the first fix, µs.
    pub start_us: u64,
    /// A recorded fix older than this no longer counts: the receiver reports no fix, seconds.
    pub max_gap_s: f64,
}

impl Default for GpsReplayOptions {
    /// Start at 0; a fix counts for 2 s (Victoria Park's GPS logs at about 5 Hz).
    fn default() -> Self {
        GpsReplayOptions {
            start_us: 0,
            max_gap_s: 2.0,
        }
    }
}

/// Recorded fixes on the emulator's clock. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct GpsReplay {
    fixes: Vec<LocalGpsFix>,
    options: GpsReplayOptions,
    /// Fixes whose time has come (at the last [`Self::apply`]).
    applied: usize,
}

impl GpsReplay {
    /// A replay of `fixes` (in time order).
    pub fn new(fixes: Vec<LocalGpsFix>, options: GpsReplayOptions) -> GpsReplay {
        GpsReplay {
            fixes,
            options,
            applied: 0,
        }
    }

    /// The fixes.
    pub fn fixes(&self) -> &[LocalGpsFix] {
        &self.fixes
    }

    /// Emulator time of fix `index`, µs.
    pub fn fix_us(&self, index: usize) -> Option<u64> {
        let first_s = self.fixes.first()?.t_s;
        let fix = self.fixes.get(index)?;
        Some(self.options.start_us + seconds_to_us(fix.t_s - first_s))
    }

    /// The truth at emulator time `now_us`: the latest fix at or before it, or `None`
    /// before the first.
    pub fn truth_at(&self, now_us: u64) -> Option<GpsTruth> {
        truth_at(&self.fixes, self.options.start_us, now_us).map(|(truth, _)| truth)
    }

    /// A trajectory function for [`GpsEmulator::set_trajectory`]: the latest fix at or
    /// before each epoch (the first fix before it), held through gaps.
    pub fn trajectory(&self) -> impl FnMut(u64) -> GpsTruth + Send + 'static {
        let fixes = self.fixes.clone();
        let start_us = self.options.start_us;
        move |epoch_us| {
            truth_at(&fixes, start_us, epoch_us)
                .or_else(|| truth_at(&fixes, start_us, start_us))
                .map_or_else(GpsTruth::default, |(truth, _)| truth)
        }
    }

    /// Feeds `gps` the state at `now_us`: the truth of the latest fix, and whether the
    /// receiver has a fix (a recorded fix no older than `max_gap_s`). Returns how many
    /// recorded fixes came due since the last call.
    pub fn apply(&mut self, gps: &mut GpsEmulator, now_us: u64) -> usize {
        let before = self.applied;
        match truth_at(&self.fixes, self.options.start_us, now_us) {
            Some((truth, index)) => {
                self.applied = index + 1;
                gps.set_truth(
                    truth.east_m,
                    truth.north_m,
                    truth.speed_mps,
                    truth.course_deg,
                );
                let age_us = self
                    .fix_us(index)
                    .map_or(u64::MAX, |fix_us| now_us.saturating_sub(fix_us));
                gps.set_fix((age_us as f64) <= self.options.max_gap_s * 1e6);
            }
            None => gps.set_fix(false),
        }
        self.applied.saturating_sub(before)
    }

    /// When [`Self::apply`] would change something next: the next fix, or the moment the
    /// latest one grows too old.
    pub fn next_change_us(&self) -> Option<u64> {
        if let Some(next_us) = self.fix_us(self.applied) {
            return Some(next_us);
        }
        let last_us = self.fix_us(self.applied.checked_sub(1)?)?;
        Some(last_us + seconds_to_us(self.options.max_gap_s) + 1)
    }

    /// Whether every fix has come due.
    pub fn is_finished(&self) -> bool {
        self.applied >= self.fixes.len()
    }
}

/// Non-negative seconds as whole µs.
fn seconds_to_us(seconds: f64) -> u64 {
    if seconds > 0.0 {
        (seconds * 1e6).round() as u64
    } else {
        0
    }
}

/// The truth of the latest fix at or before `now_us`, and its index.
fn truth_at(fixes: &[LocalGpsFix], start_us: u64, now_us: u64) -> Option<(GpsTruth, usize)> {
    let first_s = fixes.first()?.t_s;
    let now_s = first_s + (now_us.checked_sub(start_us)? as f64) / 1e6;
    // Fixes at or before now_s.
    let count = fixes.partition_point(|fix| fix.t_s <= now_s + 1e-9);
    let index = count.checked_sub(1)?;
    let fix = fixes[index];
    let (speed_mps, course_deg) = match index.checked_sub(1).map(|i| fixes[i]) {
        Some(prev) if fix.t_s > prev.t_s => {
            let (east_m, north_m) = (fix.x_m - prev.x_m, fix.y_m - prev.y_m);
            let speed_mps = east_m.hypot(north_m) / (fix.t_s - prev.t_s);
            let course_deg = east_m.atan2(north_m).to_degrees().rem_euclid(360.0);
            (speed_mps, course_deg)
        }
        _ => (0.0, 0.0),
    };
    let truth = GpsTruth {
        east_m: fix.x_m,
        north_m: fix.y_m,
        up_m: 0.0,
        speed_mps,
        course_deg,
    };
    Some((truth, index))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::GpsEmulatorOptions;
    use crate::replay::victoria::read_gps;
    use crate::world::GeoDatum;
    use firmware::nmea::{GgaRepr, Sentence};

    fn fix(t_s: f64, x_m: f64, y_m: f64) -> LocalGpsFix {
        LocalGpsFix { t_s, x_m, y_m }
    }

    #[test]
    fn latest_fix_with_speed_and_course() {
        let replay = GpsReplay::new(
            vec![
                fix(10.0, 0.0, 0.0),
                fix(11.0, 3.0, 4.0),
                fix(20.0, 3.0, 4.0),
            ],
            GpsReplayOptions {
                start_us: 1_000_000,
                max_gap_s: 2.0,
            },
        );
        assert_eq!(replay.truth_at(999_999), None);
        assert_eq!(replay.truth_at(1_000_000).unwrap().east_m, 0.0);
        let t = replay.truth_at(2_500_000).unwrap();
        assert_eq!((t.east_m, t.north_m, t.speed_mps), (3.0, 4.0, 5.0));
        assert!((t.course_deg - 36.869_897_645).abs() < 1e-6);
        assert_eq!(replay.fix_us(2), Some(11_000_000));
        let mut trajectory = replay.trajectory();
        assert_eq!(trajectory(0).east_m, 0.0);
        assert_eq!(trajectory(50_000_000).speed_mps, 0.0);
    }

    #[test]
    fn gaps_drop_the_fix() {
        let mut replay = GpsReplay::new(
            vec![fix(0.0, 1.0, 2.0), fix(5.0, 2.0, 2.0)],
            GpsReplayOptions::default(),
        );
        let mut gps = GpsEmulator::new(GpsEmulatorOptions {
            rate_hz: 1,
            ..GpsEmulatorOptions::default()
        });
        assert_eq!(replay.apply(&mut gps, 0), 1);
        assert_eq!(gps.truth().east_m, 1.0);
        assert_eq!(replay.next_change_us(), Some(5_000_000));
        let with_fix = gps.poll_output(500_000);
        assert!(String::from_utf8_lossy(&with_fix).contains(",A,"));
        replay.apply(&mut gps, 3_000_000);
        let without = gps.poll_output(3_500_000);
        assert!(String::from_utf8_lossy(&without).contains(",V,"));
        assert_eq!(replay.apply(&mut gps, 5_000_000), 1);
        assert!(replay.is_finished());
        assert_eq!(replay.next_change_us(), Some(7_000_001));
    }

    #[test]
    fn victoria_park_gps_through_the_receiver() {
        let Some(path) = datasets::require(
            "victoria_park/rfs_slam_ascii/gps.dat",
            "victoria_park_gps_through_the_receiver",
        ) else {
            return;
        };
        let fixes = read_gps(path).unwrap();
        assert_eq!(fixes.len(), 4_466);
        let options = GpsEmulatorOptions {
            horizontal_sigma_m: 0.0,
            vertical_sigma_m: 0.0,
            rate_hz: 5,
            ..GpsEmulatorOptions::default()
        };
        let datum = options.datum;
        let mut gps = GpsEmulator::new(options);
        let replay = GpsReplay::new(fixes.clone(), GpsReplayOptions::default());
        gps.set_trajectory(replay.trajectory());
        // The first 20 s: every GGA is the latest recorded position.
        let text = String::from_utf8(gps.poll_output(20_000_000)).unwrap();
        let mut checked = 0;
        for (epoch, line) in text.lines().filter(|l| l.contains("GGA")).enumerate() {
            let sentence = Sentence::new_checked(line.trim_end()).unwrap();
            let gga = GgaRepr::parse(&sentence).unwrap();
            let position = gga.position.unwrap();
            let (east_m, north_m) = GeoDatum::to_local_m(
                &datum,
                position.lat_ndeg as f64 / 1e9,
                position.lon_ndeg as f64 / 1e9,
            );
            let truth = replay.truth_at(epoch as u64 * 200_000).unwrap();
            assert!((east_m - truth.east_m).abs() < 0.01, "epoch {epoch}");
            assert!((north_m - truth.north_m).abs() < 0.01, "epoch {epoch}");
            checked += 1;
        }
        assert!(checked >= 99, "{checked}");
    }
}
