//! The authors' demonstration-collection rule (their `train_sac.py --demonstrate` and
//! `util/demonstration.py`; docs/SPEC.md section 10), beside the project's own
//! ([`crate::collection`]):
//!
//! - A bare agent trains; after every `every`-th training episode (theirs: 50) one episode of
//!   its current stochastic policy, on an environment of its own, becomes a demonstration.
//! - A demonstration is **safe when it lasted the horizon**, unsafe when shorter (their only
//!   test: the length; SPEC section 6 asks whether the environment terminated it).
//! - They keep every demonstration (all go into their DEFENDER agent's replay buffer, and its
//!   `R_task` is the lowest per-step reward over all of them) and choose N per group for the
//!   filter when a run loads them, by [`crate::diversity`]. The set written here holds every
//!   demonstration, each group in that diversity order (of the state sequences), so that the
//!   first N of a group are their choice of N for every N: a run with `num_demos = N` filters
//!   with theirs.

use crate::diversity::diverse_order;
use crate::episode_set::{EpisodeSet, Meta};
use crate::error::{DefenderError, Result};
use crate::recorder::EpisodeRecorder;
use crate::strategy::Mode;

/// Their interval, in training episodes, between two demonstrations (`demonstrate_every`).
pub const AUTHORS_EVERY: u64 = 50;

/// The demonstrations recorded so far, with the training episode each followed.
#[derive(Debug, Clone)]
pub struct AuthorsCollection {
    every: u64,
    horizon: usize,
    pool: EpisodeSet,
    /// The number of training episodes finished when each pool entry was recorded.
    sources: Vec<u64>,
}

impl AuthorsCollection {
    /// An empty collection for a task of `horizon` steps, demonstrating every `every` episodes.
    ///
    /// # Errors
    /// `every` or `horizon` is 0, or a dimension is 0.
    pub fn new(every: u64, horizon: usize, meta: Meta, obs_dim: usize, act_dim: usize) -> Result<Self> {
        if every == 0 || horizon == 0 {
            return Err(DefenderError::Config(format!(
                "the authors' collection needs a demonstration every >= 1 episodes and a horizon >= 1 \
                 (got every {every}, horizon {horizon})"
            )));
        }
        Ok(Self { every, horizon, pool: EpisodeSet::new(obs_dim, act_dim, meta)?, sources: Vec::new() })
    }

    /// Whether a demonstration follows training episode `episode` (0-based): after episodes
    /// `every`, `2 every`, ... (theirs: `(episode + 1) % 50 == 0`).
    pub fn is_due(&self, episode: u64) -> bool {
        (episode + 1).is_multiple_of(self.every)
    }

    /// Adds the recorder's episode, recorded after training episode `episode` (0-based): unsafe
    /// when shorter than the horizon.
    ///
    /// # Errors
    /// The episode does not fit the pool (no transition, dimensions, non-finite values).
    pub fn add(&mut self, recorder: &mut EpisodeRecorder, episode: u64) -> Result<()> {
        let crashed = recorder.len() < self.horizon;
        recorder.finish(&mut self.pool, crashed)?;
        self.sources.push(episode + 1);
        Ok(())
    }

    /// Demonstrations of each group so far: `(safe, unsafe)`.
    pub fn group_sizes(&self) -> (usize, usize) {
        self.pool.group_sizes()
    }

    /// Demonstrations so far.
    pub fn len(&self) -> usize {
        self.pool.len()
    }

    /// Whether none was recorded yet.
    pub fn is_empty(&self) -> bool {
        self.pool.is_empty()
    }

    /// The demonstration set: every demonstration, the safe group first, each group in the
    /// authors' diversity order of its state sequences; `meta.extra` records the rule, the
    /// training episodes each followed, the diversity order, `training_episodes` and `r_task`
    /// (the lowest per-step reward of them all: their `R_task`), `provenance` as given.
    ///
    /// # Errors
    /// [`DefenderError::MissingGroup`] when a group is empty (a filter needs both).
    pub fn finish(&self, training_episodes: u64, provenance: String) -> Result<EpisodeSet> {
        self.pool.require_both_groups()?;
        let (safe, unsafe_) = diverse_order(&self.pool, self.pool.len(), Mode::State)?;
        let safe_idx: Vec<usize> = self.pool.safe().map(|e| e.index).collect();
        let unsafe_idx: Vec<usize> = self.pool.unsafe_().map(|e| e.index).collect();
        let order: Vec<usize> =
            safe.iter().map(|&k| safe_idx[k]).chain(unsafe_.iter().map(|&k| unsafe_idx[k])).collect();
        let mut set = self.pool.reordered(&order)?;
        let meta = set.meta_mut();
        meta.provenance = Some(provenance);
        meta.extra.insert("collection".into(), "authors".into());
        meta.extra.insert(
            "rule".into(),
            format!(
                "after every {} training episodes, one episode of the current stochastic policy; safe when it \
                 lasted the horizon ({} steps), unsafe when shorter",
                self.every, self.horizon
            )
            .into(),
        );
        meta.extra.insert(
            "order".into(),
            "each group in the authors' diversity order (farthest-point over pairwise FastDTW, radius 1, L1, of \
             the state sequences, one element per transition): its first N are their choice of N"
                .into(),
        );
        meta.extra.insert(
            "source_training_episodes".into(),
            order.iter().map(|&i| self.sources[i]).collect::<Vec<u64>>().into(),
        );
        meta.extra.insert("training_episodes".into(), training_episodes.into());
        meta.extra.insert("demonstrate_every".into(), self.every.into());
        meta.extra.insert("horizon".into(), self.horizon.into());
        if let Some(r) = self.pool.min_reward() {
            meta.extra.insert("r_task".into(), f64::from(r).into());
        }
        Ok(set)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn episode(recorder: &mut EpisodeRecorder, value: f64, len: usize, reward: f64) {
        recorder.start(&[value]);
        for _ in 0..len {
            recorder.step(&[0.0], reward, &[value]).unwrap();
        }
    }

    #[test]
    fn demonstrations_follow_every_nth_episode_and_are_grouped_by_length() {
        let mut c = AuthorsCollection::new(50, 4, Meta::default(), 1, 1).unwrap();
        assert!(!c.is_due(0) && c.is_due(49) && !c.is_due(50) && c.is_due(99));
        let mut rec = EpisodeRecorder::new();
        // Safe (4 steps) at levels 0, 1, 9; unsafe (2 and 3 steps) at levels 5, 6.
        for (k, (v, len)) in [(0.0, 4), (5.0, 2), (1.0, 4), (9.0, 4), (6.0, 3)].into_iter().enumerate() {
            episode(&mut rec, v, len, -(k as f64));
            c.add(&mut rec, 50 * k as u64 + 49).unwrap();
        }
        assert_eq!(c.group_sizes(), (3, 2));
        let set = c.finish(250, "test".into()).unwrap();
        // Safe: the most distant pair (0, 9), then 1; unsafe: 5, 6. Safe group first.
        let levels: Vec<(f32, bool)> = set.episodes().map(|e| (e.obs[0], e.crashed)).collect();
        assert_eq!(levels, [(0.0, false), (9.0, false), (1.0, false), (5.0, true), (6.0, true)]);
        let extra = &set.meta().extra;
        assert_eq!(extra["source_training_episodes"], serde_json::json!([50, 200, 150, 100, 250]));
        assert_eq!(extra["r_task"], serde_json::json!(-4.0));
        assert_eq!(extra["collection"], "authors");
        assert_eq!(set.meta().provenance.as_deref(), Some("test"));
    }

    #[test]
    fn an_empty_group_or_a_zero_interval_is_refused() {
        assert!(AuthorsCollection::new(0, 4, Meta::default(), 1, 1).is_err());
        let mut c = AuthorsCollection::new(1, 4, Meta::default(), 1, 1).unwrap();
        let mut rec = EpisodeRecorder::new();
        episode(&mut rec, 0.0, 2, 0.0);
        c.add(&mut rec, 0).unwrap();
        let err = c.finish(1, String::new()).unwrap_err().to_string();
        assert!(err.contains("safe group is empty"), "{err}");
    }
}
