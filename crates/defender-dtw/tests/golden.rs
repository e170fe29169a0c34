//! Golden values from dtw-python (`dtw(x, y, dist_method="euclidean", step_pattern="symmetric1")`,
//! with `window_type="sakoechiba"` for banded cases), made by `tools/golden/dtw_golden.py`.
#![allow(clippy::unwrap_used)] // test helpers outside #[test] fns: a panic is a failed test

mod common;

use defender_dtw::{Dtw, QueryWindow, RefWindow, References, View, dtw};

struct Case {
    name: String,
    dim: usize,
    band: Option<usize>,
    want: f64,
    x: Vec<f32>,
    y: Vec<f32>,
}

fn cases() -> Vec<Case> {
    let text = include_str!("data/dtw_golden.txt");
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
        let band: i64 = f[5].parse().unwrap();
        let case = Case {
            name: f[1].to_owned(),
            dim,
            band: usize::try_from(band).ok(),
            want: f[6].parse().unwrap(),
            x: parse(lines.next()),
            y: parse(lines.next()),
        };
        assert_eq!((case.x.len(), case.y.len()), (n * dim, m * dim), "{}", case.name);
        out.push(case);
    }
    assert_eq!(out.len(), 12);
    out
}

fn assert_close(what: &str, got: f32, want: f64) {
    let rel = (f64::from(got) - want).abs() / want.abs().max(1e-12);
    assert!(rel < 1e-5, "{what}: got {got}, dtw-python {want} (relative error {rel:e})");
}

#[test]
fn batch_matches_dtw_python() {
    for c in cases() {
        let mut settings = Dtw::euclidean();
        if let Some(w) = c.band {
            settings = settings.with_band(w);
        }
        assert_close(&c.name, dtw(&c.x, &c.y, c.dim, &settings).unwrap(), c.want);
        // DTW is symmetric.
        assert_close(&c.name, dtw(&c.y, &c.x, c.dim, &settings).unwrap(), c.want);
    }
}

#[test]
fn reference_set_and_stream_match_dtw_python() {
    for c in cases().into_iter().filter(|c| c.band.is_none()) {
        let refs = References::new(c.dim, &[&c.y[..], &c.x[..]]).unwrap();
        assert_close(&c.name, refs.align(&c.x, &Dtw::euclidean()).unwrap()[0], c.want);
        let mut stream = refs.stream(&[View::new(QueryWindow::All, RefWindow::All)]).unwrap();
        for xt in c.x.chunks_exact(c.dim) {
            stream.push(xt).unwrap();
        }
        assert_close(&c.name, stream.costs(0)[0], c.want);
        assert_eq!(stream.costs(0)[1], 0.0);
    }
}
