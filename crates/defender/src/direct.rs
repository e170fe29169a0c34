//! The direct implementation of SPEC sections 2, 3, 4 and 7: every window of every step of every
//! strategy recomputed from scratch with the textbook DTW recursion in f64. Slow (cubic per
//! episode and strategy) and shared with nothing, it exists to cross-check the incremental filter
//! and the work-sharing ablation in tests, on small sets.

use crate::episode_set::{Episode, EpisodeSet};
use crate::filter::Decision;
use crate::score::{AblationRow, StrategyTally, rank};
use crate::strategy::{Mode, Strategy};

/// SPEC section 2's DTW by its definition: `c(i, j) = ||x_i - y_j||_2`, `D(0, 0) = c(0, 0)`,
/// `D(i, j) = c(i, j) + min(D(i-1, j), D(i, j-1), D(i-1, j-1))`, result `D(n-1, m-1)`.
/// `x` and `y` are row-major sequences of `dim`-vectors; an empty one gives `+inf`.
pub fn naive_dtw(x: &[f32], y: &[f32], dim: usize) -> f64 {
    let (n, m) = (x.len() / dim, y.len() / dim);
    if n == 0 || m == 0 {
        return f64::INFINITY;
    }
    let mut d = vec![f64::INFINITY; n * m];
    for i in 0..n {
        for j in 0..m {
            let c = x[i * dim..(i + 1) * dim]
                .iter()
                .zip(&y[j * dim..(j + 1) * dim])
                .map(|(a, b)| (f64::from(*a) - f64::from(*b)).powi(2))
                .sum::<f64>()
                .sqrt();
            let best = if i == 0 && j == 0 {
                0.0
            } else {
                let up = if i > 0 { d[(i - 1) * m + j] } else { f64::INFINITY };
                let left = if j > 0 { d[i * m + j - 1] } else { f64::INFINITY };
                let diag = if i > 0 && j > 0 { d[(i - 1) * m + j - 1] } else { f64::INFINITY };
                up.min(left).min(diag)
            };
            d[i * m + j] = c + best;
        }
    }
    d[n * m - 1]
}

/// `Safe(tau)` or `Unsafe(tau)` by definition: the method's window of `x` (row-major, `dim`) against
/// each demonstration of `group`, by [`naive_dtw`], reduced by the method's aggregation in f64.
pub fn group_value(method: crate::method::Method, x: &[f32], group: &[Vec<f32>], dim: usize) -> f64 {
    let n = x.len() / dim;
    let costs: Vec<f64> = group
        .iter()
        .map(|y| {
            let (xr, yr) = method.window.ranges(n, y.len() / dim);
            naive_dtw(&x[xr.start * dim..xr.end * dim], &y[yr.start * dim..yr.end * dim], dim)
        })
        .collect();
    use crate::method::Aggregation::*;
    match method.aggregation {
        Min => costs.iter().copied().fold(f64::INFINITY, f64::min),
        Max => costs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        Mean => costs.iter().sum::<f64>() / costs.len() as f64,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn naive_dtw_matches_hand_computed_values() {
        // x = [1, 5], y = [0, 0, 0]: D = [[1, 2, 3], [6, 6, 7]].
        assert_eq!(naive_dtw(&[1., 5.], &[0., 0., 0.], 1), 7.0);
        assert_eq!(naive_dtw(&[0., 0., 3., 4.], &[0., 0.], 2), 5.0);
        assert_eq!(naive_dtw(&[], &[1.], 1), f64::INFINITY);
        // Symmetric, and zero on identical sequences.
        let a = [0.3f32, 1.2, -0.5, 2.0];
        let b = [1.0f32, 0.1, 0.7];
        assert_eq!(naive_dtw(&a, &b, 1), naive_dtw(&b, &a, 1));
        assert_eq!(naive_dtw(&a, &a, 1), 0.0);
    }
}
