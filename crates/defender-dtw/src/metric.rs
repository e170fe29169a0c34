//! The point distance between two sequence elements: Euclidean (SPEC section 2) or L1 (the
//! default of the `fastdtw` package for multi-dimensional inputs, which the paper's code used).
//!
//! The f64 forms below are FastDTW's: they reproduce, bit for bit, what numpy computes for the
//! `fastdtw` package (0.3.4, pure-Python module) so that the package's tie-breaking between equal
//! costs, which decides its windows, is reproduced too.

/// The point distance `c(x_i, y_j)` of a DTW.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Metric {
    /// Euclidean norm of the difference, `||x_i - y_j||_2` (SPEC section 2; `fastdtw`'s `dist=2`).
    #[default]
    L2,
    /// Sum of absolute differences, `||x_i - y_j||_1` (`fastdtw`'s `dist=None` on vectors).
    L1,
}

impl Metric {
    /// Its name in configuration files: `"l2"` or `"l1"`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Metric::L2 => "l2",
            Metric::L1 => "l1",
        }
    }
}

/// `L` values computed side by side (cells of one DP row), which LLVM keeps in SIMD registers.
pub(crate) type V64<const L: usize> = [f64; L];

/// The distance of `L` cells at once: component `k` of the `L` differences is `diff(k)`.
///
/// L1 sums `|diff|` in numpy's pairwise order (`np.add.reduce`, which `np.linalg.norm(v, 1)`
/// calls): below 8 terms a plain loop from 0; up to 128 terms eight running sums combined as
/// `((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))`, then the remainder one by one; above that,
/// halves rounded to a multiple of 8. L2 is the square root of the sum of squares in order
/// (numpy calls BLAS `ddot` there, whose order depends on the CPU: equal up to rounding).
/// Plain loops, not `std::array::from_fn`, so that everything inlines into the SIMD kernels.
#[inline(always)]
pub(crate) fn lanes<const L: usize>(metric: Metric, dim: usize, diff: impl Fn(usize) -> V64<L>) -> V64<L> {
    match metric {
        Metric::L1 => {
            let abs = |k: usize| {
                let mut d = diff(k);
                for v in &mut d {
                    *v = v.abs();
                }
                d
            };
            if dim <= 128 { pairwise_block(0, dim, &abs) } else { pairwise(0, dim, &abs) }
        }
        Metric::L2 => {
            let mut acc = [0.0; L];
            for k in 0..dim {
                let d = diff(k);
                for l in 0..L {
                    acc[l] += d[l] * d[l];
                }
            }
            for v in &mut acc {
                *v = v.sqrt();
            }
            acc
        }
    }
}

#[inline(always)]
fn add<const L: usize>(mut x: V64<L>, y: V64<L>) -> V64<L> {
    for l in 0..L {
        x[l] += y[l];
    }
    x
}

/// numpy's `pairwise_sum` over terms `start..start + n`, `n <= 128` (no recursion, so it inlines).
#[inline(always)]
fn pairwise_block<const L: usize>(start: usize, n: usize, a: &impl Fn(usize) -> V64<L>) -> V64<L> {
    if n < 8 {
        let mut res = [0.0; L];
        for k in start..start + n {
            res = add(res, a(k));
        }
        return res;
    }
    let mut r = [[0.0; L]; 8];
    for (q, rq) in r.iter_mut().enumerate() {
        *rq = a(start + q);
    }
    let mut i = 8;
    while i < n - n % 8 {
        for (q, rq) in r.iter_mut().enumerate() {
            *rq = add(*rq, a(start + i + q));
        }
        i += 8;
    }
    let mut res = add(add(add(r[0], r[1]), add(r[2], r[3])), add(add(r[4], r[5]), add(r[6], r[7])));
    while i < n {
        res = add(res, a(start + i));
        i += 1;
    }
    res
}

/// numpy's `pairwise_sum` for any `n`: blocks of up to 128 terms, split in halves above.
fn pairwise<const L: usize>(start: usize, n: usize, a: &impl Fn(usize) -> V64<L>) -> V64<L> {
    if n <= 128 {
        return pairwise_block(start, n, a);
    }
    let mut half = n / 2;
    half -= half % 8;
    add(pairwise(start, half, a), pairwise(start + half, n - half, a))
}

/// The distance between two f64 points (the scalar form of [`lanes`]).
#[cfg(test)]
pub(crate) fn point(metric: Metric, x: &[f64], y: &[f64]) -> f64 {
    lanes::<1>(metric, x.len(), |k| [x[k] - y[k]])[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn l1_follows_numpys_pairwise_order() {
        // With these magnitudes the order of additions changes the rounded sum.
        let v: Vec<f64> = (0..300).map(|i| (f64::from(i) * 0.37).sin() * 10f64.powi(i % 7 - 3)).collect();
        for dim in [1, 3, 7, 8, 11, 17, 129, 300] {
            let x = &v[..dim];
            let zero = vec![0.0; dim];
            let got = point(Metric::L1, x, &zero);
            let want = reference_pairwise(&x.iter().map(|a| a.abs()).collect::<Vec<_>>());
            assert_eq!(got.to_bits(), want.to_bits(), "dim {dim}");
        }
        assert_eq!(point(Metric::L2, &[3.0, 4.0], &[0.0, 0.0]), 5.0);
    }

    /// numpy's pairwise sum written from its C source, independently of the lane form above.
    fn reference_pairwise(a: &[f64]) -> f64 {
        let n = a.len();
        if n < 8 {
            return a.iter().fold(0.0, |s, &x| s + x);
        }
        if n <= 128 {
            let mut r = [0.0; 8];
            r.copy_from_slice(&a[..8]);
            let mut i = 8;
            while i < n - n % 8 {
                for q in 0..8 {
                    r[q] += a[i + q];
                }
                i += 8;
            }
            let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
            for &x in &a[i..] {
                res += x;
            }
            return res;
        }
        let half = n / 2 - (n / 2) % 8;
        reference_pairwise(&a[..half]) + reference_pairwise(&a[half..])
    }
}
