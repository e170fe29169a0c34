//! The windowed costs of one group of demonstrations against the trajectory so far, step by step,
//! whatever the cost options: SPEC's exact Euclidean DTW over the whole trajectory is
//! incremental (`defender_dtw::Stream`); any other cost (FastDTW, the L1 distance, a trajectory
//! cap) is recomputed from the last `trajectory_cap` elements at every step, which a cap keeps
//! bounded (docs/benchmarks-core.md, "FastDTW: one filter step of the authors' profile").

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
            Self::Recompute(r) => r.push(x),
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
}

impl Recompute {
    pub(crate) fn new(
        seqs: Arc<Vec<Vec<f32>>>,
        dim: usize,
        windows: &[Window],
        options: CostOptions,
    ) -> Self {
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
        }
    }

    fn reset(&mut self) {
        self.traj.clear();
        self.pushed = 0;
    }

    fn push(&mut self, x: &[f32]) -> Result<()> {
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
                *cost = pair_cost(&self.options, x, y, dim)? as f32;
            }
        }
        Ok(())
    }
}

/// The cost of aligning the trajectory window `x` with the demonstration window `y` (row-major
/// `dim`-vectors) under `options`. FastDTW is not symmetric on ties: it is called as the authors'
/// code calls it, `fastdtw(demonstration, trajectory)`.
pub(crate) fn pair_cost(options: &CostOptions, x: &[f32], y: &[f32], dim: usize) -> Result<f64> {
    let metric = match options.metric {
        Metric::L2 => defender_dtw::Metric::L2,
        Metric::L1 => defender_dtw::Metric::L1,
    };
    Ok(match options.dtw {
        DtwKind::Exact => f64::from(defender_dtw::Dtw::euclidean().with_metric(metric).distance(x, y, dim)?),
        DtwKind::Fastdtw => defender_dtw::FastDtw::new(options.radius, metric).distance(y, x, dim)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact(x: &[f32], y: &[f32], dim: usize, metric: Metric) -> f32 {
        let options = CostOptions { metric, trajectory_cap: Some(100), ..CostOptions::default() };
        pair_cost(&options, x, y, dim).unwrap() as f32
    }

    #[test]
    fn exact_costs_follow_the_metric() {
        assert_eq!(exact(&[1.0, 5.0], &[0.0, 0.0, 0.0], 1, Metric::L2), 7.0);
        let a = [0.0f32, 0.0, 3.0, 4.0];
        let b = [0.0f32, 0.0];
        assert_eq!(exact(&a, &b, 2, Metric::L2), 5.0);
        assert_eq!(exact(&a, &b, 2, Metric::L1), 7.0);
        let fast = CostOptions { dtw: DtwKind::Fastdtw, metric: Metric::L1, ..CostOptions::default() };
        // The package's docstring example: fastdtw([1, 2, 3, 4, 5], [2, 3, 4]) == 2.0.
        let x = [2.0f32, 3.0, 4.0];
        let y = [1.0f32, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(pair_cost(&fast, &x, &y, 1).unwrap(), 2.0);
    }

    #[test]
    fn a_capped_stream_aligns_only_the_last_elements() {
        let seqs = Arc::new(vec![vec![0.0f32, 0.0, 0.0], vec![10.0, 10.0]]);
        let options = CostOptions { trajectory_cap: Some(2), metric: Metric::L1, ..CostOptions::default() };
        let mut r = Recompute::new(seqs, 1, &[Window::Both, Window::BothW5], options);
        for v in [100.0f32, 1.0, 2.0] {
            r.push(&[v]).unwrap();
        }
        // The cap keeps [1, 2].
        assert_eq!(r.costs[0][0], exact(&[1.0, 2.0], &[0.0, 0.0, 0.0], 1, Metric::L1));
        assert_eq!(r.costs[0][1], exact(&[1.0, 2.0], &[10.0, 10.0], 1, Metric::L1));
        assert_eq!(r.pushed, 3);
        r.reset();
        assert_eq!((r.pushed, r.traj.len()), (0, 0));
    }
}
