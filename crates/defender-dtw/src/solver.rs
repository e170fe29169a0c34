//! FastDTW's recursion, as the `fastdtw` package (0.3.4, its pure-Python module) runs it: coarsen
//! both sequences while both have at least `radius + 2` elements, run full DTW at the coarsest
//! level, then at each finer level run DTW inside the window around the coarser level's path.
//!
//! The package's DP stores, per cell, `min((up + c, ..), (left + c, ..), (diag + c, ..))` by its
//! first field, which keeps the first of equal sums: up, then left, then diagonal. The values do
//! not depend on that order (rounding is monotone, so the minimum of the three rounded sums is
//! the rounded sum of the minimum), only the path does; so the DP computes values alone, and the
//! backtracking recomputes the three sums of each path cell to take the package's step.

use crate::isa::Isa;
use crate::lanes;
use crate::metric::{self, Metric, V64};
use crate::pyramid::{Level, Pyramid};
use crate::window::Window;

/// The scratch of one FastDTW computation, reused across calls: after the first calls with the
/// longest sequences, a call allocates nothing.
#[derive(Debug, Clone, Default)]
pub(crate) struct Solver {
    window: Window,
    /// DP values of the window's cells, row after row.
    cost: Vec<f64>,
    /// The current row's local costs.
    local: Vec<f64>,
    /// The previous row's values at columns `lo - 1 .. end` of the current row (`+inf` outside
    /// its window).
    above: Vec<f64>,
    /// The path's first and last column in each row of the level just solved.
    first: Vec<usize>,
    last: Vec<usize>,
}

impl Solver {
    /// FastDTW between the two sequences whose levels are `x` and `y`; `None` when the window
    /// misses the last cell (radius 0 with an odd length: the package raises `IndexError` there).
    pub(crate) fn fastdtw(
        &mut self,
        isa: Isa,
        x: &Pyramid,
        y: &Pyramid,
        radius: usize,
        metric: Metric,
    ) -> Option<f64> {
        let min_len = radius.saturating_add(2);
        let mut base = 0;
        while x.lens[base] >= min_len && y.lens[base] >= min_len {
            base += 1;
        }
        self.window.full(x.lens[base], y.lens[base]);
        for level in (0..=base).rev() {
            if level < base {
                let (n, m) = (x.lens[level], y.lens[level]);
                self.window.expand(&self.first, &self.last, n, m, radius);
            }
            let (xl, yl) = (x.level(level), y.level(level));
            let problem = Problem { x: xl, y: yl, dim: x.dim, metric, window: &self.window };
            windowed_dtw(isa, &problem, &mut self.cost, &mut self.local, &mut self.above);
            let end = self.window.index(xl.len - 1, yl.len - 1)?;
            if self.cost[end] == f64::INFINITY {
                return None;
            }
            if level == 0 {
                return Some(self.cost[end]);
            }
            backtrack(&problem, &self.cost, &mut self.first, &mut self.last);
        }
        None
    }
}

/// The package's path from the last cell back to `(0, 0)`, kept as each row's first and last
/// column (all the window of the next level needs).
fn backtrack(p: &Problem<'_>, cost: &[f64], first: &mut Vec<usize>, last: &mut Vec<usize>) {
    let w = p.window;
    let at = |i: usize, j: usize| w.index(i, j).map_or(f64::INFINITY, |c| cost[c]);
    let (n, m) = (p.x.len, p.y.len);
    first.clear();
    first.resize(n, 0);
    last.clear();
    last.resize(n, 0);
    let (mut i, mut j) = (n - 1, m - 1);
    last[i] = j;
    loop {
        first[i] = j;
        if i == 0 && j == 0 {
            break;
        }
        let c = metric::lanes::<1>(p.metric, p.dim, |k| [p.x.component(k)[i] - p.y.component(k)[j]])[0];
        let up = (if i > 0 { at(i - 1, j) } else { f64::INFINITY }) + c;
        let left = (if j > 0 { at(i, j - 1) } else { f64::INFINITY }) + c;
        let diag = (if i > 0 && j > 0 { at(i - 1, j - 1) } else { f64::INFINITY }) + c;
        // Python's min() keeps the first of equal keys: up, then left, then diagonal.
        let (mut best, mut step) = (up, (1, 0));
        if left < best {
            (best, step) = (left, (0, 1));
        }
        if diag < best {
            step = (1, 1);
        }
        if step.0 == 1 {
            i -= 1;
            last[i] = j - step.1;
        }
        j -= step.1;
    }
}

/// One level's DP: sequences `x` (rows) and `y` (columns), the cells of `window`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Problem<'a> {
    x: Level<'a>,
    y: Level<'a>,
    dim: usize,
    metric: Metric,
    window: &'a Window,
}

lanes::dispatch! {
    /// Fills `cost` with the DP values of the window's cells, row by row: `D(i, j) = c(i, j) +
    /// min(D(i - 1, j), D(i, j - 1), D(i - 1, j - 1))`, `D(-1, -1) = 0`, `+inf` outside the window.
    fn windowed_dtw(p: &Problem<'_>, cost: &mut Vec<f64>, local: &mut Vec<f64>, above: &mut Vec<f64>) -> ()
        => windowed_kernel, lanes: (8, 4, 2)
}

#[inline(always)]
fn windowed_kernel<const L: usize, const FMA: bool>(
    p: &Problem<'_>,
    cost: &mut Vec<f64>,
    local: &mut Vec<f64>,
    above: &mut Vec<f64>,
) {
    let w = p.window;
    let inf = f64::INFINITY;
    cost.clear();
    cost.resize(w.cells, inf);
    for i in 0..p.x.len {
        let (lo, end, off) = (w.lo[i], w.end[i], w.off[i]);
        if lo >= end {
            continue;
        }
        let width = end - lo;
        local.clear();
        local.resize(width, 0.0);
        local_costs::<L>(p, i, lo, local);
        // above[t] = D(i - 1, lo - 1 + t), t = 0..=width.
        above.clear();
        above.resize(width + 1, inf);
        if i == 0 {
            above[0] = 0.0; // D(-1, -1): the start; lo = 0 in the first row.
        } else {
            let (plo, pend, poff) = (w.lo[i - 1], w.end[i - 1], w.off[i - 1]);
            // Columns max(lo - 1, plo) .. min(end, pend) of the row above.
            let from = lo.max(plo + 1) - 1;
            let to = end.min(pend);
            if from < to {
                above[from + 1 - lo..to + 1 - lo].copy_from_slice(&cost[poff + from - plo..poff + to - plo]);
            }
        }
        let row = &mut cost[off..off + width];
        let mut left = inf;
        for (t, (out, &c)) in row.iter_mut().zip(local.iter()).enumerate() {
            let (up, diag) = (above[t + 1], above[t]);
            let mut best = if up < diag { up } else { diag };
            if left < best {
                best = left;
            }
            left = best + c;
            *out = left;
        }
    }
}

/// The local costs `c(i, j)` for `j = lo .. lo + out.len()`, `L` columns at a time.
#[inline(always)]
fn local_costs<const L: usize>(p: &Problem<'_>, i: usize, lo: usize, out: &mut [f64]) {
    let (x, y) = (p.x, p.y);
    let mut chunks = out.chunks_exact_mut(L);
    let mut j = lo;
    for chunk in &mut chunks {
        let c: V64<L> = metric::lanes::<L>(p.metric, p.dim, |k| {
            let (xk, yk) = (x.component(k)[i], &y.component(k)[j..j + L]);
            let mut d = [0.0; L];
            for l in 0..L {
                d[l] = xk - yk[l];
            }
            d
        });
        chunk.copy_from_slice(&c);
        j += L;
    }
    for o in chunks.into_remainder() {
        *o = metric::lanes::<1>(p.metric, p.dim, |k| [x.component(k)[i] - y.component(k)[j]])[0];
        j += 1;
    }
}
