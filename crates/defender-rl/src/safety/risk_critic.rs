//! Recovery RL's safety critic `Q_risk(s, a)` (Thananjeyan et al. 2021, section 4.2) and the
//! recovery policy that learns from it, with their own replay buffer of executed actions.
//!
//! `Q_risk` estimates the discounted probability of a future violation: twin sigmoid critics,
//! read as the larger of the two (a pessimistic estimate of risk). One gradient step, as the
//! authors' `QRiskWrapper.update_parameters` computes it:
//!
//! ```text
//! a' ~ pi_task(.|s')                                           (the task policy, sampled)
//! y  = c + gamma_risk (1 - terminated) max_i Qt_i(s', a')
//! critic step on sum_i mean (Q_i(s, a) - y)^2
//! a~ = mean_rec(s) + std_rec eps;  recovery step on mean max_i Q_i(s, a~)   (updated critics)
//! Qt_i <- TAU Q_i + (1 - TAU) Qt_i                             (every step)
//! ```
//!
//! Only `terminated` stops the bootstrap (their mask is set before the time limit ends an
//! episode). docs/decisions-baselines.md, "Recovery RL", gives each choice and its source.

use std::path::Path;

use defender_nn::{Activation, AdamConfig};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::recovery_policy::{RecoveryPolicy, StdState};
use super::risk_batches::RiskBatches;
use crate::critics::TwinCritics;
use crate::error::RlError;
use crate::nets::concat_rows;
use crate::replay::{Batch, ReplayBuffer, Transition};
use crate::sac::Sac;
use crate::seed::{SeedPurpose, derive_seed};

/// The safety critic's Polyak coefficient (the authors' `tau_safe` default, 0.0002: the target
/// moves 50 times slower than SAC's).
pub(crate) const TAU_RISK: f32 = 0.0002;
/// The index of the safety critic's streams under their purposes (SAC's are index 0).
const STREAM: u64 = 1;

/// The shapes and settings of a safety critic.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RiskShape {
    pub(crate) obs_dim: usize,
    pub(crate) act_dim: usize,
    /// Hidden layers of the critics and of the recovery policy (the task agent's).
    pub(crate) net_arch: Vec<usize>,
    /// Adam's learning rate (the task agent's).
    pub(crate) learning_rate: f64,
    pub(crate) batch_size: usize,
    /// Capacity of its replay buffer (the task agent's).
    pub(crate) buffer_size: usize,
    pub(crate) gamma_risk: f32,
    /// The share of each batch drawn from the stored violations (0: uniform batches).
    pub(crate) pos_fraction: f64,
}

/// The losses of one gradient step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RiskStats {
    /// `sum_i mean (Q_i - y)^2`.
    pub(crate) critic_loss: f32,
    /// `mean max_i Q_i(s, a~)`.
    pub(crate) policy_loss: f32,
}

/// The safety critic's scalar state, for the agent's `state.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct RiskState {
    n_updates: u64,
    rng: ChaCha8Rng,
    recovery_std: StdState,
}

/// Buffers of one gradient step, allocated once.
#[derive(Debug, Clone)]
struct Workspace {
    batch: Batch,
    /// The task policy's `a'`, `b x a`, and its actor's `[mean | log_std]` rows.
    next_act: Vec<f32>,
    actor_out: Vec<f32>,
    next_in: Vec<f32>,
    critic_in: Vec<f32>,
    pi_in: Vec<f32>,
    target: Vec<f32>,
    grad1: Vec<f32>,
    grad2: Vec<f32>,
    dact: Vec<f32>,
    /// One `[s | a]` row, for [`RiskCritic::value`].
    one: Vec<f32>,
}

/// `Q_risk`, its targets and Adam, the recovery policy, their buffer and generator.
#[derive(Debug, Clone)]
pub(crate) struct RiskCritic {
    shape: RiskShape,
    pub(crate) critics: TwinCritics,
    pub(crate) policy: RecoveryPolicy,
    pub(crate) buffer: ReplayBuffer,
    /// How batches are drawn from `buffer` (violations over-sampled).
    batches: RiskBatches,
    pub(crate) rng: ChaCha8Rng,
    pub(crate) n_updates: u64,
    ws: Workspace,
}

impl RiskCritic {
    /// A fresh safety critic and recovery policy; weights and sampling derive from `seed` on
    /// streams of their own, so the task agent's are those it draws alone.
    pub(crate) fn new(shape: RiskShape, seed: u64) -> Result<Self, RlError> {
        let (o, a, b) = (shape.obs_dim, shape.act_dim, shape.batch_size);
        let mut init = ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Init, STREAM));
        let adam = AdamConfig { lr: shape.learning_rate as f32, ..AdamConfig::default() };
        let critics =
            TwinCritics::with_output(o, a, &shape.net_arch, adam, b, &mut init, Activation::Sigmoid)?;
        let policy = RecoveryPolicy::new(o, a, &shape.net_arch, adam, b, &mut init)?;
        Ok(Self {
            critics,
            policy,
            buffer: ReplayBuffer::new(shape.buffer_size, o, a)?,
            batches: RiskBatches::new(shape.pos_fraction),
            rng: ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Agent, STREAM)),
            n_updates: 0,
            ws: Workspace {
                batch: Batch::new(b, o, a),
                next_act: vec![0.0; b * a],
                actor_out: vec![0.0; b * 2 * a],
                next_in: vec![0.0; b * (o + a)],
                critic_in: vec![0.0; b * (o + a)],
                pi_in: vec![0.0; b * (o + a)],
                target: vec![0.0; b],
                grad1: vec![0.0; b],
                grad2: vec![0.0; b],
                dact: vec![0.0; b * a],
                one: vec![0.0; o + a],
            },
            shape,
        })
    }

    /// `Q_risk(s, a) = max(Q1, Q2)(s, a)` for one state and action (the online critics).
    pub(crate) fn value(&mut self, obs: &[f32], act: &[f32]) -> f32 {
        let o = self.shape.obs_dim;
        self.ws.one[..o].copy_from_slice(obs);
        self.ws.one[o..].copy_from_slice(act);
        let one = &self.ws.one;
        self.critics.each(|_, c| c.forward(one, 1));
        self.critics[0].q[0].max(self.critics[1].q[0])
    }

    /// Stores a transition with the action that was executed.
    pub(crate) fn push(&mut self, t: &Transition<'_>) -> Result<(), RlError> {
        self.batches.push(&mut self.buffer, t)
    }

    /// One gradient step of `Q_risk` and the recovery policy on a fresh batch; `task` gives the
    /// next actions of the target.
    pub(crate) fn gradient_step(&mut self, task: &mut Sac) -> Result<RiskStats, RlError> {
        let (b, o, a) = (self.shape.batch_size, self.shape.obs_dim, self.shape.act_dim);
        let gamma = self.shape.gamma_risk;
        let ws = &mut self.ws;
        self.batches.sample(&self.buffer, &mut self.rng, &mut ws.batch)?;

        // Target: the risk of the task policy's next action, by the larger target critic.
        task.sample_actions(&ws.batch.next_obs, b, &mut self.rng, &mut ws.actor_out, &mut ws.next_act);
        concat_rows(&mut ws.next_in, &ws.batch.next_obs, &ws.next_act, b, o, a);
        let next_in = &ws.next_in;
        self.critics.each(|_, c| c.forward_target(next_in, b));
        let (qt1, qt2) = (&self.critics[0].q, &self.critics[1].q);
        for i in 0..b {
            let bootstrap = (1.0 - ws.batch.terminated[i]) * gamma * qt1[i].max(qt2[i]);
            ws.target[i] = ws.batch.costs[i] + bootstrap;
        }

        // Critics: sum_i mse(Q_i(s, a), y) (F.mse_loss, a mean); d/dQ_i = 2 (Q_i - y) / b.
        concat_rows(&mut ws.critic_in, &ws.batch.obs, &ws.batch.actions, b, o, a);
        let (critic_in, target) = (&ws.critic_in, &ws.target);
        self.critics.each(|_, c| c.train_step(critic_in, target, b, &|diff| 2.0 * diff / b as f32));
        let mut critic_loss = 0.0f32;
        for values in [&self.critics[0].q, &self.critics[1].q] {
            critic_loss += values.iter().zip(target).map(|(q, y)| (q - y) * (q - y)).sum::<f32>() / b as f32;
        }

        let policy_loss = self.policy_backward();
        self.policy.apply();

        self.critics.polyak(TAU_RISK);
        self.n_updates += 1;
        if !(critic_loss.is_finite() && policy_loss.is_finite()) {
            return Err(RlError::Diverged { what: "Recovery RL safety critic loss", update: self.n_updates });
        }
        Ok(RiskStats { critic_loss, policy_loss })
    }

    /// The recovery policy's loss `mean max_i Q_i(s, a~)` on the batch's states through the
    /// critics as they are, its gradient left in the policy. The max's gradient goes to the
    /// larger critic, half to each on a tie (torch.max).
    pub(crate) fn policy_backward(&mut self) -> f32 {
        let (b, o, a) = (self.shape.batch_size, self.shape.obs_dim, self.shape.act_dim);
        let ws = &mut self.ws;
        self.policy.sample_batch(&ws.batch.obs, b, o, &mut self.rng);
        concat_rows(&mut ws.pi_in, &ws.batch.obs, &self.policy.act, b, o, a);
        let pi_in = &ws.pi_in;
        self.critics.each(|_, c| c.forward(pi_in, b));
        let (q1, q2) = (&self.critics[0].q, &self.critics[1].q);
        let mut loss = 0.0f32;
        let g = 1.0 / b as f32;
        for i in 0..b {
            loss += q1[i].max(q2[i]) / b as f32;
            (ws.grad1[i], ws.grad2[i]) = match q1[i].partial_cmp(&q2[i]) {
                Some(std::cmp::Ordering::Greater) => (g, 0.0),
                Some(std::cmp::Ordering::Less) => (0.0, g),
                _ => (g / 2.0, g / 2.0),
            };
        }
        let grads = [&ws.grad1, &ws.grad2];
        self.critics.each(|k, c| c.backward_input(grads[k], b));
        let (d1, d2) = (&self.critics[0].dinput, &self.critics[1].dinput);
        for i in 0..b {
            for j in 0..a {
                let k = i * (o + a) + o + j;
                ws.dact[i * a + j] = d1[k] + d2[k];
            }
        }
        self.policy.backward(&ws.dact, b);
        loss
    }

    /// The scalar state, for `state.json`.
    pub(crate) fn state(&self) -> RiskState {
        RiskState {
            n_updates: self.n_updates,
            rng: self.rng.clone(),
            recovery_std: self.policy.std_state().clone(),
        }
    }

    /// Writes the networks, their optimisers and the buffer into `dir`.
    pub(crate) fn save(&self, dir: &Path) -> Result<(), RlError> {
        self.critics.save(dir)?;
        self.policy.save(dir)?;
        self.buffer.save(&dir.join("replay.bin"))
    }

    /// Reads what [`RiskCritic::save`] wrote, and the scalar `state` (read from `path`).
    pub(crate) fn load(&mut self, dir: &Path, state: RiskState, path: &Path) -> Result<(), RlError> {
        self.critics.load(dir)?;
        self.policy.load(dir)?;
        self.buffer.load(&dir.join("replay.bin"))?;
        self.batches.rebuild(&self.buffer);
        self.policy.set_std_state(state.recovery_std, path)?;
        self.n_updates = state.n_updates;
        self.rng = state.rng;
        Ok(())
    }
}

#[cfg(test)]
#[path = "risk_critic_tests.rs"]
mod tests;
