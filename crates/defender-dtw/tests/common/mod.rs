//! The naive O(nm) DTW every fast path is checked against (SPEC section 2), in f64.
#![allow(dead_code)]

/// `D(n-1, m-1)` with `c = ||x_i - y_j||_2`, steps (1,0), (0,1), (1,1), `D(0,0) = c(0,0)`;
/// `band`: only `|i - j| <= w`.
pub fn naive_dtw(x: &[f32], y: &[f32], dim: usize, band: Option<usize>) -> f64 {
    let (n, m) = (x.len() / dim, y.len() / dim);
    let mut d = vec![vec![f64::INFINITY; m]; n];
    for i in 0..n {
        for j in 0..m {
            if band.is_some_and(|w| i.abs_diff(j) > w) {
                continue;
            }
            let c: f64 = (0..dim)
                .map(|k| {
                    let v = f64::from(x[i * dim + k]) - f64::from(y[j * dim + k]);
                    v * v
                })
                .sum::<f64>()
                .sqrt();
            let best = if i == 0 && j == 0 {
                0.0
            } else {
                let mut b = f64::INFINITY;
                if i > 0 {
                    b = b.min(d[i - 1][j]);
                }
                if j > 0 {
                    b = b.min(d[i][j - 1]);
                }
                if i > 0 && j > 0 {
                    b = b.min(d[i - 1][j - 1]);
                }
                b
            };
            d[i][j] = c + best;
        }
    }
    d[n - 1][m - 1]
}

/// `got` (f32) equals `want` up to f32 rounding along a path of up to a few thousand cells.
pub fn close(got: f32, want: f64) -> bool {
    if want.is_infinite() {
        return got == f32::INFINITY;
    }
    (f64::from(got) - want).abs() <= 1e-5 * want.abs().max(1.0)
}

/// The last `k` elements of a row-major sequence.
pub fn last(v: &[f32], dim: usize, k: usize) -> &[f32] {
    let len = v.len() / dim;
    &v[(len - k.min(len)) * dim..]
}
