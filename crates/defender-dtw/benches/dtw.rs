//! Criterion benches of defender-dtw: batch DTW (1000 x 1000, d = 11, the dtaidistance shape),
//! a reference-set alignment, one streaming push for the filter's view sets, and one step of the
//! authors' profile: FastDTW of a 20-element trajectory against 100 demonstrations, beside exact
//! DTW of the same shapes.
//!
//! `cargo bench -p defender-dtw --bench dtw` (figures in docs/benchmarks-core.md).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use defender_dtw::{Dtw, FastDtw, FastReferences, Metric, QueryWindow, RefWindow, References, View, dtw};

#[path = "support/walk.rs"]
mod walk;
use walk::walk;

fn batch(c: &mut Criterion) {
    let (n, m, dim) = (1000, 1000, 11);
    let (x, y) = (walk(n, dim, 1), walk(m, dim, 2));
    let mut g = c.benchmark_group("batch");
    g.throughput(Throughput::Elements((n * m) as u64));
    g.bench_function("dtw_1000x1000_d11", |b| b.iter(|| dtw(black_box(&x), &y, dim, &Dtw::euclidean())));
    g.bench_function("dtw_1000x1000_d11_band100", |b| {
        b.iter(|| dtw(black_box(&x), &y, dim, &Dtw::euclidean().with_band(100)))
    });
    let seqs: Vec<Vec<f32>> = (0..10).map(|i| walk(m, dim, 10 + i)).collect();
    let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
    let refs = References::new(dim, &slices).unwrap_or_else(|e| panic!("{e}"));
    g.throughput(Throughput::Elements((10 * n * m) as u64));
    g.bench_function("align_10_refs_1000x1000_d11", |b| {
        b.iter(|| refs.align(black_box(&x), &Dtw::euclidean()))
    });
    g.finish();
}

/// One push at query length ~500 (the middle of an episode), against `count` references.
fn push(c: &mut Criterion) {
    use QueryWindow as Q;
    use RefWindow as R;
    let (m, dim) = (1000, 11);
    let query = walk(m, dim, 3);
    let sets: [(&str, usize, Vec<View>); 3] = [
        ("100refs_all_all", 100, vec![View::new(Q::All, R::All)]),
        ("50refs_all_all+last10_all", 50, vec![View::new(Q::All, R::All), View::new(Q::Last(10), R::All)]),
        (
            "50refs_all_last5+all_last10+last5_last5",
            50,
            vec![
                View::new(Q::All, R::Last(5)),
                View::new(Q::All, R::Last(10)),
                View::new(Q::Last(5), R::Last(5)),
            ],
        ),
    ];
    let mut g = c.benchmark_group("push");
    for (name, count, views) in sets {
        let seqs: Vec<Vec<f32>> = (0..count).map(|i| walk(m, dim, 10 + i as u64)).collect();
        let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
        let refs = References::new(dim, &slices).unwrap_or_else(|e| panic!("{e}"));
        let mut stream = refs.stream(&views).unwrap_or_else(|e| panic!("{e}"));
        let mut t = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                if t == 1000 {
                    stream.reset();
                    t = 0;
                }
                stream.push(black_box(&query[t * dim..(t + 1) * dim])).unwrap_or_else(|e| panic!("{e}"));
                t += 1;
            })
        });
    }
    g.finish();
}

/// One filter step of the authors' profile: the last 20 states (d = 11, Hopper-v5) against 100
/// demonstrations of `m` elements, FastDTW (radius 1, L1) and exact DTW (L2 and L1) side by side.
fn step(c: &mut Criterion) {
    let (n, dim, count) = (20, 11, 100);
    let query = walk(n, dim, 4);
    let all = View::new(QueryWindow::All, RefWindow::All);
    let mut g = c.benchmark_group("step");
    for m in [1000, 20, 5] {
        let seqs: Vec<Vec<f32>> = (0..count).map(|i| walk(m, dim, 200 + i as u64)).collect();
        let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
        let mut fast =
            FastReferences::new(dim, &slices, FastDtw::default()).unwrap_or_else(|e| panic!("{e}"));
        let mut out = vec![0.0; count];
        g.bench_function(format!("fastdtw_r1_l1_20x{m}_100refs_d11"), |b| {
            b.iter(|| fast.costs_into(black_box(&query), &all, &mut out).unwrap_or_else(|e| panic!("{e}")))
        });
        let exact = References::new(dim, &slices).unwrap_or_else(|e| panic!("{e}"));
        let mut out32 = vec![0.0; count];
        for (name, settings) in [("l2", Dtw::euclidean()), ("l1", Dtw::euclidean().with_metric(Metric::L1))] {
            g.bench_function(format!("exact_{name}_20x{m}_100refs_d11"), |b| {
                b.iter(|| exact.align_view_into(black_box(&query), &all, &settings, &mut out32))
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(3));
    targets = batch, push, step
}
criterion_main!(benches);
