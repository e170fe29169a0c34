//! Choosing the strategy (`defender::selection::select`) on Hopper-v5-shaped synthetic
//! demonstrations (`defender::synthetic::WalkSet`: 11-D smooth random walks, 3-D actions):
//! leave-one-out over 2 x 10 demonstrations of 1000 transitions, the 441 strategies without
//! `Equal`, on rayon's pool (all cores).
//!
//! `cargo bench -p defender --bench selection`. The cost grows with (demonstrations)^2 x length:
//! the shipped Hopper set (50 + 50, real lengths) is timed by `defender select` itself
//! (docs/benchmarks.md, "Choosing the strategy").

#![allow(clippy::unwrap_used)] // bench helpers fail loudly on purpose

use criterion::{Criterion, criterion_group, criterion_main};
use defender::Meta;
use defender::selection::{SelectionConfig, select};
use defender::synthetic::WalkSet;
use std::hint::black_box;

fn bench_select(c: &mut Criterion) {
    let set = WalkSet { per_group: 10, ..WalkSet::HOPPER }.build(1, Meta::default()).unwrap();
    let config = SelectionConfig { equal: false, ..Default::default() };
    let mut group = c.benchmark_group("select");
    group.sample_size(10);
    group.bench_function("hopper_shape_10+10x1000_no_equal", |b| {
        b.iter(|| black_box(select(&set, None, &config, &|_| {}).unwrap()))
    });
    group.finish();
}

criterion_group!(benches, bench_select);
criterion_main!(benches);
