//! Property tests: every fast path equals the naive DTW (SPEC sections 2 and 3), under every
//! kernel this CPU can run (AVX-512, AVX2, portable), not only the detected one. The seed is
//! fixed (the same cases on every run and machine) and failures found are replayed first from
//! the committed `properties.proptest-regressions`.
#![allow(clippy::unwrap_used)] // test helpers outside #[test] fns: a panic is a failed test

mod common;

use common::{close, last, naive_dtw};
use defender_dtw::kernels::{available, current, with_kernel};
use defender_dtw::{Dtw, QueryWindow, RefWindow, References, View};
use proptest::prelude::*;
use proptest::test_runner::{FileFailurePersistence, RngAlgorithm, RngSeed};

/// 200 cases from a fixed seed; the regressions file beside this one is replayed first.
fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 200,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x0DEF_E9DE),
        failure_persistence: Some(Box::new(FileFailurePersistence::SourceParallel("proptest-regressions"))),
        ..ProptestConfig::default()
    }
}

/// Runs `check` under every kernel this CPU can run, naming the kernel in a failure.
fn every_kernel(check: impl Fn() -> Result<(), TestCaseError>) -> Result<(), TestCaseError> {
    for kernel in available() {
        with_kernel(kernel, || {
            assert_eq!(current(), kernel);
            check()
        })
        .map_err(|e| TestCaseError::fail(format!("kernel {kernel}: {e}")))?;
    }
    Ok(())
}

#[test]
fn the_kernels_run_are_the_ones_this_cpu_has() {
    let kernels = available();
    assert_eq!(kernels.last(), Some(&"portable"));
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        assert!(kernels.contains(&"avx2"), "{kernels:?}");
    }
    // Forcing is scoped: after the closure the detected kernel is back.
    let best = current();
    with_kernel("portable", || assert_eq!(current(), "portable"));
    assert_eq!(current(), best);
    assert_eq!(best, kernels[0]);
}

/// A row-major sequence of `1..=max_len` elements of dimension `dim`.
fn seq(dim: usize, max_len: usize) -> impl Strategy<Value = Vec<f32>> {
    (1..=max_len).prop_flat_map(move |len| prop::collection::vec(-3.0f32..3.0, len * dim))
}

/// The sliced sequences a view selects after `n` query elements.
fn sliced<'a>(view: &View, x: &'a [f32], y: &'a [f32], dim: usize) -> (&'a [f32], &'a [f32]) {
    let (n, m) = (x.len() / dim, y.len() / dim);
    (last(x, dim, view.query_len(n)), last(y, dim, view.ref_len(n, m)))
}

fn all_views() -> Vec<View> {
    use QueryWindow as Q;
    use RefWindow as R;
    let mut views = Vec::new();
    for q in [Q::All, Q::Last(1), Q::Last(3), Q::Last(5)] {
        for r in [R::All, R::Last(1), R::Last(2), R::Last(5), R::MatchQuery] {
            views.push(View::new(q, r));
        }
    }
    views
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn batch_equals_naive(dim in 1usize..5, (x, y) in (1usize..5).prop_flat_map(|d| (seq(d, 40), seq(d, 40))).no_shrink(), band in prop::option::of(0usize..8)) {
        let dim = dim.min(x.len()).max(1);
        // Re-slice so both have whole elements of `dim`.
        let x = &x[..x.len() / dim * dim];
        let y = &y[..y.len() / dim * dim];
        prop_assume!(!x.is_empty() && !y.is_empty());
        let mut settings = Dtw::euclidean();
        if let Some(w) = band {
            settings = settings.with_band(w);
        }
        let want = naive_dtw(x, y, dim, band);
        every_kernel(|| {
            let got = settings.distance(x, y, dim).unwrap();
            prop_assert!(close(got, want), "got {got}, want {want}");
            Ok(())
        })?;
    }

    #[test]
    fn early_abandon_is_exact_or_inf(
        (dim, x, y) in (1usize..4).prop_flat_map(|d| (Just(d), seq(d, 50), seq(d, 50))),
        frac in 0.0f64..2.0,
    ) {
        let want = naive_dtw(&x, &y, dim, None);
        let threshold = (want * frac) as f32;
        every_kernel(|| {
            let got = Dtw::euclidean().with_max_cost(threshold).distance(&x, &y, dim).unwrap();
            if want > f64::from(threshold) * (1.0 + 1e-5) {
                prop_assert_eq!(got, f32::INFINITY);
            } else if want < f64::from(threshold) * (1.0 - 1e-5) {
                prop_assert!(close(got, want), "got {got}, want {want}");
            }
            Ok(())
        })?;
    }

    #[test]
    fn reference_set_views_equal_naive(
        (dim, x, refs) in (1usize..4).prop_flat_map(|d| (Just(d), seq(d, 12), prop::collection::vec(seq(d, 12), 1..11))),
    ) {
        let slices: Vec<&[f32]> = refs.iter().map(Vec::as_slice).collect();
        every_kernel(|| {
            let set = References::new(dim, &slices).unwrap();
            prop_assert_eq!(set.align(&x, &Dtw::euclidean()).unwrap().len(), refs.len());
            let mut out = vec![0.0; refs.len()];
            for view in all_views() {
                set.align_view_into(&x, &view, &Dtw::euclidean(), &mut out).unwrap();
                for (y, &got) in refs.iter().zip(&out) {
                    let (xs, ys) = sliced(&view, &x, y, dim);
                    let want = naive_dtw(xs, ys, dim, None);
                    prop_assert!(close(got, want), "{view:?}: got {got}, want {want}");
                }
            }
            Ok(())
        })?;
    }

    #[test]
    fn stream_equals_batch_after_every_push(
        (dim, x, refs) in (1usize..4).prop_flat_map(|d| (Just(d), seq(d, 14), prop::collection::vec(seq(d, 14), 1..20))),
    ) {
        let slices: Vec<&[f32]> = refs.iter().map(Vec::as_slice).collect();
        let views = all_views();
        every_kernel(|| {
            let set = References::new(dim, &slices).unwrap();
            let mut stream = set.stream(&views).unwrap();
            // Twice, to check that `reset` really starts over.
            for _ in 0..2 {
                stream.reset();
                for (t, xt) in x.chunks_exact(dim).enumerate() {
                    stream.push(xt).unwrap();
                    let prefix = &x[..(t + 1) * dim];
                    for (v, view) in views.iter().enumerate() {
                        for (y, &got) in refs.iter().zip(stream.costs(v)) {
                            let (xs, ys) = sliced(view, prefix, y, dim);
                            let want = naive_dtw(xs, ys, dim, None);
                            prop_assert!(close(got, want), "step {t}, {view:?}: got {got}, want {want}");
                        }
                    }
                }
            }
            Ok(())
        })?;
    }
}

/// Long sequences cross many kernel strips and lane groups; checked against naive once.
#[test]
fn long_sequences_and_many_references() {
    let dim = 3;
    let make = |len: usize, phase: f32| -> Vec<f32> {
        (0..len * dim).map(|i| ((i as f32) * 0.37 + phase).sin() * 2.0).collect()
    };
    let x = make(150, 0.0);
    let refs: Vec<Vec<f32>> = (0..19).map(|i| make(40 + 9 * i, i as f32)).collect();
    let slices: Vec<&[f32]> = refs.iter().map(Vec::as_slice).collect();
    for kernel in available() {
        with_kernel(kernel, || long_sequences_under_the_current_kernel(&x, &refs, &slices, dim));
    }
}

fn long_sequences_under_the_current_kernel(x: &[f32], refs: &[Vec<f32>], slices: &[&[f32]], dim: usize) {
    let kernel = current();
    let set = References::new(dim, slices).unwrap();
    let views = [
        View::new(QueryWindow::All, RefWindow::All),
        View::new(QueryWindow::All, RefWindow::MatchQuery),
        View::new(QueryWindow::Last(10), RefWindow::All),
        View::new(QueryWindow::All, RefWindow::Last(10)),
        View::new(QueryWindow::Last(10), RefWindow::Last(10)),
    ];
    let mut stream = set.stream(&views).unwrap();
    for (t, xt) in x.chunks_exact(dim).enumerate() {
        stream.push(xt).unwrap();
        if t % 37 != 36 && t + 1 != x.len() / dim {
            continue;
        }
        let prefix = &x[..(t + 1) * dim];
        for (v, view) in views.iter().enumerate() {
            for (y, &got) in refs.iter().zip(stream.costs(v)) {
                let (xs, ys) = sliced(view, prefix, y, dim);
                let want = naive_dtw(xs, ys, dim, None);
                assert!(close(got, want), "{kernel}: step {t}, {view:?}: got {got}, want {want}");
            }
        }
    }
    for w in [0, 3, 20, 200] {
        let got = Dtw::euclidean().with_band(w).distance(x, &refs[18], dim).unwrap();
        let want = naive_dtw(x, &refs[18], dim, Some(w));
        assert!(close(got, want), "{kernel}: band {w}: got {got}, want {want}");
    }
}
