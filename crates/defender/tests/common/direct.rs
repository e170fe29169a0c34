//! The direct implementation of SPEC sections 2, 3, 4 and 7 (a test oracle): every window of every step of every
//! strategy recomputed from scratch with the textbook DTW recursion in f64. Slow (cubic per
//! episode and strategy) and shared with nothing, it exists to cross-check the incremental filter
//! and the work-sharing ablation in tests, on small sets.

#![allow(dead_code)] // each test file uses a part

use defender::{
    AblationRow, Aggregation, Decision, Episode, EpisodeSet, Method, Mode, Strategy, StrategyTally, rank,
};
use defender_dtw::oracle::naive_dtw;

/// `Safe(tau)` or `Unsafe(tau)` by definition: the method's window of `x` (row-major, `dim`) against
/// each demonstration of `group`, by `defender_dtw::oracle::naive_dtw`, reduced by the method's aggregation in f64.
pub fn group_value(method: Method, x: &[f32], group: &[Vec<f32>], dim: usize) -> f64 {
    let n = x.len() / dim;
    let costs: Vec<f64> = group
        .iter()
        .map(|y| {
            let (xr, yr) = method.window.ranges(n, y.len() / dim);
            naive_dtw(&x[xr.start * dim..xr.end * dim], &y[yr.start * dim..yr.end * dim], dim, None)
        })
        .collect();
    match method.aggregation {
        Aggregation::Min => costs.iter().copied().fold(f64::INFINITY, f64::min),
        Aggregation::Max => costs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        Aggregation::Mean => costs.iter().sum::<f64>() / costs.len() as f64,
    }
}

/// One decision per step of `episode` under `strategy`, by definition, until the first filtered
/// step (included).
pub fn decisions(strategy: Strategy, mode: Mode, demos: &EpisodeSet, episode: Episode<'_>) -> Vec<Decision> {
    let dim = mode.element_dim(demos.obs_dim(), demos.act_dim());
    let safe: Vec<Vec<f32>> = demos.safe().map(|e| e.sequence(mode)).collect();
    let unsafe_: Vec<Vec<f32>> = demos.unsafe_().map(|e| e.sequence(mode)).collect();
    let seq = episode.sequence(mode);
    let mut out = Vec::new();
    for t in 0..episode.len() {
        let x = &seq[..(t + 1) * dim];
        let d = Decision::new(
            group_value(strategy.safe, x, &safe, dim),
            group_value(strategy.unsafe_, x, &unsafe_, dim),
        );
        out.push(d);
        if d.filtered {
            break;
        }
    }
    out
}

/// The first filtered step `k` of `episode` under `strategy`, by definition.
pub fn first_filtered(
    strategy: Strategy,
    mode: Mode,
    demos: &EpisodeSet,
    episode: Episode<'_>,
) -> Option<usize> {
    decisions(strategy, mode, demos, episode).iter().position(|d| d.filtered)
}

/// SPEC section 7's scores of `strategies`, ranked, by definition.
pub fn ablation(
    demos: &EpisodeSet,
    episodes: &EpisodeSet,
    strategies: &[Strategy],
    mode: Mode,
) -> Vec<AblationRow> {
    let rows = strategies
        .iter()
        .map(|&s| {
            let mut tally = StrategyTally::default();
            for e in episodes.episodes() {
                tally.add(e.len(), e.crashed, first_filtered(s, mode, demos, e));
            }
            tally.row(s, mode)
        })
        .collect();
    rank(rows)
}
