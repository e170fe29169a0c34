//! Which part of the query and of each reference an alignment uses (SPEC section 3).

use crate::error::{DtwError, Result};

/// The part of the query (the agent's trajectory `x`, length `n`) that is aligned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum QueryWindow {
    /// All of `x`.
    All,
    /// `x[-W:]`: the last `min(W, n)` elements.
    Last(usize),
}

/// The part of each reference (a demonstration `y`, length `m`) that is aligned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RefWindow {
    /// All of `y`.
    All,
    /// `y[-W:]`: the last `min(W, m)` elements.
    Last(usize),
    /// `y[-n:]` with `n` the current query length (all of `x`, whatever the query window):
    /// the SPEC's `Equal` window; all of `y` when `n >= m`.
    MatchQuery,
}

/// One alignment view: a query window and a reference window. The SPEC's windows are
/// `Both = (All, All)`, `Equal = (All, MatchQuery)`, `TrajW = (Last(W), All)`,
/// `DemoW = (All, Last(W))`, `BothW = (Last(W), Last(W))`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct View {
    /// The part of the query.
    pub query: QueryWindow,
    /// The part of each reference.
    pub reference: RefWindow,
}

impl View {
    /// A view from its two windows.
    #[must_use]
    pub fn new(query: QueryWindow, reference: RefWindow) -> Self {
        Self { query, reference }
    }

    /// Number of query elements aligned when the query has `n` elements.
    #[must_use]
    pub fn query_len(&self, n: usize) -> usize {
        match self.query {
            QueryWindow::All => n,
            QueryWindow::Last(w) => w.min(n),
        }
    }

    /// Number of elements of a reference of length `m` aligned when the query has `n` elements.
    #[must_use]
    pub fn ref_len(&self, n: usize, m: usize) -> usize {
        match self.reference {
            RefWindow::All => m,
            RefWindow::Last(w) => w.min(m),
            RefWindow::MatchQuery => n.min(m),
        }
    }

    /// Refuses `Last(0)` windows, which would align empty sequences.
    pub(crate) fn check(&self, index: usize) -> Result<()> {
        if self.query == QueryWindow::Last(0) {
            return Err(DtwError::InvalidSetting {
                name: format!("views[{index}].query"),
                reason: "window length must be >= 1, got Last(0)".into(),
            });
        }
        if self.reference == RefWindow::Last(0) {
            return Err(DtwError::InvalidSetting {
                name: format!("views[{index}].reference"),
                reason: "window length must be >= 1, got Last(0)".into(),
            });
        }
        Ok(())
    }
}
