//! Streaming alignment: push one query element, read the cost of every view against every
//! reference (SPEC section 3, docs/architecture.md, "The filter is incremental").
//!
//! References are interleaved across SIMD lanes (`GROUP` per group) and right-aligned in columns
//! `0..=M`, so the last `W` elements of every reference share columns `M-W+1..=M` and one vector
//! DP cell updates `GROUP` references at once.
//!
//! * Each push computes the local costs of the new element against every reference column once
//!   (`O(sum m_i * d)`), into a ring of the last rows when a view needs past rows.
//! * `(All, All)` and `(All, Last(W))` keep one DP row per reference and add a row per push:
//!   `O(m)` and `O(W)` per reference.
//! * `(Last(W), All | Last(V))` re-run `min(W, n)` rows from the cached cost rows: `O(W m)`, `O(W V)`.
//! * `(_, MatchQuery)`, the `Equal` window, moves at both ends and cannot be incremental: it runs
//!   the batch kernel on `x` and `y[-n:]`, except that once `n >= m_i` it is the `(All, All)` cost.
//!
//! A column window of width `w` spans columns `a = M - w ..= M`; column `a` is a boundary that is
//! `+inf` in every row, and the virtual row `-1` is `0` just left of each reference's first
//! element in the window (so that `D(0, 0) = c(0, 0)`) and `+inf` elsewhere. Padding columns
//! have `+inf` local cost, so they stay `+inf`.

use crate::batch::Dtw;
use crate::error::Result;
use crate::kernel;
use crate::lanes::{self, GROUP, V};
use crate::references::{References, check_element};
use crate::view::{QueryWindow, RefWindow, View};

/// Streaming DTW state for one episode: the query so far and the DP state of every view.
/// Made by [`References::stream`]; [`Stream::reset`] starts a new episode without reallocating.
///
/// ```
/// use defender_dtw::{Dtw, QueryWindow, RefWindow, References, View};
/// let (a, b) = ([0.0_f32, 1.0, 2.0], [5.0_f32, 5.0]); // two references, dimension 1
/// let refs = References::new(1, &[&a[..], &b[..]])?;
/// let views = [
///     View::new(QueryWindow::All, RefWindow::All),
///     View::new(QueryWindow::Last(2), RefWindow::Last(2)),
/// ];
/// let mut stream = refs.stream(&views)?;
/// for x in [0.0_f32, 1.0, 2.5] {
///     stream.push(&[x])?;
/// }
/// assert_eq!(stream.costs(0), &[0.5, 11.5]); // DTW([0, 1, 2.5], a) and (.., b)
/// let batch = Dtw::euclidean().distance(&[1.0, 2.5], &[1.0, 2.0], 1)?;
/// assert_eq!(stream.costs(1)[0], batch);
/// # Ok::<(), defender_dtw::DtwError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Stream {
    refs: References,
    views: Vec<View>,
    plans: Vec<Plan>,
    windows: Vec<ColumnWindow>,
    incs: Vec<Incremental>,
    /// The last `ring_rows` local-cost rows, `[row][group][column][lane]`.
    ring: Vec<f32>,
    ring_rows: usize,
    /// Cost rows are computed for the last `need` columns only (the widest window that reads them).
    need: usize,
    query: Vec<f32>,
    n: usize,
    out: Vec<Vec<f32>>,
    tmp: Vec<f32>,
    scratch: Vec<f32>,
}

/// How a view is computed.
#[derive(Debug, Clone, Copy)]
enum Plan {
    /// Read the incremental state `incs[i]`.
    Incremental(usize),
    /// Re-run the last `rows` cost rows over `windows[window]`.
    Recompute { rows: usize, window: usize },
    /// `MatchQuery`: the batch kernel on the query window and `y[-n:]`; `all` is the incremental
    /// `(All, All)` state used once `n >= m_i` when the query window is `All`.
    Match { rows: Option<usize>, all: Option<usize> },
}

/// Columns `M - width ..= M` and the DP row `-1` over them, `[group][column][lane]`.
#[derive(Debug, Clone)]
struct ColumnWindow {
    width: usize,
    init: Vec<f32>,
}

/// One DP row per reference over a column window, advanced at every push.
#[derive(Debug, Clone)]
struct Incremental {
    window: usize,
    dp: Vec<f32>,
}

impl References {
    /// A streaming state for one episode, computing `views` after every push.
    ///
    /// # Errors
    /// [`crate::DtwError::InvalidSetting`] for a `Last(0)` window (naming the view's index).
    pub fn stream(&self, views: &[View]) -> Result<Stream> {
        Stream::new(self.clone(), views)
    }
}

impl Stream {
    pub(crate) fn new(refs: References, views: &[View]) -> Result<Self> {
        for (i, v) in views.iter().enumerate() {
            v.check(i)?;
        }
        let max_len = refs.inner.max_len;
        let mut windows: Vec<ColumnWindow> = Vec::new();
        let mut window_of = |width: usize| -> usize {
            let width = width.min(max_len);
            if let Some(i) = windows.iter().position(|w| w.width == width) {
                return i;
            }
            windows.push(ColumnWindow { width, init: initial_row(&refs, width) });
            windows.len() - 1
        };
        let mut inc_windows: Vec<usize> = Vec::new();
        let mut inc_of = |window: usize| -> usize {
            if let Some(i) = inc_windows.iter().position(|&w| w == window) {
                return i;
            }
            inc_windows.push(window);
            inc_windows.len() - 1
        };
        let mut ring_rows = 1;
        let plans: Vec<Plan> = views
            .iter()
            .map(|v| {
                let width = match v.reference {
                    RefWindow::All | RefWindow::MatchQuery => max_len,
                    RefWindow::Last(w) => w,
                };
                let window = window_of(width);
                match (v.query, v.reference) {
                    (query, RefWindow::MatchQuery) => Plan::Match {
                        rows: match query {
                            QueryWindow::All => None,
                            QueryWindow::Last(w) => Some(w),
                        },
                        all: (query == QueryWindow::All).then(|| inc_of(window)),
                    },
                    (QueryWindow::All, _) => Plan::Incremental(inc_of(window)),
                    (QueryWindow::Last(rows), _) => {
                        ring_rows = ring_rows.max(rows);
                        Plan::Recompute { rows, window }
                    }
                }
            })
            .collect();
        let need = inc_windows
            .iter()
            .copied()
            .chain(plans.iter().filter_map(|p| match p {
                Plan::Recompute { window, .. } => Some(*window),
                _ => None,
            }))
            .map(|w| windows[w].width)
            .max()
            .unwrap_or(0);
        let incs = inc_windows
            .iter()
            .map(|&window| Incremental { window, dp: windows[window].init.clone() })
            .collect();
        let row_len = refs.inner.groups * (max_len + 1) * GROUP;
        let out = vec![vec![f32::INFINITY; refs.len()]; views.len()];
        Ok(Self {
            ring: vec![0.0; ring_rows * row_len],
            ring_rows,
            need,
            refs,
            views: views.to_vec(),
            plans,
            windows,
            incs,
            query: Vec::new(),
            n: 0,
            out,
            tmp: Vec::new(),
            scratch: Vec::new(),
        })
    }

    /// The views, in the order given to [`References::stream`].
    #[must_use]
    pub fn views(&self) -> &[View] {
        &self.views
    }

    /// The references this stream aligns with.
    #[must_use]
    pub fn references(&self) -> &References {
        &self.refs
    }

    /// The number of query elements pushed since the start or the last [`Stream::reset`].
    #[must_use]
    pub fn len(&self) -> usize {
        self.n
    }

    /// True before the first push of an episode.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The query pushed so far, row-major.
    #[must_use]
    pub fn query(&self) -> &[f32] {
        &self.query
    }

    /// Starts a new episode: forgets the query, keeps every buffer.
    pub fn reset(&mut self) {
        self.n = 0;
        self.query.clear();
        for inc in &mut self.incs {
            inc.dp.copy_from_slice(&self.windows[inc.window].init);
        }
        for o in &mut self.out {
            o.fill(f32::INFINITY);
        }
    }

    /// The cost of view `view` against every reference (in reference order) after the last push:
    /// the batch DTW of the windows that view selects. All `+inf` before the first push.
    ///
    /// # Panics
    /// If `view >= self.views().len()` (see [`Stream::get_costs`]).
    #[must_use]
    pub fn costs(&self, view: usize) -> &[f32] {
        &self.out[view]
    }

    /// As [`Stream::costs`], `None` for an out-of-range view index.
    #[must_use]
    pub fn get_costs(&self, view: usize) -> Option<&[f32]> {
        self.out.get(view).map(Vec::as_slice)
    }

    /// Appends one query element (`dim` values) and updates every view's costs.
    ///
    /// # Errors
    /// [`crate::DtwError::DimensionMismatch`] if `x.len()` is not the dimension,
    /// [`crate::DtwError::NonFinite`] for NaN or infinite values; the state is then unchanged.
    pub fn push(&mut self, x: &[f32]) -> Result<()> {
        let inner = &*self.refs.inner;
        let dim = inner.dim;
        check_element(x, dim)?;
        self.query.extend_from_slice(x);
        self.n += 1;
        let n = self.n;
        let cols = inner.max_len + 1;
        let row_len = inner.groups * cols * GROUP;
        let slot = (n - 1) % self.ring_rows;
        let row = &mut self.ring[slot * row_len..(slot + 1) * row_len];
        cost_row(inner.isa, x, &inner.inter, &inner.pen, row, Columns { dim, cols, need: self.need });
        let row = &self.ring[slot * row_len..(slot + 1) * row_len];
        for inc in &mut self.incs {
            let width = self.windows[inc.window].width;
            advance(inner.isa, &mut inc.dp, row, width, cols);
        }
        for (plan, out) in self.plans.iter().zip(&mut self.out) {
            match *plan {
                Plan::Incremental(i) => {
                    let inc = &self.incs[i];
                    read_last_column(&inc.dp, self.windows[inc.window].width, out);
                }
                Plan::Recompute { rows, window } => {
                    let w = &self.windows[window];
                    self.tmp.clear();
                    self.tmp.extend_from_slice(&w.init);
                    let rows = rows.min(n);
                    let ring = Ring {
                        data: &self.ring,
                        rows: self.ring_rows,
                        row_len,
                        first: n - rows,
                        count: rows,
                    };
                    advance_from_ring(inner.isa, &mut self.tmp, ring, w.width, cols);
                    read_last_column(&self.tmp, w.width, out);
                }
                Plan::Match { rows, all } => {
                    let q = rows.map_or(n, |w| w.min(n));
                    let xq = &self.query[(n - q) * dim..];
                    for (i, o) in out.iter_mut().enumerate() {
                        let m = inner.lens[i];
                        *o = if let Some(all) = all.filter(|_| n >= m) {
                            let inc = &self.incs[all];
                            let width = self.windows[inc.window].width;
                            let (g, lane) = (i / GROUP, i % GROUP);
                            inc.dp[(g * (width + 1) + width) * GROUP + lane]
                        } else {
                            let problem = self.refs.problem(i, xq, n.min(m), &Dtw::euclidean());
                            kernel::dtw_cost(inner.isa, &problem, &mut self.scratch)
                        };
                    }
                }
            }
        }
        Ok(())
    }
}

/// Row `-1` of the DP over the last `width` columns: `[group][t][lane]`, `t = 0..=width` for
/// columns `M - width + t`; 0 at the column just before each reference's window, `+inf` elsewhere.
fn initial_row(refs: &References, width: usize) -> Vec<f32> {
    let inner = &*refs.inner;
    let mut init = vec![f32::INFINITY; inner.groups * (width + 1) * GROUP];
    for (i, &m) in inner.lens.iter().enumerate() {
        let (g, lane) = (i / GROUP, i % GROUP);
        let t = width - width.min(m);
        init[(g * (width + 1) + t) * GROUP + lane] = 0.0;
    }
    init
}

/// Copies each reference's cost at the window's last column (`M`) into `out`.
fn read_last_column(dp: &[f32], width: usize, out: &mut [f32]) {
    for (i, o) in out.iter_mut().enumerate() {
        let (g, lane) = (i / GROUP, i % GROUP);
        *o = dp[(g * (width + 1) + width) * GROUP + lane];
    }
}

lanes::dispatch! {
    /// Local costs `||x - y_col||` for every group and column `0..=M` (`+inf` on padding).
    fn cost_row(x: &[f32], inter: &[f32], pen: &[f32], out: &mut [f32], shape: Columns) -> ()
        => cost_row_kernel, lanes: (GROUP, GROUP, GROUP)
}

/// The shape of a cost row: `cols` columns per group of `dim`-vectors, of which the last `need`
/// are computed.
#[derive(Debug, Clone, Copy)]
struct Columns {
    dim: usize,
    cols: usize,
    need: usize,
}

#[inline(always)]
fn cost_row_kernel<const L: usize, const FMA: bool>(
    x: &[f32],
    inter: &[f32],
    pen: &[f32],
    out: &mut [f32],
    shape: Columns,
) {
    let Columns { dim, cols, need } = shape;
    let (out, _) = out.as_chunks_mut::<L>();
    let (pen, _) = pen.as_chunks::<L>();
    let (inter, _) = inter.as_chunks::<L>();
    let skip = cols - need;
    for ((out, pen), inter) in
        out.chunks_exact_mut(cols).zip(pen.chunks_exact(cols)).zip(inter.chunks_exact(cols * dim))
    {
        for ((o, p), ys) in
            out[skip..].iter_mut().zip(&pen[skip..]).zip(inter[skip * dim..].chunks_exact(dim))
        {
            let mut acc = *p;
            for (&xk, yk) in x.iter().zip(ys) {
                acc = lanes::sq_diff_acc::<L, FMA>(acc, lanes::splat(xk), *yk);
            }
            *o = lanes::sqrt(acc);
        }
    }
}

/// The cached cost rows `first..first + count` (query indices) of a ring of `rows` rows.
#[derive(Debug, Clone, Copy)]
struct Ring<'a> {
    data: &'a [f32],
    rows: usize,
    row_len: usize,
    first: usize,
    count: usize,
}

impl Ring<'_> {
    #[inline(always)]
    fn row(&self, query_index: usize) -> &[f32] {
        let s = query_index % self.rows;
        &self.data[s * self.row_len..(s + 1) * self.row_len]
    }
}

lanes::dispatch! {
    /// Adds the ring's rows to `dp` (as [`advance`] once per row), four rows per sweep: the four
    /// rows' min/add chains are independent, so they overlap instead of waiting on each other.
    fn advance_from_ring(dp: &mut [f32], ring: Ring<'_>, width: usize, cols: usize) -> ()
        => advance_from_ring_kernel, lanes: (GROUP, GROUP, GROUP)
}

#[inline(always)]
fn advance_from_ring_kernel<const L: usize, const FMA: bool>(
    dp: &mut [f32],
    ring: Ring<'_>,
    width: usize,
    cols: usize,
) {
    let mut r = ring.first;
    let end = ring.first + ring.count;
    while r + 4 <= end {
        advance_block::<L, 4>(dp, std::array::from_fn(|k| ring.row(r + k)), width, cols);
        r += 4;
    }
    while r < end {
        advance_block::<L, 1>(dp, [ring.row(r)], width, cols);
        r += 1;
    }
}

/// Adds `R` rows (cost rows `costs`, in order) to `dp` in one sweep over the columns: row `k`
/// at column `t` needs row `k - 1` at `t` and `t - 1`, both already computed in this sweep.
#[inline(always)]
fn advance_block<const L: usize, const R: usize>(
    dp: &mut [f32],
    costs: [&[f32]; R],
    width: usize,
    cols: usize,
) {
    let inf = lanes::splat::<L>(f32::INFINITY);
    let (dp, _) = dp.as_chunks_mut::<L>();
    let costs = costs.map(|c| c.as_chunks::<L>().0);
    for (g, d) in dp.chunks_exact_mut(width + 1).enumerate() {
        let base = g * cols + (cols - 1 - width);
        let c: [&[V<L>]; R] = costs.map(|c| &c[base..base + width + 1]);
        // diag[k] = row k's upper-left neighbour, left[k] = row k's left neighbour.
        let mut diag = [inf; R];
        diag[0] = d[0];
        d[0] = inf;
        let mut left = [inf; R];
        for t in 1..=width {
            let mut up = d[t];
            for k in 0..R {
                let v = lanes::add(c[k][t], lanes::min(lanes::min(up, diag[k]), left[k]));
                diag[k] = up;
                left[k] = v;
                up = v;
            }
            d[t] = up;
        }
    }
}

lanes::dispatch! {
    /// Adds one DP row over the last `width` columns of every group, from the cost row `cost`
    /// (`[group][column 0..cols][lane]`).
    fn advance(dp: &mut [f32], cost: &[f32], width: usize, cols: usize) -> ()
        => advance_kernel, lanes: (GROUP, GROUP, GROUP)
}

#[inline(always)]
fn advance_kernel<const L: usize, const FMA: bool>(dp: &mut [f32], cost: &[f32], width: usize, cols: usize) {
    let inf = lanes::splat::<L>(f32::INFINITY);
    let (dp, _) = dp.as_chunks_mut::<L>();
    let (cost, _) = cost.as_chunks::<L>();
    for (d, c) in dp.chunks_exact_mut(width + 1).zip(cost.chunks_exact(cols)) {
        let c = &c[cols - 1 - width..];
        let mut diag = d[0];
        d[0] = inf;
        let mut left = inf;
        for (dt, &ct) in d[1..].iter_mut().zip(&c[1..]) {
            let up = *dt;
            let v = lanes::add(ct, lanes::min(lanes::min(up, diag), left));
            *dt = v;
            diag = up;
            left = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::isa::Isa;
    use crate::{Dtw, dtw};

    #[test]
    fn every_instruction_set_matches_batch() {
        let dim = 3;
        let seq = |len: usize, phase: f32| -> Vec<f32> {
            (0..len * dim).map(|i| (i as f32 * 0.61 + phase).sin()).collect()
        };
        let refs: Vec<Vec<f32>> = (0..11).map(|i| seq(5 + 3 * i, i as f32)).collect();
        let slices: Vec<&[f32]> = refs.iter().map(Vec::as_slice).collect();
        let views = [
            View::new(QueryWindow::All, RefWindow::All),
            View::new(QueryWindow::All, RefWindow::Last(4)),
            View::new(QueryWindow::Last(3), RefWindow::All),
            View::new(QueryWindow::All, RefWindow::MatchQuery),
        ];
        let x = seq(30, 0.3);
        let best = Isa::detect();
        for isa in [Isa::Avx512, Isa::Avx2, Isa::Portable] {
            if isa != Isa::Portable && best != Isa::Avx512 && isa != best {
                continue;
            }
            let mut set = References::new(dim, &slices).unwrap();
            std::sync::Arc::get_mut(&mut set.inner).unwrap().isa = isa;
            let mut stream = set.stream(&views).unwrap();
            for (t, xt) in x.chunks_exact(dim).enumerate() {
                stream.push(xt).unwrap();
                let xs = &x[..(t + 1) * dim];
                for (v, view) in views.iter().enumerate() {
                    for (y, &got) in refs.iter().zip(stream.costs(v)) {
                        let (n, m) = (t + 1, y.len() / dim);
                        let xw = &xs[(n - view.query_len(n)) * dim..];
                        let yw = &y[(m - view.ref_len(n, m)) * dim..];
                        let want = dtw(xw, yw, dim, &Dtw::euclidean()).unwrap();
                        assert!(
                            (got - want).abs() <= 1e-5 * want.max(1.0),
                            "{isa:?} {view:?}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }
}
