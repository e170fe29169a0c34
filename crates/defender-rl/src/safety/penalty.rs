//! The crash penalty: the agent learns from `r - p * c` instead of `r`, the simplest way the field
//! makes an agent avoid violations (a reward-shaping baseline). Everything else, the episode
//! returns the trainer records included, is the wrapped agent's.

use std::path::Path;

use crate::agent::{Agent, UpdateStats};
use crate::error::RlError;
use crate::replay::Transition;

/// An agent whose stored rewards are penalised by the step's cost.
pub struct Penalized<A> {
    inner: A,
    penalty: f64,
}

impl<A: Agent> Penalized<A> {
    /// `inner` learning from `reward - penalty * cost`.
    pub fn new(inner: A, penalty: f64) -> Self {
        Self { inner, penalty }
    }

    /// The transition as the wrapped agent stores it.
    fn penalised<'a>(&self, t: &Transition<'a>) -> Transition<'a> {
        Transition { reward: t.reward - self.penalty * t.cost, ..*t }
    }
}

impl<A: Agent> Agent for Penalized<A> {
    fn algo(&self) -> &'static str {
        self.inner.algo()
    }
    fn obs_dim(&self) -> usize {
        self.inner.obs_dim()
    }
    fn act_dim(&self) -> usize {
        self.inner.act_dim()
    }
    fn num_timesteps(&self) -> u64 {
        self.inner.num_timesteps()
    }
    fn act(&mut self, obs: &[f64], deterministic: bool, action: &mut [f32]) -> Result<(), RlError> {
        self.inner.act(obs, deterministic, action)
    }
    fn act_with(
        &mut self,
        obs: &[f64],
        rng: &mut rand_chacha::ChaCha8Rng,
        action: &mut [f32],
    ) -> Result<(), RlError> {
        self.inner.act_with(obs, rng, action)
    }
    fn observe(&mut self, transition: &Transition<'_>) -> Result<(), RlError> {
        let t = self.penalised(transition);
        self.inner.observe(&t)
    }
    /// A demonstration's crash is penalised as the agent's own: the same data, the same reward.
    fn store_demonstration(&mut self, transition: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        let t = self.penalised(transition);
        self.inner.store_demonstration(&t, bc)
    }
    fn update(&mut self) -> Result<Option<UpdateStats>, RlError> {
        self.inner.update()
    }
    /// The penalty is the run's configuration, not state: the wrapped agent's files are all.
    fn save(&self, dir: &Path) -> Result<(), RlError> {
        self.inner.save(dir)
    }
    fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        self.inner.load(dir)
    }
    fn save_actor(&self, path: &Path) -> Result<(), RlError> {
        self.inner.save_actor(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Sac, SacConfig};

    #[test]
    fn the_stored_reward_is_the_reward_minus_the_penalised_cost() {
        let config = SacConfig { net_arch: vec![8], batch_size: 4, buffer_size: 10, ..SacConfig::default() };
        let mut agent = Penalized::new(Sac::new(config, 1, 1, 0).unwrap(), 100.0);
        for (reward, cost) in [(1.0, 0.0), (2.0, 1.0)] {
            let t = Transition {
                obs: &[0.0],
                action: &[0.0],
                reward,
                cost,
                next_obs: &[0.0],
                terminated: cost > 0.0,
                truncated: false,
            };
            agent.observe(&t).unwrap();
        }
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(0);
        let mut batch = crate::Batch::new(64, 1, 1);
        agent.inner.buffer().sample_into(&mut rng, &mut batch).unwrap();
        for (r, c) in batch.rewards.iter().zip(&batch.costs) {
            assert_eq!(*r, if *c > 0.0 { 2.0 - 100.0 } else { 1.0 });
        }
        assert!(batch.costs.contains(&1.0) && batch.costs.contains(&0.0));
    }
}
