//! Reference vs fast raster-overlap scan matcher on one realistic pair: two consecutive scans
//! (361 beams, half a degree apart) of a synthetic L-shaped room with a pillar, matched over a
//! table of 21 × 21 translations (one 5 cm pixel apart) × 31 rotations (half a degree apart) on
//! a 256 × 256 raster.
//!
//! Run with `cargo bench -p host --bench scan_match -- --quick`.

use std::f64::consts::FRAC_PI_2;
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use host::geometry::Pose2;
use host::scan_match::synthetic::{WallInMap, cast_scan, polygon_walls};
use host::scan_match::{
    FastMatcher, RasterOptions, ReferenceMatcher, Scan, ScanMatcher, SearchTable,
};

/// An L-shaped room about 9 m × 7 m with a square pillar.
fn room_walls() -> Vec<WallInMap> {
    let mut walls = polygon_walls(&[
        [-3.0, -2.5],
        [5.5, -2.5],
        [5.5, 1.0],
        [2.0, 1.0],
        [2.0, 4.5],
        [-3.0, 4.5],
    ]);
    walls.extend(polygon_walls(&[
        [1.0, -1.0],
        [1.6, -1.0],
        [1.6, -0.4],
        [1.0, -0.4],
    ]));
    walls
}

/// The reference scan and the next one, after the robot moved 12 cm forward, 4 cm left and
/// turned 2 degrees.
fn consecutive_scans() -> (Scan, Scan) {
    let walls = room_walls();
    let reference_pose_in_map = Pose2::new(-0.4, 0.3, 0.2);
    let new_pose_in_map = reference_pose_in_map * Pose2::new(0.12, 0.04, 2f64.to_radians());
    let cast = |pose| cast_scan(&walls, pose, -FRAC_PI_2, 0.5f64.to_radians(), 361, 8.0);
    (cast(reference_pose_in_map), cast(new_pose_in_map))
}

fn bench_scan_match(c: &mut Criterion) {
    let (reference_scan, new_scan) = consecutive_scans();
    let raster = RasterOptions::default();
    let table = SearchTable::default();
    let reference = ReferenceMatcher::new(raster, table).expect("default options are valid");
    let fast = FastMatcher::new(raster, table).expect("default options are valid");

    let expected = reference
        .match_scans(&reference_scan, &new_scan, Pose2::IDENTITY)
        .expect("the guess is finite");
    let actual = fast
        .match_scans(&reference_scan, &new_scan, Pose2::IDENTITY)
        .expect("the guess is finite");
    assert_eq!(
        (actual.table_index, actual.score_px),
        (expected.table_index, expected.score_px),
        "the fast matcher must return the reference's answer"
    );
    println!(
        "best {:?}, score {} px; fast scored {} of {} candidates",
        expected.reference_from_new,
        expected.score_px,
        actual.candidates_evaluated,
        expected.candidates_evaluated
    );

    let mut group = c.benchmark_group("scan_match_21x21x31");
    group.sample_size(10);
    group.bench_function("reference", |b| {
        b.iter(|| {
            reference.match_scans(
                black_box(&reference_scan),
                black_box(&new_scan),
                Pose2::IDENTITY,
            )
        })
    });
    group.bench_function("fast", |b| {
        b.iter(|| {
            fast.match_scans(
                black_box(&reference_scan),
                black_box(&new_scan),
                Pose2::IDENTITY,
            )
        })
    });
    group.finish();
}

criterion_group!(benches, bench_scan_match);
criterion_main!(benches);
