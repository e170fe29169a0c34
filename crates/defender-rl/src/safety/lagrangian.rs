//! Lagrangian SAC (OmniSafe 0.5's SACLag) and PID Lagrangian SAC (its SACPID): SAC whose actor
//! also pays for the expected cost of its actions, weighed by a multiplier that grows while the
//! episodes cost more than the limit `d`:
//!
//! ```text
//! per gradient step (SAC's batch and next actions):
//!   cost critic step on mean (Q_c(s, a) - (c + gamma (1 - terminated) Q_c'(s', a')))^2
//!   actor step on mean(alpha logp - min(Q1, Q2) + lambda Q_c) / (1 + lambda)
//! lagrangian: per finished training episode, once learning has started:
//!   Adam step on -lambda (J_c - d), lambda <- max(lambda, 0)
//! pid: per training step, once learning has started: OmniSafe's pid_update(J_c)
//! ```
//!
//! The reward side is SAC's unchanged (`crate::Sac`, the same networks and hyperparameters as
//! every other arm) unless `max_grad_norm` clips its gradients too; the cost critic is in
//! [`super::cost_critic`], the multipliers in [`super::multiplier`] and [`super::pid`], the cost
//! normalisation in [`super::cost_normalizer`].

use std::path::Path;

use defender_nn::Parallelism;
use serde::{Deserialize, Serialize};

use super::cost_critic::{CostCritic, CostRange};
use super::cost_normalizer::{CLIP, CostNormalizer};
use super::multiplier::Multiplier;
use super::pid::PidMultiplier;
use super::{CostCriticConfig, LagrangianConfig, PidConfig, SafetyConfig};
use crate::agent::{Agent, UpdateStats};
use crate::checkpoint::{read_json, write_json};
use crate::config::SacConfig;
use crate::error::RlError;
use crate::replay::{Batch, Transition};
use crate::sac::{CostTerm, Sac};

/// The checkpoint file of the Lagrangian side (SAC's own files are beside it).
const STATE_FILE: &str = "lagrangian.json";

/// What sets the multiplier.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Controller {
    /// Adam on `-lambda (J_c - d)` once per episode (`method = "lagrangian"`).
    Lagrangian(Multiplier),
    /// OmniSafe's PID controller once per step (`method = "pid"`).
    Pid(PidMultiplier),
}

impl Controller {
    fn lambda(&self) -> f32 {
        match self {
            Self::Lagrangian(m) => m.lambda(),
            Self::Pid(p) => p.lambda(),
        }
    }
    fn mean_episode_cost(&self) -> Option<f64> {
        match self {
            Self::Lagrangian(m) => m.mean_episode_cost(),
            Self::Pid(p) => p.mean_episode_cost(),
        }
    }
    fn observe(&mut self, cost: f64, end: bool, learning: bool) {
        match self {
            Self::Lagrangian(m) => m.observe(cost, end, learning),
            Self::Pid(p) => p.observe(cost, end, learning),
        }
    }
}

/// What [`STATE_FILE`] holds besides the cost critic's networks.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct LagrangianState {
    config: SafetyConfig,
    controller: Controller,
    #[serde(default)]
    normalizer: CostNormalizer,
    cost_critic_updates: u64,
    cost_critic_loss: f32,
}

/// SAC with a cost critic and a Lagrange multiplier set by Adam or by a PID controller.
#[derive(Debug, Clone)]
pub struct LagrangianSac {
    sac: Sac,
    cost: CostCritic,
    controller: Controller,
    /// `[safety]`: `Lagrangian` or `Pid`.
    config: SafetyConfig,
    critic_config: CostCriticConfig,
    normalizer: CostNormalizer,
}

/// The cost critic and this step's multiplier, as SAC's gradient step takes them.
struct Term<'a> {
    critic: &'a mut CostCritic,
    lambda: f32,
    max_grad_norm: Option<f32>,
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
    fn max_grad_norm(&self) -> Option<f32> {
        self.max_grad_norm
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
        let controller = Controller::Lagrangian(Multiplier::new(&lagrangian));
        Self::build(sac, SafetyConfig::Lagrangian(lagrangian), controller, obs_dim, act_dim, seed)
    }

    /// As [`LagrangianSac::new`], the multiplier set by OmniSafe's PID controller.
    ///
    /// # Errors
    /// [`RlError::Config`] naming the first bad key of either.
    pub fn pid(
        sac: SacConfig,
        pid: PidConfig,
        obs_dim: usize,
        act_dim: usize,
        seed: u64,
    ) -> Result<Self, RlError> {
        let controller = Controller::Pid(PidMultiplier::new(&pid));
        Self::build(sac, SafetyConfig::Pid(pid), controller, obs_dim, act_dim, seed)
    }

    fn build(
        sac: SacConfig,
        config: SafetyConfig,
        controller: Controller,
        obs_dim: usize,
        act_dim: usize,
        seed: u64,
    ) -> Result<Self, RlError> {
        config.validate()?;
        let critic_config = match &config {
            SafetyConfig::Lagrangian(c) => c.critic(),
            SafetyConfig::Pid(c) => c.critic(),
            _ => unreachable!("built from a Lagrangian or PID configuration"),
        };
        let per_step = critic_config.bounded_cost_critic.then(|| {
            if critic_config.cost_normalize {
                (-CLIP as f32, CLIP as f32)
            } else {
                (0.0, critic_config.cost_max as f32)
            }
        });
        let range = CostRange { per_step, max_grad_norm: critic_config.max_grad_norm.map(|n| n as f32) };
        let cost = CostCritic::new(&sac, obs_dim, act_dim, seed, range)?;
        Ok(Self {
            sac: Sac::new(sac, obs_dim, act_dim, seed)?,
            cost,
            controller,
            config,
            critic_config,
            normalizer: CostNormalizer::default(),
        })
    }

    /// The multiplier `lambda`.
    pub fn lambda(&self) -> f32 {
        self.controller.lambda()
    }

    /// `J_c`: the mean cost of the last `window` training episodes (`None` before the first).
    pub fn mean_episode_cost(&self) -> Option<f64> {
        self.controller.mean_episode_cost()
    }

    /// The transition as the cost critic learns from it: its cost checked against `cost_max`,
    /// and normalised if asked.
    fn learned<'a>(&mut self, transition: &Transition<'a>) -> Result<Transition<'a>, RlError> {
        let c = transition.cost;
        if !(0.0..=self.critic_config.cost_max).contains(&c) {
            return Err(RlError::Config {
                field: "cost_max",
                value: format!("{} (a step cost {c})", self.critic_config.cost_max),
                expected: "every step's cost in [0, cost_max]: raise [safety] cost_max to the task's largest step cost",
            });
        }
        let cost = if self.critic_config.cost_normalize { self.normalizer.normalize(c) } else { c };
        Ok(Transition { cost, ..*transition })
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
    fn act_with(
        &mut self,
        obs: &[f64],
        rng: &mut rand_chacha::ChaCha8Rng,
        action: &mut [f32],
    ) -> Result<(), RlError> {
        self.sac.act_with(obs, rng, action)
    }

    /// Stores the transition, and sums the episode's cost: at its end (terminated or truncated,
    /// a filtered step included) the multiplier steps unless SAC is still warming up.
    fn observe(&mut self, transition: &Transition<'_>) -> Result<(), RlError> {
        let learned = self.learned(transition)?;
        self.sac.observe(&learned)?;
        let end = transition.terminated || transition.truncated;
        // J_c reads the raw cost (OmniSafe's EpCost: `original_cost`).
        self.controller.observe(transition.cost, end, !self.sac.before_learning_starts());
        Ok(())
    }

    /// A demonstration's cost trains the cost critic through the replay buffer; it is not a
    /// training episode, so `J_c` does not count it. With `cost_normalize` it is normalised as a
    /// training step's cost is (as if recorded through OmniSafe's wrapper).
    fn store_demonstration(&mut self, transition: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        let learned = self.learned(transition)?;
        self.sac.store_demonstration(&learned, bc)
    }

    fn update(&mut self) -> Result<Option<UpdateStats>, RlError> {
        // Constant within the step (OmniSafe reads `lagrangian_multiplier.item()`).
        let lambda = self.controller.lambda();
        let max_grad_norm = self.critic_config.max_grad_norm.map(|n| n as f32);
        let mut term = Term { critic: &mut self.cost, lambda, max_grad_norm };
        let stats = self.sac.update_with(Some(&mut term))?;
        Ok(stats.map(|s| UpdateStats {
            cost_critic_loss: Some(self.cost.last_loss),
            lagrange_multiplier: Some(lambda),
            qc_mean: Some(self.cost.last_qc_mean),
            ..s
        }))
    }

    fn save(&self, dir: &Path) -> Result<(), RlError> {
        self.sac.save(dir)?;
        self.cost.save(dir)?;
        let state = LagrangianState {
            config: self.config.clone(),
            controller: self.controller.clone(),
            normalizer: self.normalizer.clone(),
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
        self.controller = state.controller;
        self.normalizer = state.normalizer;
        self.cost.updates = state.cost_critic_updates;
        self.cost.last_loss = state.cost_critic_loss;
        Ok(())
    }

    fn save_actor(&self, path: &Path) -> Result<(), RlError> {
        self.sac.save_actor(path)
    }
}
