//! How replayed episodes become a strategy's score: SPEC section 7's score, or the one the
//! paper's authors computed (their `util/ablations/dtw_process.py`; docs/SPEC.md section 10).
//!
//! Their score, per recorded episode of `T` steps first filtered at step `k` (0-based), if any:
//! `p = k / T` (not SPEC's `(k + 1) / T`; 0 when the first step is filtered), else 1; an episode
//! shorter than the horizon counts as crashed (their only crash test; SPEC uses the recorded
//! `crashed` flag) and is avoided when filtered at some step; `score = mean(p) * mean(avoided
//! over the crashed episodes)`, or `mean(p)` alone when none is shorter than the horizon. Which
//! episodes are scored (their first 500) is the caller's choice.

use crate::score::{AblationRow, StrategyTally};
use crate::strategy::{Mode, Strategy};

/// Per recorded episode, the first filtered step of every strategy (in the ablation's order): what
/// the ablation (crate::ablation) replays and a scoring scores.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EpisodeReplay {
    /// Number of transitions `T_e` (decisions replayed).
    pub len: usize,
    /// The recorded episode crashed.
    pub crashed: bool,
    /// Per strategy, `k`: the first filtered step, if any.
    pub first_filtered: Vec<Option<usize>>,
}

/// Which score an ablation computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scoring {
    /// SPEC section 7.
    #[default]
    Spec,
    /// The authors' (module docs); episodes shorter than `horizon` steps count as crashed.
    Authors {
        /// The task's horizon (1000 for the three MuJoCo tasks; their code has 1000 written in).
        horizon: usize,
    },
}

impl Scoring {
    /// The name written beside the scores (`spec`, `authors`).
    pub fn name(self) -> &'static str {
        match self {
            Scoring::Spec => "spec",
            Scoring::Authors { .. } => "authors",
        }
    }

    /// One unranked row (rank 0) per strategy, in the order given, from the replays of every
    /// scored episode (`first_filtered` in the strategies' order).
    pub fn rows(self, strategies: &[Strategy], mode: Mode, replays: &[EpisodeReplay]) -> Vec<AblationRow> {
        match self {
            Scoring::Spec => {
                let mut tallies = vec![StrategyTally::default(); strategies.len()];
                for r in replays {
                    for (tally, k) in tallies.iter_mut().zip(&r.first_filtered) {
                        tally.add(r.len, r.crashed, *k);
                    }
                }
                strategies.iter().zip(&tallies).map(|(&s, t)| t.row(s, mode)).collect()
            }
            Scoring::Authors { horizon } => {
                let mut tallies = vec![AuthorsTally::default(); strategies.len()];
                for r in replays {
                    for (tally, k) in tallies.iter_mut().zip(&r.first_filtered) {
                        tally.add(r.len, *k, horizon);
                    }
                }
                strategies.iter().zip(&tallies).map(|(&s, t)| t.row(s, mode)).collect()
            }
        }
    }
}

/// Running sums of one strategy under the authors' score.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AuthorsTally {
    /// Sum of `p`.
    pub p_sum: f64,
    /// Episodes.
    pub episodes: usize,
    /// Episodes shorter than the horizon.
    pub crashed: usize,
    /// Of those, the ones filtered at some step.
    pub avoided: usize,
}

impl AuthorsTally {
    /// Adds one recorded episode of `len` steps, first filtered at step `first_filtered` (if any).
    pub fn add(&mut self, len: usize, first_filtered: Option<usize>, horizon: usize) {
        self.p_sum += match first_filtered {
            Some(k) => k as f64 / len as f64,
            None => 1.0,
        };
        self.episodes += 1;
        if len < horizon {
            self.crashed += 1;
            self.avoided += usize::from(first_filtered.is_some());
        }
    }

    /// The unranked row (rank 0) of `strategy`: `mean_ratio` is `mean(p)`, `safe_rate` the share
    /// of crashed episodes avoided (1 when none crashed, so that `score = mean_ratio *
    /// safe_rate` as in SPEC's rows).
    pub fn row(&self, strategy: Strategy, mode: Mode) -> AblationRow {
        let mean_ratio = self.p_sum / self.episodes.max(1) as f64;
        let safe_rate = if self.crashed == 0 { 1.0 } else { self.avoided as f64 / self.crashed as f64 };
        AblationRow { rank: 0, strategy, mode, mean_ratio, safe_rate, score: mean_ratio * safe_rate }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_authors_tally_follows_their_formula() {
        let s: Strategy = "MinBoth/MinBoth".parse().unwrap();
        let mut t = AuthorsTally::default();
        t.add(10, Some(4), 1000); // crashed (10 < 1000), avoided: p = 4/10
        t.add(10, None, 1000); // crashed, not avoided: p = 1
        t.add(1000, None, 1000); // reached the horizon: p = 1
        t.add(1000, Some(0), 1000); // filtered at once: p = 0
        let r = t.row(s, Mode::State);
        assert_eq!(r.mean_ratio, (0.4 + 1.0 + 1.0 + 0.0) / 4.0);
        assert_eq!(r.safe_rate, 0.5);
        assert_eq!(r.score, r.mean_ratio * 0.5);
        // No episode shorter than the horizon: mean(p) alone.
        let mut none = AuthorsTally::default();
        none.add(5, Some(1), 5);
        let r = none.row(s, Mode::State);
        assert_eq!((r.mean_ratio, r.safe_rate, r.score), (0.2, 1.0, 0.2));
    }

    #[test]
    fn the_two_scorings_differ_where_the_rules_do() {
        let s: Strategy = "MinBoth/MinBoth".parse().unwrap();
        // 4 steps, filtered at step 1, recorded as not crashed, shorter than the horizon 10.
        let replays = [EpisodeReplay { len: 4, crashed: false, first_filtered: vec![Some(1)] }];
        let spec = &Scoring::Spec.rows(&[s], Mode::State, &replays)[0];
        assert_eq!((spec.mean_ratio, spec.safe_rate), (0.5, 1.0));
        let authors = &Scoring::Authors { horizon: 10 }.rows(&[s], Mode::State, &replays)[0];
        assert_eq!((authors.mean_ratio, authors.safe_rate), (0.25, 1.0));
        let never = [EpisodeReplay { len: 4, crashed: false, first_filtered: vec![None] }];
        let authors = &Scoring::Authors { horizon: 10 }.rows(&[s], Mode::State, &never)[0];
        assert_eq!((authors.mean_ratio, authors.safe_rate, authors.score), (1.0, 0.0, 0.0));
        assert_eq!(Scoring::Authors { horizon: 1 }.name(), "authors");
    }
}
