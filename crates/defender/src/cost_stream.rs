//! The windowed costs of one group of demonstrations against the trajectory so far, step by step,
//! whatever the cost options: SPEC's exact Euclidean DTW over the whole trajectory is
//! incremental (`defender_dtw::Stream`); any other cost (FastDTW, the L1 distance, a trajectory
//! cap) is recomputed from the last `trajectory_cap` elements at every step, which a cap keeps
//! bounded (docs/benchmarks.md, "The authors' cost per step").

use std::sync::Arc;

use defender_dtw::Stream;

use crate::cost::{CostOptions, DtwKind, Metric};
use crate::error::Result;
use crate::window::Window;

/// One group's costs for a list of windows (views), updated by [`CostStream::push`].
#[derive(Debug, Clone)]
pub enum CostStream {
    /// SPEC's cost, incremental.
    Exact(Stream),
    /// Any other cost, recomputed per step.
    Recompute(Recompute),
}

impl CostStream {
    /// Steps pushed since the last reset.
    pub fn len(&self) -> usize {
        match self {
            Self::Exact(s) => s.len(),
            Self::Recompute(r) => r.pushed,
        }
    }

    /// True at the start of an episode.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Forgets the trajectory (keeps every buffer).
    pub fn reset(&mut self) {
        match self {
            Self::Exact(s) => s.reset(),
            Self::Recompute(r) => r.reset(),
        }
    }

    /// Appends one trajectory element (already checked to be finite and of the right length)
    /// and updates every view's costs.
    ///
    /// # Errors
    /// A DTW error for a bad element.
    pub fn push(&mut self, x: &[f32]) -> Result<()> {
        match self {
            Self::Exact(s) => Ok(s.push(x)?),
            Self::Recompute(r) => {
                r.push(x);
                Ok(())
            }
        }
    }

    /// The costs of view `view`, one per demonstration of the group (after at least one push).
    pub fn costs(&self, view: usize) -> &[f32] {
        match self {
            Self::Exact(s) => s.costs(view),
            Self::Recompute(r) => &r.costs[view],
        }
    }
}

/// The recomputing engine: the last `cap` trajectory elements, and per view the cost of each
/// demonstration's window against the trajectory's window.
#[derive(Debug, Clone)]
pub struct Recompute {
    seqs: Arc<Vec<Vec<f32>>>,
    dim: usize,
    windows: Vec<Window>,
    options: CostOptions,
    /// The last `cap` elements, row-major (all of them without a cap).
    traj: Vec<f32>,
    pushed: usize,
    costs: Vec<Vec<f32>>,
    scratch: Vec<f64>,
}

impl Recompute {
    pub(crate) fn new(seqs: Arc<Vec<Vec<f32>>>, dim: usize, windows: &[Window], options: CostOptions) -> Self {
        let n = seqs.len();
        let cap = options.trajectory_cap.unwrap_or(0);
        Self {
            seqs,
            dim,
            windows: windows.to_vec(),
            options,
            traj: Vec::with_capacity(cap * dim),
            pushed: 0,
            costs: vec![vec![f32::NAN; n]; windows.len()],
            scratch: Vec::new(),
        }
    }

    fn reset(&mut self) {
        self.traj.clear();
        self.pushed = 0;
    }

    fn push(&mut self, x: &[f32]) {
        self.traj.extend_from_slice(x);
        if let Some(cap) = self.options.trajectory_cap
            && self.traj.len() > cap * self.dim
        {
            self.traj.drain(..self.traj.len() - cap * self.dim);
        }
        self.pushed += 1;
        let dim = self.dim;
        let n = self.traj.len() / dim;
        for (window, costs) in self.windows.iter().zip(&mut self.costs) {
            for (seq, cost) in self.seqs.iter().zip(costs.iter_mut()) {
                let (xr, yr) = window.ranges(n, seq.len() / dim);
                let x = &self.traj[xr.start * dim..xr.end * dim];
                let y = &seq[yr.start * dim..yr.end * dim];
                *cost = pair_cost(&self.options, x, y, dim, &mut self.scratch) as f32;
            }
        }
    }
}

/// The cost of aligning `x` with `y` (row-major `dim`-vectors) under `options`, in f64.
pub(crate) fn pair_cost(options: &CostOptions, x: &[f32], y: &[f32], dim: usize, scratch: &mut Vec<f64>) -> f64 {
    match options.dtw {
        DtwKind::Exact => exact_dtw(x, y, dim, options.metric, scratch),
        DtwKind::Fastdtw => exact_dtw(x, y, dim, options.metric, scratch),
    }
}

/// Exact DTW (SPEC section 2's recursion) under `metric`, one row of the matrix at a time.
fn exact_dtw(x: &[f32], y: &[f32], dim: usize, metric: Metric, row: &mut Vec<f64>) -> f64 {
    let (n, m) = (x.len() / dim, y.len() / dim);
    if n == 0 || m == 0 {
        return f64::INFINITY;
    }
    let dist = |i: usize, j: usize| {
        let (a, b) = (&x[i * dim..(i + 1) * dim], &y[j * dim..(j + 1) * dim]);
        match metric {
            Metric::L2 => a.iter().zip(b).map(|(p, q)| (f64::from(*p) - f64::from(*q)).powi(2)).sum::<f64>().sqrt(),
            Metric::L1 => a.iter().zip(b).map(|(p, q)| (f64::from(*p) - f64::from(*q)).abs()).sum::<f64>(),
        }
    };
    row.clear();
    row.resize(m, f64::INFINITY);
    for i in 0..n {
        let mut diag = if i == 0 { 0.0 } else { f64::INFINITY };
        let mut left = f64::INFINITY;
        for j in 0..m {
            let up = row[j];
            let best = if i == 0 && j == 0 { 0.0 } else { up.min(left).min(diag) };
            let d = dist(i, j) + best;
            diag = up;
            row[j] = d;
            left = d;
        }
    }
    row[m - 1]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_dtw_matches_the_oracle_under_l2_and_hand_values_under_l1() {
        let x = [1.0f32, 5.0];
        let y = [0.0f32, 0.0, 0.0];
        let mut s = Vec::new();
        assert_eq!(exact_dtw(&x, &y, 1, Metric::L2, &mut s), 7.0);
        let a = [0.0f32, 0.0, 3.0, 4.0];
        let b = [0.0f32, 0.0];
        assert_eq!(exact_dtw(&a, &b, 2, Metric::L2, &mut s), 5.0);
        assert_eq!(exact_dtw(&a, &b, 2, Metric::L1, &mut s), 7.0);
        let p: Vec<f32> = (0..21).map(|i| ((i * 7) % 5) as f32 - 2.0).collect();
        let q: Vec<f32> = (0..15).map(|i| ((i * 3) % 4) as f32 * 0.5).collect();
        let oracle = defender_dtw::oracle::naive_dtw(&p, &q, 3, None);
        assert!((exact_dtw(&p, &q, 3, Metric::L2, &mut s) - oracle).abs() < 1e-9);
    }

    #[test]
    fn a_capped_stream_aligns_only_the_last_elements() {
        let seqs = Arc::new(vec![vec![0.0f32, 0.0, 0.0], vec![10.0, 10.0]]);
        let options = CostOptions { trajectory_cap: Some(2), metric: Metric::L1, ..CostOptions::default() };
        let mut r = Recompute::new(seqs, 1, &[Window::Both, Window::BothW5], options);
        for v in [100.0f32, 1.0, 2.0] {
            r.push(&[v]);
        }
        // The cap keeps [1, 2]: against [0,0,0] the path costs 1 + 2 + 2 (or 1+1+2) = 4 at best.
        let mut s = Vec::new();
        let expect = exact_dtw(&[1.0, 2.0], &[0.0, 0.0, 0.0], 1, Metric::L1, &mut s) as f32;
        assert_eq!(r.costs[0][0], expect);
        assert_eq!(r.costs[0][1], exact_dtw(&[1.0, 2.0], &[10.0, 10.0], 1, Metric::L1, &mut s) as f32);
        assert_eq!(r.pushed, 3);
        r.reset();
        assert_eq!((r.pushed, r.traj.len()), (0, 0));
    }
}
