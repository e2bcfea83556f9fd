//! Pose-graph optimisation on a Manhattan-like synthetic graph of 5 000 nodes and about
//! 15 000 edges (an odometry chain and up to three loop closures per pose against earlier
//! visits of the same intersection of a 30 × 30 street grid), starting from dead reckoning.
//!
//! * `optimize_from_dead_reckoning`: a fresh graph each time, so the fill-reducing ordering and
//!   the symbolic factorisation are included.
//! * `reoptimize_converged`: the same graph optimised again, reusing its solver state; the
//!   cost of one linearise–factorise–solve round and the stopping test.
//!
//! Run with `cargo bench -p host --bench pose_graph -- --quick`.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use host::pose_graph::OptimizeOptions;
use host::pose_graph::synthetic::{Noise, manhattan_grid};

fn bench(c: &mut Criterion) {
    let noise = Noise {
        seed: 2,
        ..Noise::default()
    };
    let synthetic = manhattan_grid(5000, 30, 3, &noise);
    let options = OptimizeOptions::default();

    let mut group = c.benchmark_group("pose_graph_5000_nodes");
    group.sample_size(10);
    group.bench_function("optimize_from_dead_reckoning", |b| {
        b.iter_batched(
            || synthetic.graph.clone(),
            |mut graph| black_box(graph.optimize(&options)),
            BatchSize::LargeInput,
        );
    });

    let mut converged = synthetic.graph.clone();
    // The synthetic graph is anchored and well posed, so this cannot fail.
    let _ = converged.optimize(&options);
    group.bench_function("reoptimize_converged", |b| {
        b.iter(|| black_box(converged.optimize(&options)));
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
