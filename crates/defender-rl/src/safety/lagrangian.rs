//! Lagrangian SAC (OmniSafe 0.5's SACLag): SAC whose actor also pays for the expected cost of its
//! actions, weighed by a multiplier that grows while the episodes cost more than the limit `d`:
//!
//! ```text
//! per gradient step (SAC's batch and next actions):
//!   cost critic step on mean (Q_c(s, a) - (c + gamma (1 - terminated) Q_c'(s', a')))^2
//!   actor step on mean(alpha logp - min(Q1, Q2) + lambda Q_c) / (1 + lambda)
//! per finished training episode, once learning has started:
//!   Adam step on -lambda (J_c - d), lambda <- max(lambda, 0)
//! ```
//!
//! The reward side is SAC's unchanged (`crate::Sac`, the same networks and hyperparameters as
//! every other arm); the cost critic is in [`super::cost_critic`], the multiplier in
//! [`super::multiplier`].

use std::path::Path;

use defender_nn::Parallelism;
use serde::{Deserialize, Serialize};

use super::LagrangianConfig;
use super::cost_critic::CostCritic;
use super::multiplier::Multiplier;
use crate::agent::{Agent, UpdateStats};
use crate::checkpoint::{read_json, write_json};
use crate::config::SacConfig;
use crate::error::RlError;
use crate::replay::{Batch, Transition};
use crate::sac::{CostTerm, Sac};

/// The checkpoint file of the Lagrangian side (SAC's own files are beside it).
const STATE_FILE: &str = "lagrangian.json";

/// What [`STATE_FILE`] holds besides the cost critic's networks.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct LagrangianState {
    config: LagrangianConfig,
    multiplier: Multiplier,
    cost_critic_updates: u64,
    cost_critic_loss: f32,
}

/// SAC with a cost critic and a Lagrange multiplier.
#[derive(Debug, Clone)]
pub struct LagrangianSac {
    sac: Sac,
    cost: CostCritic,
    multiplier: Multiplier,
    config: LagrangianConfig,
}

/// The cost critic and this step's multiplier, as SAC's gradient step takes them.
struct Term<'a> {
    critic: &'a mut CostCritic,
    lambda: f32,
}

impl CostTerm for Term<'_> {
    fn critic_step(&mut self, batch: &Batch, critic_in: &[f32], next_in: &[f32]) -> Result<(), RlError> {
        self.critic.step(batch, critic_in, next_in).map(|_| ())
    }
    fn multiplier(&self) -> f32 {
        self.lambda
    }
    fn actor_term(&mut self, pi_in: &[f32], weight: f32, dact: &mut [f32]) -> f32 {
        self.critic.actor_term(pi_in, weight, dact)
    }
}

impl LagrangianSac {
    /// A fresh agent: SAC with `sac` (exactly the plain SAC of this seed on the reward side) and
    /// the Lagrangian settings `lagrangian`.
    ///
    /// # Errors
    /// [`RlError::Config`] naming the first bad key of either.
    pub fn new(
        sac: SacConfig,
        lagrangian: LagrangianConfig,
        obs_dim: usize,
        act_dim: usize,
        seed: u64,
    ) -> Result<Self, RlError> {
        super::SafetyConfig::Lagrangian(lagrangian.clone()).validate()?;
        let cost = CostCritic::new(&sac, obs_dim, act_dim, seed)?;
        Ok(Self {
            sac: Sac::new(sac, obs_dim, act_dim, seed)?,
            cost,
            multiplier: Multiplier::new(&lagrangian),
            config: lagrangian,
        })
    }

    /// The multiplier `lambda`.
    pub fn lambda(&self) -> f32 {
        self.multiplier.lambda()
    }

    /// `J_c`: the mean cost of the last `window` training episodes (`None` before the first).
    pub fn mean_episode_cost(&self) -> Option<f64> {
        self.multiplier.mean_episode_cost()
    }

    /// The networks' threads (as [`Sac::set_parallelism`]; the cost critic uses them all).
    pub fn set_parallelism(&mut self, parallelism: Parallelism) {
        self.sac.set_parallelism(parallelism);
        self.cost.set_parallelism(parallelism);
    }

    /// The SAC agent of the reward side.
    pub fn sac(&self) -> &Sac {
        &self.sac
    }
}

impl Agent for LagrangianSac {
    fn algo(&self) -> &'static str {
        "sac"
    }
    fn obs_dim(&self) -> usize {
        self.sac.obs_dim()
    }
    fn act_dim(&self) -> usize {
        self.sac.act_dim()
    }
    fn num_timesteps(&self) -> u64 {
        self.sac.num_timesteps()
    }
    fn act(&mut self, obs: &[f64], deterministic: bool, action: &mut [f32]) -> Result<(), RlError> {
        self.sac.act(obs, deterministic, action)
    }

    /// Stores the transition, and sums the episode's cost: at its end (terminated or truncated,
    /// a filtered step included) the multiplier steps unless SAC is still warming up.
    fn observe(&mut self, transition: &Transition<'_>) -> Result<(), RlError> {
        self.sac.observe(transition)?;
        let end = transition.terminated || transition.truncated;
        self.multiplier.observe(transition.cost, end, !self.sac.before_learning_starts());
        Ok(())
    }

    /// A demonstration's cost trains the cost critic through the replay buffer; it is not a
    /// training episode, so `J_c` does not count it.
    fn store_demonstration(&mut self, transition: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        self.sac.store_demonstration(transition, bc)
    }

    fn update(&mut self) -> Result<Option<UpdateStats>, RlError> {
        // Constant within the step (OmniSafe reads `lagrangian_multiplier.item()`).
        let lambda = self.multiplier.lambda();
        let mut term = Term { critic: &mut self.cost, lambda };
        let stats = self.sac.update_with(Some(&mut term))?;
        Ok(stats.map(|s| UpdateStats {
            cost_critic_loss: Some(self.cost.last_loss),
            lagrange_multiplier: Some(lambda),
            ..s
        }))
    }

    fn save(&self, dir: &Path) -> Result<(), RlError> {
        self.sac.save(dir)?;
        self.cost.save(dir)?;
        let state = LagrangianState {
            config: self.config.clone(),
            multiplier: self.multiplier.clone(),
            cost_critic_updates: self.cost.updates,
            cost_critic_loss: self.cost.last_loss,
        };
        write_json(&dir.join(STATE_FILE), &state)
    }

    fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        let path = dir.join(STATE_FILE);
        let state: LagrangianState = read_json(&path)?;
        if state.config != self.config {
            return Err(RlError::checkpoint(
                &path,
                format!("saved with [safety] {:?}, this run has {:?}", state.config, self.config),
            ));
        }
        self.sac.load(dir)?;
        self.cost.load(dir)?;
        self.multiplier = state.multiplier;
        self.cost.updates = state.cost_critic_updates;
        self.cost.last_loss = state.cost_critic_loss;
        Ok(())
    }

    fn save_actor(&self, path: &Path) -> Result<(), RlError> {
        self.sac.save_actor(path)
    }
}
