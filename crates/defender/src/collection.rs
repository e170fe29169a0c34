//! The paper's demonstration-collection rule: an agent is trained and, after every training
//! episode, one episode of its current policy is recorded; which of those become safe and unsafe
//! demonstrations, and how N of each are spread over the run.
//!
//! - An episode is a **candidate** once the agent has started learning (its training episode
//!   ended past `learning_starts` steps); before that the policy is the same untrained network
//!   after every episode, and its episodes are copies of one demonstration.
//! - A candidate is **unsafe** when the environment terminated it before the horizon (SPEC
//!   section 6), safe otherwise.
//! - Training may stop once both groups hold enough candidates (and a minimum of steps has
//!   passed); then N of each group are taken at **evenly spaced positions** of its candidates in
//!   the order they were made, first and last included, so that each group spans the whole run.
//!
//! Why this rule (and what went wrong with the first N crashes): docs/decisions.md,
//! "Demonstrations". `defender demos collect` drives it with SAC; any front can drive it with
//! its own agent and environment.

use std::path::PathBuf;

use crate::{DefenderError, EpisodeRecorder, EpisodeSet, Meta, Result};

/// How many demonstrations of each group to keep, and when recording starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CollectionTarget {
    /// Safe demonstrations to keep (>= 1).
    pub safe: usize,
    /// Unsafe demonstrations to keep (>= 1).
    pub unsafe_: usize,
    /// The agent's random-action steps before its first update: no candidate before them.
    pub learning_starts: u64,
    /// Train at least this many steps before the collection may stop (more candidates to spread
    /// over).
    pub min_steps: u64,
}

/// The candidates recorded so far, with the training episode each was recorded after.
#[derive(Debug, Clone)]
pub struct Candidates {
    target: CollectionTarget,
    pool: EpisodeSet,
    /// The training episode after which each pool entry was recorded.
    sources: Vec<u64>,
}

impl Candidates {
    /// An empty pool for a task.
    ///
    /// # Errors
    /// A group of zero demonstrations (the filter needs both), or zero dimensions.
    pub fn new(target: CollectionTarget, meta: Meta, obs_dim: usize, act_dim: usize) -> Result<Self> {
        if target.safe == 0 || target.unsafe_ == 0 {
            return Err(DefenderError::Mismatch {
                what: "demonstrations to collect per group".into(),
                expected: "at least 1 safe and 1 unsafe (DEFENDER needs both groups)".into(),
                got: format!("{} safe and {} unsafe", target.safe, target.unsafe_),
            });
        }
        Ok(Self { target, pool: EpisodeSet::new(obs_dim, act_dim, meta)?, sources: Vec::new() })
    }

    /// Whether the episode of the current policy recorded after a training episode that ended at
    /// `total_steps` is a candidate: only once the agent has started learning.
    pub fn is_candidate(&self, total_steps: u64) -> bool {
        total_steps > self.target.learning_starts
    }

    /// Adds a recorded episode of the policy (after training episode `after_episode`);
    /// `terminated` is whether the environment ended it before the horizon (unsafe).
    ///
    /// # Errors
    /// The recorder's episode does not fit the pool's dimensions.
    pub fn add(
        &mut self,
        recorder: &mut EpisodeRecorder,
        terminated: bool,
        after_episode: u64,
    ) -> Result<()> {
        recorder.finish(&mut self.pool, terminated)?;
        self.sources.push(after_episode);
        Ok(())
    }

    /// Candidates of each group so far: `(safe, unsafe)`.
    pub fn group_sizes(&self) -> (usize, usize) {
        self.pool.group_sizes()
    }

    /// Candidates so far.
    pub fn len(&self) -> usize {
        self.pool.len()
    }

    /// Whether no candidate was recorded yet.
    pub fn is_empty(&self) -> bool {
        self.pool.is_empty()
    }

    /// Whether training may stop after `total_steps`: both groups hold enough candidates and the
    /// minimum of steps has passed.
    pub fn enough(&self, total_steps: u64) -> bool {
        let (safe, unsafe_) = self.pool.group_sizes();
        safe >= self.target.safe && unsafe_ >= self.target.unsafe_ && total_steps >= self.target.min_steps
    }

    /// The demonstration set: N of each group at evenly spaced positions of the candidates, in the
    /// order they were made; the rule, the source training episodes, `training_steps` and
    /// `learning_starts` go into `meta.extra`, `provenance` as given.
    ///
    /// # Errors
    /// [`DefenderError::NotEnoughDemos`] when a group has fewer candidates than asked.
    pub fn select(&self, training_steps: u64, provenance: String) -> Result<EpisodeSet> {
        let (safe, unsafe_) = self.pool.group_sizes();
        for (group, asked, available) in
            [("safe", self.target.safe, safe), ("unsafe", self.target.unsafe_, unsafe_)]
        {
            if available < asked {
                return Err(DefenderError::NotEnoughDemos {
                    path: PathBuf::from(format!("<candidates after {training_steps} training steps>")),
                    setting: "the collection",
                    group,
                    asked,
                    available,
                });
            }
        }
        let by_group = |crashed: bool| -> Vec<usize> {
            (0..self.pool.len()).filter(|&i| self.pool.episode(i).crashed == crashed).collect()
        };
        let mut chosen = spread(&by_group(false), self.target.safe);
        chosen.extend(spread(&by_group(true), self.target.unsafe_));
        chosen.sort_unstable();
        let mut meta = self.pool.meta().clone();
        meta.provenance = Some(provenance);
        meta.extra.insert(
            "selection".into(),
            "per group, evenly spaced positions (first and last included) among the candidates in order"
                .into(),
        );
        meta.extra.insert(
            "source_training_episodes".into(),
            chosen.iter().map(|&i| self.sources[i]).collect::<Vec<u64>>().into(),
        );
        meta.extra.insert("training_steps".into(), training_steps.into());
        meta.extra.insert("learning_starts".into(), self.target.learning_starts.into());
        let mut set = EpisodeSet::new(self.pool.obs_dim(), self.pool.act_dim(), meta)?;
        for i in chosen {
            let e = self.pool.episode(i);
            set.push_episode(e.obs, e.act, e.rew, e.crashed)?;
        }
        Ok(set)
    }
}

/// `n` of `items` at evenly spaced positions, first and last included (`1 <= n <= len`; `n = 1`
/// takes the last, the most trained policy's).
pub fn spread(items: &[usize], n: usize) -> Vec<usize> {
    match n {
        0 => Vec::new(),
        1 => items.last().copied().into_iter().collect(),
        _ => (0..n).map(|k| items[(k * (items.len() - 1) + (n - 1) / 2) / (n - 1)]).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_takes_distinct_evenly_spaced_items_with_both_ends() {
        let items: Vec<usize> = (0..10).collect();
        assert_eq!(spread(&items, 10), items);
        assert_eq!(spread(&items, 2), vec![0, 9]);
        assert_eq!(spread(&items, 4), vec![0, 3, 6, 9]);
        assert_eq!(spread(&items, 1), vec![9]);
        assert_eq!(spread(&items, 0), Vec::<usize>::new());
        let s = spread(&items, 7);
        assert!(s.windows(2).all(|w| w[0] < w[1]) && s[0] == 0 && s[6] == 9);
    }

    fn episode(recorder: &mut EpisodeRecorder, value: f64, len: usize) {
        recorder.start(&[value]);
        for _ in 0..len {
            recorder.step(&[0.0], -1.0, &[value]).unwrap();
        }
    }

    #[test]
    fn candidates_are_spread_per_group_with_their_sources() {
        let target = CollectionTarget { safe: 2, unsafe_: 2, learning_starts: 100, min_steps: 0 };
        let mut c = Candidates::new(target, Meta::default(), 1, 1).unwrap();
        assert!(!c.is_candidate(100) && c.is_candidate(101));
        let mut rec = EpisodeRecorder::new();
        // Training episodes 10..16: unsafe, safe, unsafe, safe, unsafe, safe.
        for (k, source) in (10..16).enumerate() {
            episode(&mut rec, source as f64, 3);
            c.add(&mut rec, k % 2 == 0, source).unwrap();
            assert_eq!(c.enough(1000), k >= 3);
        }
        assert!(!c.enough(0) || target.min_steps == 0);
        let set = c.select(1000, "test".into()).unwrap();
        assert_eq!(set.group_sizes(), (2, 2));
        // Safe candidates 11, 13, 15 -> 11, 15; unsafe 10, 12, 14 -> 10, 14; in recorded order.
        let sources: Vec<f32> = set.episodes().map(|e| e.obs[0]).collect();
        assert_eq!(sources, [10.0, 11.0, 14.0, 15.0]);
        assert_eq!(set.meta().provenance.as_deref(), Some("test"));
        assert_eq!(set.meta().extra["source_training_episodes"], serde_json::json!([10, 11, 14, 15]));
        assert_eq!(set.meta().extra["learning_starts"], serde_json::json!(100));
    }

    #[test]
    fn too_few_candidates_and_empty_groups_are_errors() {
        let zero = CollectionTarget { safe: 0, unsafe_: 1, learning_starts: 0, min_steps: 0 };
        assert!(Candidates::new(zero, Meta::default(), 1, 1).is_err());
        let target = CollectionTarget { safe: 1, unsafe_: 2, learning_starts: 0, min_steps: 10 };
        let mut c = Candidates::new(target, Meta::default(), 1, 1).unwrap();
        let mut rec = EpisodeRecorder::new();
        episode(&mut rec, 0.0, 2);
        c.add(&mut rec, true, 1).unwrap();
        episode(&mut rec, 0.0, 2);
        c.add(&mut rec, false, 2).unwrap();
        let err = c.select(50, "x".into()).unwrap_err().to_string();
        assert!(err.contains("unsafe") && err.contains("only 1"), "{err}");
        episode(&mut rec, 0.0, 2);
        c.add(&mut rec, true, 3).unwrap();
        assert!(!c.enough(9) && c.enough(10));
    }
}
