//! Laser scans rebuilt from Victoria Park tree detections, for the LMS emulator.
//!
//! The raw laser of the Victoria Park run (361 ranges at 0.5°, in cm, per scan) is not in
//! the dataset folder; only the trees detected in each scan are ([`TreeScan`]). This module
//! makes a stand-in scan from them: each detection becomes a circle of the detected diameter
//! centred at the detected range and bearing (the detector reports the distance to the
//! trunk's centre), and every beam is ray cast against those circles. Beams that hit no tree
//! are "no echo". So a rebuilt scan shows the detected trunks and nothing else: no
//! undetected trees, bushes, cars, people or ground returns, and every trunk is a perfect
//! circle. A trunk thinner than the beam spacing could fall between two beams; since the
//! detector saw it in at least one beam, the beam nearest its bearing is set to the trunk's
//! near surface (range − diameter / 2) if no beam hit it.
//!
//! Geometry: 361 beams from −90° to +90° at 0.5° around the forward axis, as the LMS200 of
//! the dataset was configured.

use std::f64::consts::FRAC_PI_2;

use super::victoria::TreeScan;
use crate::emulators::RecordedScan;
use crate::world::{Room, World};

/// The rebuilt scans' geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TreeScanOptions {
    /// Beams per scan.
    pub beams: usize,
    /// Bearing of beam 0 from the forward axis, radians (counter-clockwise positive).
    pub first_beam_rad: f64,
    /// Bearing step between beams, radians.
    pub resolution_rad: f64,
    /// Trunks farther away are not seen, metres (the dataset counts more than 80 m as no
    /// return).
    pub max_range_m: f64,
}

impl Default for TreeScanOptions {
    /// 361 beams over 180° at 0.5°, 80 m.
    fn default() -> Self {
        TreeScanOptions {
            beams: 361,
            first_beam_rad: -FRAC_PI_2,
            resolution_rad: 0.5f64.to_radians(),
            max_range_m: 80.0,
        }
    }
}

/// The stand-in scan of the detections of `scan` (see the [module documentation](self)).
pub fn synthesize_tree_scan(scan: &TreeScan, options: &TreeScanOptions) -> RecordedScan {
    // Sensor frame: x forward, y left; a laser-frame bearing b is b − 90° from forward.
    let mut trees = Room::empty();
    for tree in &scan.detections {
        let bearing_rad = tree.bearing_rad - FRAC_PI_2;
        let center_m = [
            tree.range_m * bearing_rad.cos(),
            tree.range_m * bearing_rad.sin(),
        ];
        trees = trees.with_pillar(center_m, tree.diameter_m / 2.0);
    }
    let mut ranges_m: Vec<f64> = (0..options.beams)
        .map(|i| {
            let bearing_rad = options.first_beam_rad + i as f64 * options.resolution_rad;
            trees
                .ray_cast([0.0, 0.0], bearing_rad, options.max_range_m)
                .unwrap_or(f64::INFINITY)
        })
        .collect();
    for tree in &scan.detections {
        let surface_m = (tree.range_m - tree.diameter_m / 2.0).max(0.0);
        if surface_m > options.max_range_m || options.resolution_rad == 0.0 {
            continue;
        }
        let position =
            (tree.bearing_rad - FRAC_PI_2 - options.first_beam_rad) / options.resolution_rad;
        let nearest = position.round();
        if nearest < 0.0 || nearest >= options.beams as f64 {
            continue;
        }
        let beam = nearest as usize;
        // Hit by some beam already (within the trunk's angular width)?
        let half_width_rad = (tree.diameter_m / 2.0 / tree.range_m).min(1.0).asin();
        let width_beams = (half_width_rad / options.resolution_rad.abs()).floor() as usize;
        let lo = beam.saturating_sub(width_beams);
        let hi = (beam + width_beams).min(options.beams - 1);
        let seen = ranges_m[lo..=hi]
            .iter()
            .any(|&r| (r - tree.range_m).abs() <= tree.diameter_m / 2.0 + 1e-9);
        if !seen {
            ranges_m[beam] = ranges_m[beam].min(surface_m);
        }
    }
    RecordedScan {
        timestamp_s: scan.t_s,
        first_beam_rad: options.first_beam_rad,
        resolution_rad: options.resolution_rad,
        ranges_m,
        no_return_from_m: None,
        telegram: None,
    }
}

/// The stand-in scans of every scan time, in order; a
/// [`ScanSource`](crate::emulators::ScanSource) as `tree_scans(..).into_iter()`.
pub fn tree_scans(scans: &[TreeScan], options: &TreeScanOptions) -> Vec<RecordedScan> {
    scans
        .iter()
        .map(|scan| synthesize_tree_scan(scan, options))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::{BeamMapping, Variant, recorded_words};
    use crate::replay::victoria::{TreeDetection, read_tree_scans};
    use firmware::sick::MeasuringMode;
    use protocol::RangeUnit;

    fn one_tree(range_m: f64, bearing_deg: f64, diameter_m: f64) -> TreeScan {
        TreeScan {
            line: 1,
            t_s: 2.5,
            detections: vec![TreeDetection {
                range_m,
                bearing_rad: bearing_deg.to_radians(),
                diameter_m,
            }],
        }
    }

    #[test]
    fn a_tree_ahead() {
        let scan = synthesize_tree_scan(&one_tree(10.0, 90.0, 0.6), &TreeScanOptions::default());
        assert_eq!((scan.ranges_m.len(), scan.timestamp_s), (361, 2.5));
        // Straight ahead is beam 180: the near surface, 9.7 m.
        assert!((scan.ranges_m[180] - 9.7).abs() < 1e-9);
        // 0.6 m at 10 m spans about 3.4°: beams 177–183, nothing beyond.
        let hits: Vec<usize> = (0..361).filter(|&i| scan.ranges_m[i].is_finite()).collect();
        assert_eq!(hits, (177..=183).collect::<Vec<_>>());
        // As LMS words in cm (mode 0, up to 81.9 m): 970; no echo elsewhere.
        let words = recorded_words(
            &scan,
            Variant::new(180, 50),
            RangeUnit::Cm,
            MeasuringMode(0),
            80.0,
            BeamMapping::Exact,
        );
        assert_eq!((words[180], words[0]), (970, 0x1FFF));
    }

    #[test]
    fn a_thin_tree_still_shows() {
        let scan = synthesize_tree_scan(&one_tree(30.0, 45.2, 0.05), &TreeScanOptions::default());
        let hits: Vec<usize> = (0..361).filter(|&i| scan.ranges_m[i].is_finite()).collect();
        assert_eq!(hits, [90]);
        assert!((scan.ranges_m[90] - 29.975).abs() < 1e-9);
    }

    #[test]
    fn victoria_park_scans_show_their_trees() {
        let Some(path) = datasets::require(
            "victoria_park/rfs_slam_ascii/measurements.dat",
            "victoria_park_scans_show_their_trees",
        ) else {
            return;
        };
        let scans = read_tree_scans(path).unwrap();
        let options = TreeScanOptions::default();
        let rebuilt = tree_scans(&scans[..200], &options);
        for (scan, recorded) in scans.iter().zip(&rebuilt) {
            assert_eq!(recorded.timestamp_s, scan.t_s);
            for tree in &scan.detections {
                // Some beam within the trunk's angular width sees its near side.
                let beam = ((tree.bearing_rad - FRAC_PI_2 - options.first_beam_rad)
                    / options.resolution_rad)
                    .round() as usize;
                let near = (beam.saturating_sub(6)..=(beam + 6).min(360))
                    .map(|i| recorded.ranges_m[i])
                    .fold(f64::INFINITY, f64::min);
                assert!(near <= tree.range_m, "t = {}: {tree:?}", scan.t_s);
            }
        }
    }
}
