//! The batch DTW kernel (SPEC section 2): anti-diagonal strips of `L` query rows.
//!
//! Along one DP row every cell waits for its left neighbour (a serial min/add chain of ~7 cycles
//! per cell). A strip of `L` consecutive rows `i..i+L` is instead swept by steps `s`, lane `k`
//! holding cell `(i + k, s - k)`: all lanes of one step are independent, so one step is a handful
//! of SIMD instructions for `L` cells. The neighbours come from the previous two steps:
//!
//! ```text
//! left (i+k,   s-k-1) = prev[k]        up   (i+k-1, s-k)   = prev[k-1]   (lane 0: row above)
//! diag (i+k-1, s-k-1) = prev2[k-1]     (lane 0: row above)
//! ```
//!
//! The local costs of a step need `y[s-k]` for `k = 0..L`, which is contiguous when `y` is stored
//! reversed and dimension-major ([`RevSeq`]); the query strip is transposed once per strip.
//! Out-of-range lanes compute finite junk that only ever flows to other out-of-range cells, except
//! columns `< 0`, which stay `+inf` because everything before the first step is `+inf`.

use crate::lanes::{self, PAD, V};
use crate::metric::Metric;

/// A sequence stored reversed and dimension-major with `PAD` zeros on both sides:
/// component `k` of element `len - 1 - p` is at `data[k * stride + PAD + p]`.
///
/// A suffix `y[len - r..]` is the prefix `p < r` of this storage, which is how the `MatchQuery`
/// window and reference sets reuse it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RevSeq<'a> {
    pub(crate) data: &'a [f32],
    pub(crate) stride: usize,
}

impl RevSeq<'_> {
    /// Appends the storage of `y` (`m` elements of dimension `dim`, row-major) to `out`.
    pub(crate) fn store(y: &[f32], dim: usize, out: &mut Vec<f32>) {
        let m = y.len() / dim;
        let stride = m + 2 * PAD;
        let start = out.len();
        out.resize(start + dim * stride, 0.0);
        let block = &mut out[start..];
        for (j, row) in y.chunks_exact(dim).enumerate() {
            for (k, &v) in row.iter().enumerate() {
                block[k * stride + PAD + (m - 1 - j)] = v;
            }
        }
    }
}

/// What to align: `rows` query elements (row-major, `dim` each) against the suffix of length
/// `cols` of a stored sequence.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Problem<'a> {
    pub(crate) x: &'a [f32],
    pub(crate) y: RevSeq<'a>,
    pub(crate) dim: usize,
    pub(crate) cols: usize,
    /// Sakoe-Chiba half-width: cells with `|i - j| > band` are forbidden.
    pub(crate) band: Option<usize>,
    /// `+inf` is returned once the result must exceed this (`+inf`: never abandon).
    pub(crate) max_cost: f32,
    /// The local cost.
    pub(crate) metric: Metric,
}

lanes::dispatch! {
    /// DTW cost of `problem` (SPEC section 2), `+inf` if no path or abandoned.
    pub(crate) fn dtw_cost(problem: &Problem<'_>, scratch: &mut Vec<f32>) -> f32
        => kernel, lanes: (16, 8, 8)
}

#[inline(always)]
fn kernel<const L: usize, const FMA: bool>(p: &Problem<'_>, scratch: &mut Vec<f32>) -> f32 {
    match (p.band, p.metric) {
        (Some(w), Metric::L2) => strips::<L, FMA, true, false>(p, w, scratch),
        (None, Metric::L2) => strips::<L, FMA, false, false>(p, 0, scratch),
        (Some(w), Metric::L1) => strips::<L, FMA, true, true>(p, w, scratch),
        (None, Metric::L1) => strips::<L, FMA, false, true>(p, 0, scratch),
    }
}

#[inline(always)]
fn strips<const L: usize, const FMA: bool, const BANDED: bool, const L1: bool>(
    p: &Problem<'_>,
    w: usize,
    scratch: &mut Vec<f32>,
) -> f32 {
    let (dim, r) = (p.dim, p.cols);
    let n = p.x.len() / dim;
    let inf = f32::INFINITY;
    // above[j + 1] = D(i - 1, j) for the strip starting at row i; above[0] = D(i - 1, -1), which is
    // 0 above the first row so that D(0, 0) = c(0, 0).
    scratch.clear();
    scratch.resize(r + L + 1, inf);
    let above = &mut scratch[..];
    above[0] = 0.0;
    let mut xs: Vec<V<L>> = vec![[0.0; L]; dim];
    let two_k: V<L> = std::array::from_fn(|k| 2.0 * k as f32);
    let wf = w as f32;
    let mut result = inf;
    let mut i = 0;
    while i < n {
        for (k, xk) in xs.iter_mut().enumerate() {
            *xk = std::array::from_fn(|lane| if i + lane < n { p.x[(i + lane) * dim + k] } else { 0.0 });
        }
        let last_strip = i + L >= n;
        let kf = if last_strip { n - 1 - i } else { usize::MAX };
        let mut s_lo = 0;
        let mut s_hi = r + L - 2;
        if BANDED {
            s_lo = i.saturating_sub(w);
            s_hi = s_hi.min(i + 2 * (L - 1) + w);
        }
        let mut prev = lanes::splat::<L>(inf);
        let mut prev2 = prev;
        let fi = i as f32;
        for s in s_lo..=s_hi {
            let at = PAD + r - 1 - s;
            let mut acc = lanes::splat::<L>(0.0);
            for (k, xk) in xs.iter().enumerate() {
                let yk = lanes::load::<L>(p.y.data, k * p.y.stride + at);
                acc = if L1 {
                    lanes::abs_diff_acc(acc, *xk, yk)
                } else {
                    lanes::sq_diff_acc::<L, FMA>(acc, *xk, yk)
                };
            }
            let mut c = if L1 { acc } else { lanes::sqrt(acc) };
            if BANDED {
                let off = fi - s as f32;
                c = std::array::from_fn(|k| if (off + two_k[k]).abs() > wf { inf } else { c[k] });
            }
            let up = lanes::shift_in(above[s + 1], prev);
            let diag = lanes::shift_in(above[s], prev2);
            let cur = lanes::add(c, lanes::min(lanes::min(prev, up), diag));
            if s >= L - 1 && s - (L - 1) < r {
                above[s - (L - 1) + 1] = cur[L - 1];
            }
            if last_strip && s == r - 1 + kf {
                result = cur[kf];
            }
            prev2 = prev;
            prev = cur;
        }
        above[0] = inf;
        if !last_strip && p.max_cost < inf {
            let row_min = above[1..=r].iter().fold(inf, |a, &b| if b < a { b } else { a });
            if row_min > p.max_cost {
                return inf;
            }
        }
        i += L;
    }
    if result > p.max_cost { inf } else { result }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::isa::Isa;

    /// Every instruction set this CPU has (the integration tests only run the detected one).
    pub(crate) fn available() -> Vec<Isa> {
        let best = Isa::detect();
        [Isa::Avx512, Isa::Avx2, Isa::Portable]
            .into_iter()
            .filter(|&i| i == Isa::Portable || best == Isa::Avx512 || (best == Isa::Avx2 && i == Isa::Avx2))
            .collect()
    }

    #[test]
    fn every_instruction_set_matches_naive() {
        let mut state = 12345u32;
        let mut rnd = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 * 4.0 - 2.0
        };
        for &(n, m, dim, band) in &[
            (1, 1, 1, None),
            (3, 40, 2, None),
            (17, 16, 11, None),
            (40, 33, 3, Some(4)),
            (40, 33, 3, Some(8)),
            (70, 90, 5, Some(30)),
        ] {
            let x: Vec<f32> = (0..n * dim).map(|_| rnd()).collect();
            let y: Vec<f32> = (0..m * dim).map(|_| rnd()).collect();
            let mut storage = Vec::new();
            RevSeq::store(&y, dim, &mut storage);
            let problem = Problem {
                x: &x,
                y: RevSeq { data: &storage, stride: m + 2 * PAD },
                dim,
                cols: m,
                band,
                max_cost: f32::INFINITY,
                metric: Metric::L2,
            };
            let want = crate::oracle::naive_dtw(&x, &y, dim, band);
            for isa in available() {
                let got = dtw_cost(isa, &problem, &mut Vec::new());
                assert!(
                    f64::from(got) == want || (f64::from(got) - want).abs() <= 1e-5 * want.max(1.0),
                    "{isa:?} {n}x{m}: {got} vs {want}"
                );
            }
        }
    }
}
