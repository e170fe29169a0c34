//! FastDTW of one query against many fixed references (the demonstrations), for every step of
//! an episode: each reference's coarsened levels are computed once, the scratch is kept between
//! calls, so a call allocates nothing once it has seen its longest inputs.

use std::sync::Arc;

use crate::error::{DtwError, Result, check_sequence};
use crate::fastdtw::FastDtw;
use crate::isa::{Isa, isa};
use crate::pyramid::Pyramid;
use crate::solver::Solver;
use crate::view::{RefWindow, View};

/// Reference sequences prepared for FastDTW, with the scratch of the computation.
///
/// Cloning shares the prepared references and gives the clone its own scratch (one per thread).
///
/// ```
/// use defender_dtw::{FastDtw, FastReferences, QueryWindow, RefWindow, View};
/// let (safe, unsafe_) = ([0.0_f32, 1.0, 2.0, 3.0], [5.0_f32, 5.0, 5.0]); // dimension 1
/// let mut refs = FastReferences::new(1, &[&safe[..], &unsafe_[..]], FastDtw::default())?;
/// let all = View::new(QueryWindow::All, RefWindow::All);
/// let mut costs = [0.0; 2];
/// refs.costs_into(&[0.0, 1.0, 2.5], &all, &mut costs)?;
/// assert_eq!(costs, [1.0, 11.5]); // the package's fastdtw(query, safe) and (query, unsafe_)
/// assert_eq!(costs[1], FastDtw::default().distance(&[0.0, 1.0, 2.5], &unsafe_, 1)?);
/// # Ok::<(), defender_dtw::DtwError>(())
/// ```
#[derive(Debug, Clone)]
pub struct FastReferences {
    shared: Arc<Shared>,
    isa: Isa,
    solver: Solver,
    query: Pyramid,
    tail: Pyramid,
}

#[derive(Debug)]
struct Shared {
    settings: FastDtw,
    dim: usize,
    lens: Vec<usize>,
    pyramids: Vec<Pyramid>,
}

impl FastReferences {
    /// Prepares `seqs`, each a row-major sequence of `dim`-vectors (at least one element), for
    /// FastDTW under `settings`.
    ///
    /// # Errors
    /// [`DtwError::NoReferences`] for an empty list, [`DtwError::ZeroDimension`],
    /// [`DtwError::EmptySequence`] / [`DtwError::LengthNotMultiple`] / [`DtwError::NonFinite`]
    /// naming the reference's index.
    pub fn new(dim: usize, seqs: &[&[f32]], settings: FastDtw) -> Result<Self> {
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
        let pyramids = seqs.iter().map(|s| Pyramid::new(s, dim)).collect();
        let shared = Shared { settings, dim, lens, pyramids };
        Ok(Self {
            shared: Arc::new(shared),
            isa: isa(),
            solver: Solver::default(),
            query: Pyramid::default(),
            tail: Pyramid::default(),
        })
    }

    /// The settings every cost is computed with.
    #[must_use]
    pub fn settings(&self) -> FastDtw {
        self.shared.settings
    }

    /// The dimension of every element.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.shared.dim
    }

    /// The number of references.
    #[must_use]
    pub fn len(&self) -> usize {
        self.shared.lens.len()
    }

    /// Always false: a reference set holds at least one sequence.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.shared.lens.is_empty()
    }

    /// The length (number of elements) of each reference, in order.
    #[must_use]
    pub fn lengths(&self) -> &[usize] {
        &self.shared.lens
    }

    /// The FastDTW cost of `query` (row-major, [`FastReferences::dim`] values per element)
    /// against every reference, in the windows `view` selects (as
    /// [`crate::References::align_view_into`]: `n` is the whole query's length for
    /// [`RefWindow::MatchQuery`]), written to `out[i]`. A window is coarsened from its own first
    /// element, as the package does with a sliced array, so `RefWindow::Last(w)` is not a part of
    /// the whole reference's computation.
    ///
    /// # Errors
    /// [`DtwError::DimensionMismatch`] if `out.len()` is not the number of references; for the
    /// query, [`DtwError::EmptySequence`], [`DtwError::LengthNotMultiple`],
    /// [`DtwError::NonFinite`]; [`DtwError::InvalidSetting`] for a `Last(0)` window;
    /// [`DtwError::NoWarpingPath`] (naming the reference) where the package fails (radius 0).
    pub fn costs_into(&mut self, query: &[f32], view: &View, out: &mut [f64]) -> Result<()> {
        view.check(0)?;
        let shared = &*self.shared;
        let dim = shared.dim;
        let n = check_sequence("query", query, dim)?;
        if out.len() != shared.lens.len() {
            return Err(DtwError::DimensionMismatch {
                name: "out".into(),
                expected: shared.lens.len(),
                got: out.len(),
            });
        }
        let q = view.query_len(n);
        self.query.rebuild(&query[(n - q) * dim..], dim);
        let FastDtw { radius, metric } = shared.settings;
        for (i, (o, y)) in out.iter_mut().zip(&shared.pyramids).enumerate() {
            let m = shared.lens[i];
            let cols = view.ref_len(n, m);
            let y = if cols == m || view.reference == RefWindow::All {
                y
            } else {
                self.tail.rebuild_tail(y, cols);
                &self.tail
            };
            *o = self.solver.fastdtw(self.isa, &self.query, y, radius, metric).ok_or_else(|| {
                DtwError::NoWarpingPath { name: format!("reference {i}"), n: q, m: cols, radius }
            })?;
        }
        Ok(())
    }

    /// [`FastReferences::costs_into`] into a new vector.
    ///
    /// # Errors
    /// As [`FastReferences::costs_into`].
    pub fn costs(&mut self, query: &[f32], view: &View) -> Result<Vec<f64>> {
        let mut out = vec![0.0; self.len()];
        self.costs_into(query, view, &mut out)?;
        Ok(out)
    }
}
