//! The authors' choice of N demonstrations of a group "for diversity" (their
//! `util/demonstration.py`, `sample_demonstrations`; docs/SPEC.md section 10): farthest-point
//! selection over the pairwise FastDTW costs of the group's sequences.
//!
//! - The cost of two demonstrations `i < j` is `fastdtw(seq_i, seq_j)` with the package's
//!   defaults (radius 1, L1), over their whole sequences (no cap), one element per transition
//!   (`o_0 .. o_{N-1}` in state mode, `concat(o_t, a_t)` in state-action mode).
//! - The first two chosen are the most distant pair; then, repeatedly, the demonstration with the
//!   largest mean cost to those already chosen.
//! - Ties go to the lowest position in the group (file order), the pair to the lowest `i`, then
//!   the lowest `j`: what their strict `>` scans in that order give. Their code breaks where ours
//!   goes on (all costs 0, `n = 1`, a group of one): see [`farthest_point`].
//!
//! The rule is greedy, so the first `k` of the order for `n` are the order for `k`: a file whose
//! groups are written in this order gives the authors' choice of any `k` as its first `k`.

use defender_dtw::{FastDtw, Metric};
use rayon::prelude::*;

use crate::episode_set::EpisodeSet;
use crate::error::{DefenderError, Result};
use crate::strategy::Mode;

/// A symmetric matrix of pairwise costs, row-major `len x len` (the diagonal is unused).
#[derive(Debug, Clone, PartialEq)]
pub struct PairCosts {
    len: usize,
    costs: Vec<f64>,
}

impl PairCosts {
    /// The matrix from a function of the pairs `i < j` (called once per pair).
    pub fn from_fn(len: usize, cost: impl Fn(usize, usize) -> f64) -> Self {
        let mut costs = vec![0.0; len * len];
        for i in 0..len {
            for j in i + 1..len {
                let c = cost(i, j);
                costs[i * len + j] = c;
                costs[j * len + i] = c;
            }
        }
        Self { len, costs }
    }

    /// The authors' costs of `seqs` (row-major sequences of `dim`-vectors): `fastdtw(seq_i,
    /// seq_j)` with radius 1 and the L1 distance, computed in parallel.
    ///
    /// # Errors
    /// A DTW error for an empty or malformed sequence.
    pub fn fastdtw(seqs: &[&[f32]], dim: usize) -> Result<Self> {
        let len = seqs.len();
        let settings = FastDtw::new(1, Metric::L1);
        let pairs: Vec<(usize, usize)> = (0..len).flat_map(|i| (i + 1..len).map(move |j| (i, j))).collect();
        let values: Vec<f64> = pairs
            .par_iter()
            .map(|&(i, j)| settings.distance(seqs[i], seqs[j], dim))
            .collect::<std::result::Result<_, _>>()?;
        let mut costs = vec![0.0; len * len];
        for (&(i, j), &c) in pairs.iter().zip(&values) {
            costs[i * len + j] = c;
            costs[j * len + i] = c;
        }
        Ok(Self { len, costs })
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there is no item.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The cost of items `i` and `j`.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.costs[i * self.len + j]
    }
}

/// The first `min(n, len)` items in farthest-point order: the most distant pair `(i, j)`, `i <
/// j`, as `[i, j]`, then repeatedly the item of largest mean cost to those chosen; ties to the
/// lowest index (the pair: lowest `i`, then lowest `j`).
///
/// Where the authors' code breaks, this goes on: with `n = 1` theirs returns the pair (two
/// items), this the pair's first; with every cost 0 theirs fails, this takes the lowest indices;
/// a single item is itself. With `n > len` theirs returns every item in file order, this every
/// item in farthest-point order (the same set).
pub fn farthest_point(costs: &PairCosts, n: usize) -> Vec<usize> {
    let len = costs.len();
    let n = n.min(len);
    if n == 0 {
        return Vec::new();
    }
    if len == 1 {
        return vec![0];
    }
    let (mut a, mut b, mut worst) = (0, 1, f64::NEG_INFINITY);
    for i in 0..len {
        for j in i + 1..len {
            if costs.get(i, j) > worst {
                (a, b, worst) = (i, j, costs.get(i, j));
            }
        }
    }
    let mut chosen = vec![a, b];
    chosen.truncate(n);
    // Running sums of each item's costs to the chosen ones (the mean's order of summation is the
    // order of choice, as numpy's mean over their list).
    let mut sums: Vec<f64> = (0..len).map(|k| chosen.iter().map(|&c| costs.get(k, c)).sum()).collect();
    let mut taken = vec![false; len];
    for &c in &chosen {
        taken[c] = true;
    }
    while chosen.len() < n {
        let count = chosen.len() as f64;
        let mut best: Option<(usize, f64)> = None;
        for k in (0..len).filter(|&k| !taken[k]) {
            let mean = sums[k] / count;
            if best.is_none_or(|(_, m)| mean > m) {
                best = Some((k, mean));
            }
        }
        let Some((k, _)) = best else { break };
        taken[k] = true;
        chosen.push(k);
        for (s, row) in sums.iter_mut().zip(0..len) {
            *s += costs.get(row, k);
        }
    }
    chosen
}

/// Per group of `set`, the positions in the group (file order) of the first `n` in the authors'
/// diversity order, computed on the groups' sequences of `mode`, one element per transition:
/// `(safe, unsafe)`. A group with fewer than `n` gives all of its members, as their code does.
///
/// # Errors
/// `n = 0`; a DTW error for unusable sequences.
pub fn diverse_order(set: &EpisodeSet, n: usize, mode: Mode) -> Result<(Vec<usize>, Vec<usize>)> {
    if n == 0 {
        return Err(DefenderError::Config("the number of demonstrations per group must be >= 1".into()));
    }
    let dim = mode.element_dim(set.obs_dim(), set.act_dim());
    let group = |crashed: bool| -> Result<Vec<usize>> {
        let seqs: Vec<Vec<f32>> = set
            .episodes()
            .filter(|e| e.crashed == crashed)
            .map(|e| {
                let mut s = e.sequence(mode);
                s.truncate(e.len() * dim);
                s
            })
            .collect();
        let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
        Ok(farthest_point(&PairCosts::fastdtw(&slices, dim)?, n))
    };
    Ok((group(false)?, group(true)?))
}

/// The demonstrations a run uses under the authors' rule: per group, the first `n` of
/// [`diverse_order`] in that order, the safe group's first (a group with fewer keeps all).
/// The result names the same source; its meta says how it was chosen.
///
/// # Errors
/// As [`diverse_order`].
pub fn select_diverse(set: &EpisodeSet, n: usize, mode: Mode) -> Result<EpisodeSet> {
    let (safe, unsafe_) = diverse_order(set, n, mode)?;
    let safe_idx: Vec<usize> = set.safe().map(|e| e.index).collect();
    let unsafe_idx: Vec<usize> = set.unsafe_().map(|e| e.index).collect();
    let order: Vec<usize> =
        safe.iter().map(|&k| safe_idx[k]).chain(unsafe_.iter().map(|&k| unsafe_idx[k])).collect();
    let mut out = set.reordered(&order)?;
    out.meta_mut().extra.insert(
        "demo_choice".into(),
        format!(
            "diverse: {n} per group by farthest-point selection over pairwise FastDTW (radius 1, L1) of \
             the {mode} sequences, one element per transition"
        )
        .into(),
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode_set::Meta;

    /// Points on a line: the cost is the distance.
    fn line(points: &[f64]) -> PairCosts {
        PairCosts::from_fn(points.len(), |i, j| (points[i] - points[j]).abs())
    }

    #[test]
    fn farthest_point_on_a_hand_computed_case() {
        // Points 0, 1, 5, 9, 10. Most distant pair: (0, 10) = indices (0, 4).
        // Next, mean distance to {0, 10}: 1 -> (1 + 9) / 2 = 5, 5 -> 5, 9 -> 5: a three-way tie,
        // broken by the lowest index: 1 (point 1).
        // Then, to {0, 10, 1}: 5 -> (5 + 5 + 4) / 3 = 4.67, 9 -> (9 + 1 + 8) / 3 = 6: index 3.
        let c = line(&[0.0, 1.0, 5.0, 9.0, 10.0]);
        assert_eq!(farthest_point(&c, 5), [0, 4, 1, 3, 2]);
        // Greedy: every shorter order is a prefix.
        for n in 0..=5 {
            assert_eq!(farthest_point(&c, n), farthest_point(&c, 5)[..n]);
        }
        assert_eq!(farthest_point(&c, 9), [0, 4, 1, 3, 2], "n beyond the group: all");
    }

    #[test]
    fn ties_go_to_the_lowest_indices_and_degenerate_groups_still_choose() {
        // Two pairs at the largest cost 4: (0, 2) comes first in row-major order, not (1, 3);
        // then items 1 and 3 tie at mean 1: the lower, 1.
        let c = PairCosts::from_fn(4, |i, j| if (i, j) == (0, 2) || (i, j) == (1, 3) { 4.0 } else { 1.0 });
        assert_eq!(farthest_point(&c, 4), [0, 2, 1, 3]);
        let zero = PairCosts::from_fn(3, |_, _| 0.0);
        assert_eq!(farthest_point(&zero, 3), [0, 1, 2]);
        assert_eq!(farthest_point(&line(&[3.0]), 2), [0]);
        assert_eq!(farthest_point(&line(&[]), 2), Vec::<usize>::new());
    }

    #[test]
    fn the_costs_are_the_packages_fastdtw_of_each_pair() {
        // fastdtw([1, 2, 3, 4, 5], [2, 3, 4]) == 2.0 (the package's docstring example).
        let (x, y) = ([1.0f32, 2.0, 3.0, 4.0, 5.0], [2.0f32, 3.0, 4.0]);
        let c = PairCosts::fastdtw(&[&x, &y], 1).unwrap();
        assert_eq!((c.get(0, 1), c.get(1, 0)), (2.0, 2.0));
    }

    #[test]
    fn a_set_keeps_each_groups_chosen_in_order() {
        // Safe episodes (1-D) at levels 0, 1, 5, 9, 10; unsafe at 0 and 3; each 2 transitions.
        let mut set = EpisodeSet::new(1, 1, Meta::default()).unwrap();
        for (v, crashed) in [(0.0, false), (0.0, true), (1.0, false), (5.0, false), (3.0, true), (9.0, false)]
            .into_iter()
            .chain([(10.0, false)])
        {
            // The final observation differs wildly: one element per transition leaves it out.
            set.push_episode(&[v, v, 100.0], &[0.0, 0.0], &[v, v], crashed).unwrap();
        }
        let chosen = select_diverse(&set, 3, Mode::State).unwrap();
        let levels: Vec<(f32, bool)> = chosen.episodes().map(|e| (e.obs[0], e.crashed)).collect();
        assert_eq!(levels, [(0.0, false), (10.0, false), (1.0, false), (0.0, true), (3.0, true)]);
        assert!(chosen.meta().extra["demo_choice"].as_str().unwrap().starts_with("diverse: 3"));
        assert!(select_diverse(&set, 0, Mode::State).is_err());
    }
}
