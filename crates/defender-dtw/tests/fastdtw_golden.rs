//! Golden values from the PyPI `fastdtw` package 0.3.4 (its pure-Python module, the one a
//! `pip install` gives), made by `tools/golden/fastdtw_golden.py`: `fastdtw(x, y, radius, dist)` for
//! radius 0, 1, 2 with L1 (`dist=None`) and L2 (`dist=2`), and the package's exact `dtw`.
#![allow(clippy::unwrap_used)] // test helpers outside #[test] fns: a panic is a failed test

use defender_dtw::{
    Dtw, DtwError, FastDtw, FastReferences, Metric, QueryWindow, RefWindow, View, dtw, fastdtw,
};

struct Case {
    name: String,
    dim: usize,
    /// `(radius or None for exact, metric, distance or None where the package raises)`.
    want: Vec<(Option<usize>, Metric, Option<f64>)>,
    x: Vec<f32>,
    y: Vec<f32>,
}

fn cases() -> Vec<Case> {
    let text = include_str!("data/fastdtw_golden.txt");
    let mut lines = text.lines();
    let mut out = Vec::new();
    while let Some(head) = lines.next() {
        let f: Vec<&str> = head.split_whitespace().collect();
        assert_eq!(f[0], "case");
        let parse = |line: Option<&str>| -> Vec<f32> {
            line.unwrap().split_whitespace().map(|v| v.parse().unwrap()).collect()
        };
        let (n, m, dim): (usize, usize, usize) =
            (f[2].parse().unwrap(), f[3].parse().unwrap(), f[4].parse().unwrap());
        let want = f[5..]
            .iter()
            .map(|s| {
                let (setting, value) = s.split_once('=').unwrap();
                let (radius, metric) = setting.split_once('-').unwrap();
                let radius = radius.strip_prefix('r').map(|r| r.parse().unwrap());
                let metric = if metric == "l1" { Metric::L1 } else { Metric::L2 };
                (radius, metric, (value != "error").then(|| value.parse().unwrap()))
            })
            .collect();
        let case = Case { name: f[1].to_owned(), dim, want, x: parse(lines.next()), y: parse(lines.next()) };
        assert_eq!((case.x.len(), case.y.len()), (n * dim, m * dim), "{}", case.name);
        out.push(case);
    }
    assert_eq!(out.len(), 226);
    out
}

fn assert_close(what: &str, got: f64, want: f64) {
    let rel = (got - want).abs() / want.abs().max(1e-300);
    assert!(got == want || rel <= 1e-9, "{what}: got {got}, fastdtw {want} (relative error {rel:e})");
}

#[test]
fn fastdtw_matches_the_package() {
    let (mut checked, mut failures) = (0, 0);
    for c in cases() {
        for &(radius, metric, want) in &c.want {
            let settings = FastDtw::new(radius.unwrap_or(usize::MAX), metric);
            let what = format!("{} radius {radius:?} {metric:?}", c.name);
            match (fastdtw(&c.x, &c.y, c.dim, &settings), want) {
                (Ok(got), Some(want)) => assert_close(&what, got, want),
                (Err(DtwError::NoWarpingPath { radius: 0, .. }), None) => failures += 1,
                (got, want) => panic!("{what}: got {got:?}, the package {want:?}"),
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 226 * 8);
    assert!(failures > 100, "the radius-0 failures of the package are covered ({failures})");
}

#[test]
fn exact_l1_and_l2_kernels_match_the_packages_dtw() {
    for c in cases() {
        for &(radius, metric, want) in c.want.iter().filter(|w| w.0.is_none()) {
            let what = format!("{} exact {metric:?} ({radius:?})", c.name);
            let got = dtw(&c.x, &c.y, c.dim, &Dtw::euclidean().with_metric(metric)).unwrap();
            let want = want.unwrap();
            // The SIMD kernels work in f32: equal up to f32 rounding along the path.
            let rel = (f64::from(got) - want).abs() / want.abs().max(1.0);
            assert!(rel < 1e-5, "{what}: got {got}, fastdtw.dtw {want} (relative error {rel:e})");
        }
    }
}

#[test]
fn reference_sets_match_the_package() {
    let all = View::new(QueryWindow::All, RefWindow::All);
    for metric in [Metric::L1, Metric::L2] {
        for radius in [1, 2] {
            let settings = FastDtw::new(radius, metric);
            for dim in [1, 3, 11] {
                let group: Vec<Case> = cases().into_iter().filter(|c| c.dim == dim).collect();
                // Every case's y is a reference; each case's x is a query against all of them.
                let ys: Vec<&[f32]> = group.iter().map(|c| &c.y[..]).collect();
                let mut refs = FastReferences::new(dim, &ys, settings).unwrap();
                let mut out = vec![0.0; ys.len()];
                for (q, c) in group.iter().enumerate().step_by(7) {
                    refs.costs_into(&c.x, &all, &mut out).unwrap();
                    let (_, _, want) = c.want.iter().find(|w| w.0 == Some(radius) && w.1 == metric).unwrap();
                    assert_close(&c.name, out[q], want.unwrap());
                    for (y, &got) in ys.iter().zip(&out) {
                        assert_eq!(got, fastdtw(&c.x, y, dim, &settings).unwrap());
                    }
                }
            }
        }
    }
}
