//! A set of reference sequences (the demonstrations), stored twice for speed:
//! reversed and dimension-major per reference for the batch kernel ([`crate::kernel::RevSeq`]),
//! and interleaved across references, right-aligned, for the streaming kernels.

use std::sync::Arc;

use crate::batch::Dtw;
use crate::error::{DtwError, Result, check_finite, check_sequence};
use crate::isa::Isa;
use crate::isa::isa;
use crate::kernel::{self, Problem, RevSeq};
use crate::lanes::{GROUP, PAD};
use crate::view::{QueryWindow, View};

/// Many reference sequences of one dimension, aligned with one query at once.
///
/// Cloning is cheap (the storage is shared), so a [`crate::Stream`] owns a clone and needs no lifetime.
#[derive(Debug, Clone)]
pub struct References {
    pub(crate) inner: Arc<Inner>,
}

#[derive(Debug)]
pub(crate) struct Inner {
    pub(crate) dim: usize,
    pub(crate) lens: Vec<usize>,
    /// Per reference, its [`RevSeq`] block starts at `rev_start[i]`.
    pub(crate) rev: Vec<f32>,
    pub(crate) rev_start: Vec<usize>,
    /// `M`, the longest reference. Streaming columns are `0..=M`; reference `i` occupies columns
    /// `M + 1 - m_i ..= M` (right-aligned), so every window `y[-W:]` ends at column `M`.
    pub(crate) max_len: usize,
    pub(crate) groups: usize,
    /// `[group][column][component][lane]`: component of reference `group * GROUP + lane`.
    pub(crate) inter: Vec<f32>,
    /// `[group][column][lane]`: 0 where the column holds an element of that lane's reference,
    /// `+inf` on padding, so that padding costs are `+inf`.
    pub(crate) pen: Vec<f32>,
    pub(crate) isa: Isa,
}

impl References {
    /// Stores `seqs`, each a row-major sequence of `dim`-vectors (`len = m_i * dim`, `m_i >= 1`).
    ///
    /// # Errors
    /// [`DtwError::NoReferences`] for an empty list, [`DtwError::ZeroDimension`],
    /// [`DtwError::EmptySequence`] / [`DtwError::LengthNotMultiple`] for a bad sequence,
    /// [`DtwError::NonFinite`] for NaN or infinite values; each names the reference's index.
    pub fn new(dim: usize, seqs: &[&[f32]]) -> Result<Self> {
        if dim == 0 {
            return Err(DtwError::ZeroDimension);
        }
        if seqs.is_empty() {
            return Err(DtwError::NoReferences);
        }
        let mut lens = Vec::with_capacity(seqs.len());
        for (i, s) in seqs.iter().enumerate() {
            lens.push(check_sequence(&format!("reference {i}"), s, dim)?);
        }
        let mut rev = Vec::new();
        let mut rev_start = Vec::with_capacity(seqs.len());
        for s in seqs {
            rev_start.push(rev.len());
            RevSeq::store(s, dim, &mut rev);
        }
        let max_len = lens.iter().copied().max().unwrap_or(0);
        let groups = seqs.len().div_ceil(GROUP);
        let cols = max_len + 1;
        let mut inter = vec![0.0; groups * cols * dim * GROUP];
        let mut pen = vec![f32::INFINITY; groups * cols * GROUP];
        for (i, s) in seqs.iter().enumerate() {
            let (g, lane) = (i / GROUP, i % GROUP);
            let first = cols - lens[i];
            for (j, row) in s.chunks_exact(dim).enumerate() {
                let col = first + j;
                pen[(g * cols + col) * GROUP + lane] = 0.0;
                for (k, &v) in row.iter().enumerate() {
                    inter[((g * cols + col) * dim + k) * GROUP + lane] = v;
                }
            }
        }
        let inner = Inner { dim, lens, rev, rev_start, max_len, groups, inter, pen, isa: isa() };
        Ok(Self { inner: Arc::new(inner) })
    }

    /// The dimension of every element.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.inner.dim
    }

    /// The number of references.
    #[must_use]
    pub fn len(&self) -> usize {
        self.inner.lens.len()
    }

    /// Always false: a reference set holds at least one sequence.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.inner.lens.is_empty()
    }

    /// The length (number of elements) of each reference, in order.
    #[must_use]
    pub fn lengths(&self) -> &[usize] {
        &self.inner.lens
    }

    /// DTW cost of `query` against every reference (whole sequences), in reference order.
    ///
    /// # Errors
    /// As [`References::align_view_into`].
    pub fn align(&self, query: &[f32], settings: &Dtw) -> Result<Vec<f32>> {
        let all = View::new(QueryWindow::All, crate::RefWindow::All);
        let mut out = vec![0.0; self.len()];
        self.align_view_into(query, &all, settings, &mut out)?;
        Ok(out)
    }

    /// Batch DTW of the windows `view` selects: for each reference `y_i`, the cost between
    /// `query[window]` and `y_i[window]` (with `n` = the whole query's length for
    /// [`crate::RefWindow::MatchQuery`]), written to `out[i]`. The streaming [`crate::Stream`] gives the
    /// same numbers step by step.
    ///
    /// # Errors
    /// [`DtwError::DimensionMismatch`] if `out.len()` is not the number of references; for the
    /// query, [`DtwError::EmptySequence`], [`DtwError::LengthNotMultiple`] (length not a multiple
    /// of [`References::dim`]), [`DtwError::NonFinite`]; [`DtwError::InvalidSetting`] for a
    /// `Last(0)` window or a NaN `max_cost`.
    pub fn align_view_into(&self, query: &[f32], view: &View, settings: &Dtw, out: &mut [f32]) -> Result<()> {
        settings.check()?;
        view.check(0)?;
        let dim = self.dim();
        let n = check_sequence("query", query, dim)?;
        if out.len() != self.len() {
            return Err(DtwError::DimensionMismatch {
                name: "out".into(),
                expected: self.len(),
                got: out.len(),
            });
        }
        let q = view.query_len(n);
        let x = &query[(n - q) * dim..];
        let mut scratch = Vec::new();
        for (i, o) in out.iter_mut().enumerate() {
            let cols = view.ref_len(n, self.inner.lens[i]);
            let problem = self.problem(i, x, cols, settings);
            *o = kernel::dtw_cost(self.inner.isa, &problem, &mut scratch);
        }
        Ok(())
    }

    /// The batch problem `x` against the last `cols` elements of reference `i`.
    pub(crate) fn problem<'a>(&'a self, i: usize, x: &'a [f32], cols: usize, settings: &Dtw) -> Problem<'a> {
        let inner = &*self.inner;
        let stride = inner.lens[i] + 2 * PAD;
        let start = inner.rev_start[i];
        let y = RevSeq { data: &inner.rev[start..start + inner.dim * stride], stride };
        Problem {
            x,
            y,
            dim: inner.dim,
            cols,
            band: settings.band,
            max_cost: settings.threshold(),
            metric: settings.metric,
        }
    }
}

/// Checks one query element before it is pushed.
pub(crate) fn check_element(x: &[f32], dim: usize) -> Result<()> {
    if x.len() != dim {
        return Err(DtwError::DimensionMismatch {
            name: "pushed element".into(),
            expected: dim,
            got: x.len(),
        });
    }
    check_finite("pushed element", x)
}
