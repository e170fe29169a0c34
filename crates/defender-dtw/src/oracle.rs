//! The test oracle: SPEC section 2's DTW by its definition, in f64, O(nm) time and memory. Every
//! fast path of this workspace (the SIMD kernels, the streams, the online filter, the ablation) is
//! checked against it. Not part of the API (hidden from the docs): tests of other crates use it so
//! that there is one oracle, not one per test suite.

/// `D(n-1, m-1)` with `c(i, j) = ||x_i - y_j||_2`, `D(0, 0) = c(0, 0)`,
/// `D(i, j) = c(i, j) + min(D(i-1, j), D(i, j-1), D(i-1, j-1))`; `band`: only cells with
/// `|i - j| <= w`. `x` and `y` are row-major sequences of `dim`-vectors; an empty one (or a band
/// that cannot reach the last cell) gives `+inf`.
pub fn naive_dtw(x: &[f32], y: &[f32], dim: usize, band: Option<usize>) -> f64 {
    let (n, m) = (x.len() / dim.max(1), y.len() / dim.max(1));
    if n == 0 || m == 0 {
        return f64::INFINITY;
    }
    let mut d = vec![f64::INFINITY; n * m];
    for i in 0..n {
        for j in 0..m {
            if band.is_some_and(|w| i.abs_diff(j) > w) {
                continue;
            }
            let c = x[i * dim..(i + 1) * dim]
                .iter()
                .zip(&y[j * dim..(j + 1) * dim])
                .map(|(a, b)| (f64::from(*a) - f64::from(*b)).powi(2))
                .sum::<f64>()
                .sqrt();
            let best = if i == 0 && j == 0 {
                0.0
            } else {
                let up = if i > 0 { d[(i - 1) * m + j] } else { f64::INFINITY };
                let left = if j > 0 { d[i * m + j - 1] } else { f64::INFINITY };
                let diag = if i > 0 && j > 0 { d[(i - 1) * m + j - 1] } else { f64::INFINITY };
                up.min(left).min(diag)
            };
            d[i * m + j] = c + best;
        }
    }
    d[n * m - 1]
}

#[cfg(test)]
mod tests {
    use super::naive_dtw;

    #[test]
    fn matches_hand_computed_values() {
        // x = [1, 5], y = [0, 0, 0]: D = [[1, 2, 3], [6, 6, 7]].
        assert_eq!(naive_dtw(&[1., 5.], &[0., 0., 0.], 1, None), 7.0);
        assert_eq!(naive_dtw(&[0., 0., 3., 4.], &[0., 0.], 2, None), 5.0);
        assert_eq!(naive_dtw(&[], &[1.], 1, None), f64::INFINITY);
        // Symmetric, and zero on identical sequences.
        let a = [0.3f32, 1.2, -0.5, 2.0];
        let b = [1.0f32, 0.1, 0.7];
        assert_eq!(naive_dtw(&a, &b, 1, None), naive_dtw(&b, &a, 1, None));
        assert_eq!(naive_dtw(&a, &a, 1, None), 0.0);
        // A band of 0 on equal lengths is the diagonal: the sum of the pointwise distances.
        assert_eq!(naive_dtw(&[1., 2.], &[0., 0.], 1, Some(0)), 3.0);
        assert_eq!(naive_dtw(&[1., 2., 3.], &[0.], 1, Some(1)), f64::INFINITY);
    }
}
