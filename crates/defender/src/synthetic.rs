//! Synthetic trajectories for benchmarks and scale experiments: smooth random walks (a velocity
//! with momentum), shaped like a task's episodes but not drawn from it.
//!
//! DTW's cost depends only on the lengths and the dimension of the sequences, not on their values
//! (except through the `Equal` window), so these walks time the filter, the dynamics model and the
//! ablation exactly as real episodes of the same shape would, without needing a trained agent.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::episode_set::{EpisodeSet, Meta};
use crate::error::Result;

/// One smooth random walk of `n` transitions: observations `(n + 1) x obs_dim` and actions
/// `n x act_dim`, row-major. Each observation coordinate starts uniform in [-1, 1) and moves by
/// 0.05 times a velocity that keeps 90% of itself and adds 10% of uniform noise per step; actions
/// are uniform in [-1, 1).
pub fn random_walk(rng: &mut impl Rng, n: usize, obs_dim: usize, act_dim: usize) -> (Vec<f32>, Vec<f32>) {
    let mut s: Vec<f32> = (0..obs_dim).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mut v = vec![0.0f32; obs_dim];
    let (mut obs, mut act) = (Vec::with_capacity((n + 1) * obs_dim), Vec::with_capacity(n * act_dim));
    obs.extend_from_slice(&s);
    for _ in 0..n {
        for (sk, vk) in s.iter_mut().zip(v.iter_mut()) {
            *vk = 0.9 * *vk + 0.1 * rng.random_range(-1.0f32..1.0);
            *sk += 0.05 * *vk;
        }
        obs.extend_from_slice(&s);
        act.extend((0..act_dim).map(|_| rng.random_range(-1.0f32..1.0)));
    }
    (obs, act)
}

/// The shape of a synthetic demonstration set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WalkSet {
    /// Observation dimension.
    pub obs_dim: usize,
    /// Action dimension.
    pub act_dim: usize,
    /// Demonstrations per group (safe and unsafe alike).
    pub per_group: usize,
    /// Transitions per demonstration.
    pub len: usize,
    /// Added to every observation of the unsafe demonstrations. 0 keeps both groups alike; a
    /// large value puts the unsafe group far from anything else, so a filter never fires.
    pub unsafe_offset: f32,
}

impl WalkSet {
    /// Hopper-v5's shape: 11-D observations, 3-D actions, 50 + 50 demonstrations of 1000
    /// transitions (the longest episode the task allows), no offset.
    pub const HOPPER: WalkSet =
        WalkSet { obs_dim: 11, act_dim: 3, per_group: 50, len: 1000, unsafe_offset: 0.0 };

    /// Builds the set from `seed`: demonstrations alternate safe, unsafe (so the groups interleave
    /// as in a collection run), every reward is 1.
    ///
    /// # Errors
    /// When a dimension is zero (as [`EpisodeSet::new`]).
    pub fn build(&self, seed: u64, meta: Meta) -> Result<EpisodeSet> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut set = EpisodeSet::new(self.obs_dim, self.act_dim, meta)?;
        for i in 0..2 * self.per_group {
            let crashed = i % 2 == 1;
            let (mut obs, act) = random_walk(&mut rng, self.len, self.obs_dim, self.act_dim);
            if crashed && self.unsafe_offset != 0.0 {
                obs.iter_mut().for_each(|v| *v += self.unsafe_offset);
            }
            set.push_episode(&obs, &act, &vec![1.0; self.len], crashed)?;
        }
        Ok(set)
    }
}

/// A demonstration set whose unsafe demonstrations follow the safe ones' distribution until late
/// in the episode and then drift away (a task whose crashes show only near their end): the test
/// case of choosing a strategy (crate::selection).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LateDivergence {
    /// Observation dimension.
    pub obs_dim: usize,
    /// Action dimension.
    pub act_dim: usize,
    /// Demonstrations per group.
    pub per_group: usize,
    /// Transitions per demonstration.
    pub len: usize,
    /// The transition after which the unsafe demonstrations drift.
    pub diverge_at: usize,
    /// Added to the first observation coordinate per step after `diverge_at` (unsafe only).
    pub drift: f32,
}

impl LateDivergence {
    /// 3-D observations, 1-D actions, 8 + 8 demonstrations of 60 transitions that drift by 0.5
    /// per step over their last 15 (far beyond the safe walks, which stay within about [-2, 2]).
    pub const SMALL: LateDivergence =
        LateDivergence { obs_dim: 3, act_dim: 1, per_group: 8, len: 60, diverge_at: 45, drift: 0.5 };

    /// Builds the set from `seed`: random walks ([`random_walk`]) alternating safe, unsafe; every
    /// reward is 1.
    ///
    /// # Errors
    /// When a dimension is zero (as [`EpisodeSet::new`]).
    pub fn build(&self, seed: u64, meta: Meta) -> Result<EpisodeSet> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut set = EpisodeSet::new(self.obs_dim, self.act_dim, meta)?;
        for i in 0..2 * self.per_group {
            let crashed = i % 2 == 1;
            let (mut obs, act) = random_walk(&mut rng, self.len, self.obs_dim, self.act_dim);
            if crashed {
                for t in self.diverge_at + 1..=self.len {
                    obs[t * self.obs_dim] += self.drift * (t - self.diverge_at) as f32;
                }
            }
            set.push_episode(&obs, &act, &vec![1.0; self.len], crashed)?;
        }
        Ok(set)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walks_have_the_requested_shape_and_are_reproducible() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (obs, act) = random_walk(&mut rng, 7, 4, 2);
        assert_eq!((obs.len(), act.len()), (8 * 4, 7 * 2));
        // Steps are small: the walk is smooth.
        for t in 0..7 {
            for k in 0..4 {
                assert!((obs[(t + 1) * 4 + k] - obs[t * 4 + k]).abs() <= 0.05, "t {t} k {k}");
            }
        }
        let shape = WalkSet { obs_dim: 4, act_dim: 2, per_group: 3, len: 5, unsafe_offset: 100.0 };
        let a = shape.build(1, Meta::default()).unwrap();
        let b = shape.build(1, Meta::default()).unwrap();
        assert_eq!(a.len(), 6);
        for i in 0..6 {
            let (ea, eb) = (a.episode(i), b.episode(i));
            assert_eq!(ea.obs, eb.obs);
            assert_eq!(ea.crashed, i % 2 == 1);
            assert_eq!(ea.obs.iter().all(|&v| v > 50.0), ea.crashed, "episode {i}");
        }
    }
}
