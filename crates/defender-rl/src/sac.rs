//! Soft Actor-Critic (Haarnoja et al. 2018, "SAC: Algorithms and Applications"), as
//! Stable-Baselines3's `SAC` computes it: twin Q critics with Polyak targets, a tanh-squashed
//! Gaussian policy, automatic entropy tuning.
//!
//! One gradient step (SB3 `SAC.train`, reordered only so that each network's forward pass is
//! followed by its own backward pass):
//!
//! ```text
//! alpha  = exp(log_alpha)                                  (the value before this step's update)
//! a', logp' ~ pi(.|s');  y = r + gamma (1 - terminated) (min_i Qt_i(s', a') - alpha logp')
//! a~, logp  ~ pi(.|s)
//! alpha step on  -log_alpha (logp + target_entropy)
//! critic step on 0.5 sum_i mean (Q_i(s, a) - y)^2
//! actor step on  mean(alpha logp - min_i Q_i(s, a~))        (through the updated critics)
//!                + bc_weight * BC(a~, a)                    (0 unless demonstrations are cloned)
//! Qt_i <- tau Q_i + (1 - tau) Qt_i
//! ```
//!
//! The behaviour-cloning term is the authors' addition for DEFENDER's agent (docs/SPEC.md,
//! "The authors' profile"): the squared error between the fresh policy action `a~` and the
//! replayed action `a`, on the rows of safe demonstrations (`bc_form = "per-row"`), or, as
//! their code computes it, on every row times the share of demonstration rows (`"authors"`).

use std::path::Path;

use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::agent::{Agent, UpdateStats};
use crate::checkpoint::{read_json, write_json};
use crate::config::{BcForm, EntCoef, SacConfig};
use crate::critics::TwinCritics;
use crate::error::RlError;
use crate::nets::{
    ScalarAdam, check_action_len, clip_grad_norm, concat_rows, copy_out, load_net, new_mlp, obs_to_f32, rows,
    save_net, widths,
};
use crate::off_policy::{Experience, Identity, Schedule, check_saved, uniform_action};
use crate::replay::{Batch, ReplayBuffer, Transition};
use crate::seed::{SeedPurpose, derive_seed};

/// SB3's bounds on the policy's log standard deviation.
const LOG_STD_MIN: f32 = -20.0;
const LOG_STD_MAX: f32 = 2.0;
/// SB3's epsilon in `log(1 - tanh(u)^2 + eps)`.
const TANH_EPS: f32 = 1e-6;
/// `ln(sqrt(2 pi))`.
const LN_SQRT_2PI: f32 = 0.918_938_5;

/// Buffers of one gradient step, allocated once.
#[derive(Debug, Clone)]
struct Workspace {
    batch: Batch,
    /// `[s' | a']` rows for the target critics.
    next_in: Vec<f32>,
    /// `[s | a]` rows (replayed actions) for the critic loss.
    critic_in: Vec<f32>,
    /// `[s | a~]` rows (fresh policy actions) for the actor loss.
    pi_in: Vec<f32>,
    /// Actor output `[mean | log_std]` rows.
    actor_out: Vec<f32>,
    /// Noise `eps`, squashed actions `a~ = tanh(mean + std eps)`, and `std`, per row and dim.
    eps: Vec<f32>,
    pi_act: Vec<f32>,
    std: Vec<f32>,
    /// Whether `log_std` was inside the clamp (the clamp passes the gradient only there).
    in_clamp: Vec<bool>,
    /// `log pi(a~|s)` and `log pi(a'|s')` per row.
    logp: Vec<f32>,
    next_logp: Vec<f32>,
    /// Bellman targets, per row.
    target: Vec<f32>,
    /// The actor loss's gradient with respect to each critic's output.
    grad1: Vec<f32>,
    grad2: Vec<f32>,
    /// `dL/da~` accumulated over both critics.
    dact: Vec<f32>,
    /// Gradient w.r.t. the actor output.
    grad_actor: Vec<f32>,
    /// One observation, for `act`.
    obs1: Vec<f32>,
}

impl Workspace {
    fn new(b: usize, o: usize, a: usize) -> Self {
        Self {
            batch: Batch::new(b, o, a),
            next_in: vec![0.0; b * (o + a)],
            critic_in: vec![0.0; b * (o + a)],
            pi_in: vec![0.0; b * (o + a)],
            actor_out: vec![0.0; b * 2 * a],
            eps: vec![0.0; b * a],
            pi_act: vec![0.0; b * a],
            std: vec![0.0; b * a],
            in_clamp: vec![false; b * a],
            logp: vec![0.0; b],
            next_logp: vec![0.0; b],
            target: vec![0.0; b],
            grad1: vec![0.0; b],
            grad2: vec![0.0; b],
            dact: vec![0.0; b * a],
            grad_actor: vec![0.0; b * 2 * a],
            obs1: vec![0.0; o],
        }
    }
}

/// A cost the actor minimises beside the reward, with the critic that estimates it, trained on the
/// batch of SAC's own step (Lagrangian SAC, `safety/lagrangian.rs`). With it the actor's loss is
/// `mean(alpha logp - min(Q1, Q2) + lambda Q_c) / (1 + lambda)`, `lambda` constant within the
/// step, plus the behaviour-cloning term, weighed by the same `1 / (1 + lambda)` as SAC's terms
/// (its weight against the reward stays `bc_weight` whatever `lambda`).
pub(crate) trait CostTerm {
    /// One step of the cost critic on this step's batch: `critic_in` holds its `[s | a]` rows,
    /// `next_in` the `[s' | a']` rows with the next actions SAC sampled for its reward target.
    ///
    /// # Errors
    /// [`RlError::Diverged`] if the cost critic's loss is not finite.
    fn critic_step(&mut self, batch: &Batch, critic_in: &[f32], next_in: &[f32]) -> Result<(), RlError>;
    /// The multiplier `lambda >= 0` of this step.
    fn multiplier(&self) -> f32;
    /// Adds `weight * dQ_c/da~` to `dact` for the `[s | a~]` rows `pi_in` (through the updated
    /// cost critic) and returns `weight * sum_i Q_c(s_i, a~_i)`.
    fn actor_term(&mut self, pi_in: &[f32], weight: f32, dact: &mut [f32]) -> f32;
    /// Gradient-norm clipping of the actor and the reward critics (OmniSafe's `max_grad_norm`).
    fn max_grad_norm(&self) -> Option<f32>;
}

/// What `state.json` holds besides the networks and the buffer.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct SacState {
    algo: String,
    config: SacConfig,
    obs_dim: usize,
    act_dim: usize,
    num_timesteps: u64,
    n_updates: u64,
    log_alpha: f32,
    alpha_opt: Option<ScalarAdam>,
    rng: ChaCha8Rng,
}

/// A Soft Actor-Critic agent.
#[derive(Debug, Clone)]
pub struct Sac {
    config: SacConfig,
    obs_dim: usize,
    act_dim: usize,
    /// `obs -> net_arch -> [mean | log_std]` (SB3's `latent_pi`, then the `mu` and `log_std`
    /// heads as one linear layer: the same function and the same initial distribution).
    actor: Mlp,
    actor_opt: Adam,
    /// The twin critics with their targets.
    critics: TwinCritics,
    log_alpha: f32,
    /// `Some` when alpha is learned.
    alpha_opt: Option<ScalarAdam>,
    target_entropy: f32,
    experience: Experience,
    rng: ChaCha8Rng,
    n_updates: u64,
    ws: Workspace,
}

impl Sac {
    /// A fresh agent for observations of `obs_dim` and actions of `act_dim` values; weights
    /// and sampling derive from `seed`.
    ///
    /// # Errors
    /// [`RlError::Config`] if the configuration is out of range.
    pub fn new(config: SacConfig, obs_dim: usize, act_dim: usize, seed: u64) -> Result<Self, RlError> {
        config.validate()?;
        let (o, a, b) = (obs_dim, act_dim, config.batch_size);
        let mut init = ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Init, 0));
        let actor = new_mlp(&widths(o, &config.net_arch, 2 * a), Activation::Identity, &mut init)?;
        let adam = AdamConfig { lr: config.learning_rate as f32, ..AdamConfig::default() };
        let critics = TwinCritics::new(o, a, &config.net_arch, adam, b, &mut init)?;
        let (log_alpha, alpha_opt, target_entropy) = match config.ent_coef {
            EntCoef::Auto { target_entropy, init } => (
                init.ln(),
                Some(ScalarAdam::new(config.learning_rate)),
                target_entropy.unwrap_or(-(a as f32)),
            ),
            EntCoef::Fixed(alpha) => (alpha.ln(), None, -(a as f32)),
        };
        Ok(Self {
            actor_opt: Adam::new(&actor, adam),
            critics,
            experience: Experience::new(ReplayBuffer::new(config.buffer_size, o, a)?),
            rng: ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Agent, 0)),
            ws: Workspace::new(b, o, a),
            config,
            obs_dim,
            act_dim,
            actor,
            log_alpha,
            alpha_opt,
            target_entropy,
            n_updates: 0,
        })
    }

    /// The hyperparameters.
    pub fn config(&self) -> &SacConfig {
        &self.config
    }

    /// The current entropy coefficient.
    pub fn alpha(&self) -> f32 {
        match self.config.ent_coef {
            EntCoef::Fixed(alpha) => alpha,
            EntCoef::Auto { .. } => self.log_alpha.exp(),
        }
    }

    /// How many threads the networks use (defender-nn's default is `min(2, cores)`, or
    /// `DEFENDER_NN_THREADS`): the actor's matrix products are split over them, the twin critics
    /// run side by side. Results are bit-identical for every setting; use
    /// [`Parallelism::Sequential`] to run one training per core.
    pub fn set_parallelism(&mut self, parallelism: Parallelism) {
        self.actor.set_parallelism(parallelism);
        self.critics.set_parallelism(parallelism);
    }

    /// The replay buffer.
    pub fn buffer(&self) -> &ReplayBuffer {
        &self.experience.buffer
    }

    fn identity(&self) -> Identity {
        Identity { algo: "sac", obs_dim: self.obs_dim, act_dim: self.act_dim }
    }

    fn schedule(&self) -> Schedule {
        let c = &self.config;
        Schedule {
            learning_starts: c.learning_starts,
            train_freq: c.train_freq,
            gradient_steps: c.gradient_steps,
            min_buffer: if c.warmup { 0 } else { c.batch_size },
        }
    }

    /// [`Agent::update`], with `cost` in every gradient step.
    pub(crate) fn update_with(
        &mut self,
        mut cost: Option<&mut (dyn CostTerm + '_)>,
    ) -> Result<Option<UpdateStats>, RlError> {
        let buffer_len = self.experience.buffer.len();
        let schedule = self.schedule();
        schedule.run(self.experience.num_timesteps, buffer_len, || self.gradient_step(cost.as_deref_mut()))
    }

    /// Whether the schedule has not started learning yet (`num_timesteps <= learning_starts`).
    pub(crate) fn before_learning_starts(&self) -> bool {
        self.experience.num_timesteps <= self.config.learning_starts
    }

    /// The policy network (`obs -> [mean | log_std]`).
    pub fn actor(&self) -> &Mlp {
        &self.actor
    }

    /// Samples `a~ = tanh(mean + std eps)` and `log pi(a~|s)` for every row of the actor output
    /// in `ws.actor_out`: actions into `ws.pi_act` (with `eps`, `std`, `in_clamp` kept for the
    /// backward pass), log-probabilities into `ws.next_logp` if `next`, else `ws.logp`.
    fn sample_policy(ws: &mut Workspace, rng: &mut ChaCha8Rng, b: usize, a: usize, next: bool) {
        for i in 0..b {
            let mut logp = 0.0f32;
            for j in 0..a {
                let k = i * a + j;
                let mean = ws.actor_out[i * 2 * a + j];
                let raw = ws.actor_out[i * 2 * a + a + j];
                let log_std = raw.clamp(LOG_STD_MIN, LOG_STD_MAX);
                let std = log_std.exp();
                let eps: f32 = rng.sample(StandardNormal);
                let act = (mean + std * eps).tanh();
                // Gaussian log-density of u = mean + std eps, then the change of variables
                // a = tanh(u): log pi(a) = log N(u) - log(1 - tanh(u)^2 + 1e-6) per dimension.
                logp += -0.5 * eps * eps - log_std - LN_SQRT_2PI - (1.0 - act * act + TANH_EPS).ln();
                ws.eps[k] = eps;
                ws.std[k] = std;
                ws.pi_act[k] = act;
                ws.in_clamp[k] = (LOG_STD_MIN..=LOG_STD_MAX).contains(&raw);
            }
            if next {
                ws.next_logp[i] = logp;
            } else {
                ws.logp[i] = logp;
            }
        }
    }

    /// The actor's loss `mean(alpha logp - min(Q1, Q2)(s, a~))` through the (updated) critics,
    /// for the actions sampled by the last [`Sac::sample_policy`] of the current states; leaves
    /// its gradient in the actor (whose last forward pass must be that of the current states).
    /// With a `cost`, the Lagrangian loss of [`CostTerm`]: every term of SAC's loss is weighed by
    /// `k = 1 / (1 + lambda)` (`k = 1` exactly without, so plain SAC's numbers are unchanged).
    fn actor_backward(&mut self, alpha: f32, cost: Option<&mut (dyn CostTerm + '_)>) -> f32 {
        let (b, o, a) = (self.config.batch_size, self.obs_dim, self.act_dim);
        let ws = &mut self.ws;
        concat_rows(&mut ws.pi_in, &ws.batch.obs, &ws.pi_act, b, o, a);
        let pi_in = &ws.pi_in;
        self.critics.each(|_, c| c.forward(pi_in, b));
        let (q1, q2) = (&self.critics[0].q, &self.critics[1].q);
        let lambda = cost.as_ref().map_or(0.0, |c| c.multiplier());
        let k = 1.0 / (1.0 + lambda);
        let mut actor_loss = 0.0f32;
        for i in 0..b {
            // The min's gradient goes to the smaller critic (the first on ties, as torch.min).
            let first = q1[i] <= q2[i];
            let min_q = if first { q1[i] } else { q2[i] };
            actor_loss += k * (alpha * ws.logp[i] - min_q) / b as f32;
            ws.grad1[i] = if first { -k / b as f32 } else { 0.0 };
            ws.grad2[i] = if first { 0.0 } else { -k / b as f32 };
        }
        let grads = [&ws.grad1, &ws.grad2];
        self.critics.each(|k, c| c.backward_input(grads[k], b));
        let (d1, d2) = (&self.critics[0].dinput, &self.critics[1].dinput);
        for i in 0..b {
            for j in 0..a {
                ws.dact[i * a + j] = d1[i * (o + a) + o + j];
            }
        }
        for i in 0..b {
            for j in 0..a {
                ws.dact[i * a + j] += d2[i * (o + a) + o + j];
            }
        }
        if let Some(cost) = cost {
            actor_loss += cost.actor_term(&ws.pi_in, k * lambda / b as f32, &mut ws.dact);
        }
        // The cloning term belongs to the task's side of the Lagrangian, so it is weighed by `k`
        // as SAC's terms are: its weight against the reward stays `bc_weight` whatever `lambda`
        // (docs/decisions-baselines.md, "The learner half under a multiplier").
        actor_loss += Self::behaviour_cloning(ws, &self.config, b, a, k);
        // Back through a~ = tanh(u), u = mean + std eps, and log pi:
        //   dL/du = dL/da~ (1 - a~^2) + (alpha/b) d/du[-log(1 - tanh(u)^2 + 1e-6)]
        //   dL/dmean = dL/du;  dL/dlog_std = dL/du std eps - alpha/b  (d log N(u)/d log_std = -1
        //   once u is reparameterised), zero where the clamp cut log_std.
        let scale = k * alpha / b as f32;
        for i in 0..b {
            for j in 0..a {
                let k = i * a + j;
                let t = ws.pi_act[k];
                let one_minus = 1.0 - t * t;
                let du = ws.dact[k] * one_minus + scale * 2.0 * t * one_minus / (one_minus + TANH_EPS);
                ws.grad_actor[i * 2 * a + j] = du;
                ws.grad_actor[i * 2 * a + a + j] =
                    if ws.in_clamp[k] { du * ws.std[k] * ws.eps[k] - scale } else { 0.0 };
            }
        }
        self.actor.zero_grad();
        self.actor.backward_params(rows(&ws.grad_actor, b, 2 * a));
        actor_loss
    }

    /// Adds the behaviour-cloning term's gradient `d/da~` to `ws.dact` and returns the term
    /// (0 when `bc_weight` is 0). Per row `i` and action dimension `j`, with `e = a~_ij - a_ij`:
    /// per-row `k w bc_i e^2 / (b a)`; the authors' `k w mean(bc) e^2 / (b a)` on every row
    /// (`k` is the Lagrangian's `1 / (1 + lambda)`, 1 exactly without a cost term).
    fn behaviour_cloning(ws: &mut Workspace, config: &SacConfig, b: usize, a: usize, k: f32) -> f32 {
        let w = config.bc_weight as f32;
        if w == 0.0 {
            return 0.0;
        }
        let share = ws.batch.bc.iter().sum::<f32>() / b as f32;
        let scale = k * w / (b * a) as f32;
        let mut loss = 0.0f32;
        for i in 0..b {
            let row_weight = match config.bc_form {
                BcForm::PerRow => ws.batch.bc[i],
                BcForm::Authors => share,
            };
            if row_weight == 0.0 {
                continue;
            }
            for j in 0..a {
                let k = i * a + j;
                let e = ws.pi_act[k] - ws.batch.actions[k];
                loss += scale * row_weight * e * e;
                ws.dact[k] += scale * row_weight * 2.0 * e;
            }
        }
        loss
    }

    /// One gradient step on a fresh batch, with the cost critic's step and the actor's cost term
    /// if `cost` is given.
    fn gradient_step(&mut self, mut cost: Option<&mut (dyn CostTerm + '_)>) -> Result<UpdateStats, RlError> {
        let (b, o, a) = (self.config.batch_size, self.obs_dim, self.act_dim);
        let gamma = self.config.gamma as f32;
        let ws = &mut self.ws;
        self.experience.buffer.sample_into(&mut self.rng, &mut ws.batch)?;
        // The coefficient of this step is the value before this step's alpha update (SB3).
        let alpha = match self.config.ent_coef {
            EntCoef::Fixed(alpha) => alpha,
            EntCoef::Auto { .. } => self.log_alpha.exp(),
        };

        // Bellman target from the next states, with actions from the current policy (no gradient).
        copy_out(self.actor.forward(rows(&ws.batch.next_obs, b, o)), &mut ws.actor_out);
        Self::sample_policy(ws, &mut self.rng, b, a, true);
        concat_rows(&mut ws.next_in, &ws.batch.next_obs, &ws.pi_act, b, o, a);
        let next_in = &ws.next_in;
        self.critics.each(|_, c| c.forward_target(next_in, b));
        let (qt1, qt2) = (&self.critics[0].q, &self.critics[1].q);
        for i in 0..b {
            let next_q = qt1[i].min(qt2[i]) - alpha * ws.next_logp[i];
            // Bootstrap only if the episode did not terminate; a truncated transition (time
            // limit) bootstraps as usual: its `terminated` is 0.
            ws.target[i] = ws.batch.rewards[i] + (1.0 - ws.batch.terminated[i]) * gamma * next_q;
        }

        // Fresh actions for the current states; the actor's forward pass stays for its backward.
        copy_out(self.actor.forward(rows(&ws.batch.obs, b, o)), &mut ws.actor_out);
        Self::sample_policy(ws, &mut self.rng, b, a, false);
        let mean_logp = ws.logp.iter().sum::<f32>() / b as f32;

        // Entropy coefficient: d/d(log_alpha) of -log_alpha (logp + target) averaged.
        let mut alpha_loss = None;
        if let Some(opt) = &mut self.alpha_opt {
            let g = -(mean_logp + self.target_entropy);
            alpha_loss = Some(self.log_alpha * g);
            opt.step(&mut self.log_alpha, g);
        }

        // Critics: 0.5 * sum_i mse(Q_i(s, a), y); d/dQ_i = (Q_i - y) / b.
        concat_rows(&mut ws.critic_in, &ws.batch.obs, &ws.batch.actions, b, o, a);
        let (critic_in, target) = (&ws.critic_in, &ws.target);
        let max_grad_norm = cost.as_ref().and_then(|c| c.max_grad_norm());
        self.critics.train_step(critic_in, target, b, &|diff| diff / b as f32, max_grad_norm);
        let (mut qf_loss, mut qf1_mean) = (0.0f32, 0.0f32);
        for (k, values) in [&self.critics[0].q, &self.critics[1].q].into_iter().enumerate() {
            for (&q, &y) in values.iter().zip(target) {
                let diff = q - y;
                qf_loss += 0.5 * diff * diff / b as f32;
                if k == 0 {
                    qf1_mean += q / b as f32;
                }
            }
        }

        // The cost critic after the reward critics, before the actor (OmniSafe's order).
        if let Some(cost) = cost.as_deref_mut() {
            cost.critic_step(&ws.batch, &ws.critic_in, &ws.next_in)?;
        }

        let actor_loss = self.actor_backward(alpha, cost);
        if let Some(max) = max_grad_norm {
            clip_grad_norm(&mut self.actor, max);
        }
        self.actor_opt.step(&mut self.actor);

        self.n_updates += 1;
        if self.n_updates.is_multiple_of(self.config.target_update_interval) {
            let tau = self.config.tau as f32;
            self.critics.polyak(tau);
        }
        if !(qf_loss.is_finite() && actor_loss.is_finite()) {
            return Err(RlError::Diverged { what: "SAC loss", update: self.n_updates });
        }
        Ok(UpdateStats {
            n_updates: self.n_updates,
            qf_loss,
            qf1_mean,
            actor_loss: Some(actor_loss),
            alpha: Some(alpha),
            alpha_loss,
            recovery_steps: None,
            cost_critic_loss: None,
            lagrange_multiplier: None,
            qc_mean: None,
        })
    }
}

impl Agent for Sac {
    fn algo(&self) -> &'static str {
        "sac"
    }

    fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    fn act_dim(&self) -> usize {
        self.act_dim
    }

    fn num_timesteps(&self) -> u64 {
        self.experience.num_timesteps
    }

    fn act(&mut self, obs: &[f64], deterministic: bool, action: &mut [f32]) -> Result<(), RlError> {
        let warming = self.config.warmup && self.experience.warming_up(self.config.learning_starts);
        let (o, a) = (self.obs_dim, self.act_dim);
        sample_action(
            &mut self.actor,
            &mut self.ws.obs1,
            (o, a),
            warming,
            deterministic,
            &mut self.rng,
            obs,
            action,
        )
    }

    fn act_with(&mut self, obs: &[f64], rng: &mut ChaCha8Rng, action: &mut [f32]) -> Result<(), RlError> {
        let warming = self.config.warmup && self.experience.warming_up(self.config.learning_starts);
        let (o, a) = (self.obs_dim, self.act_dim);
        sample_action(&mut self.actor, &mut self.ws.obs1, (o, a), warming, false, rng, obs, action)
    }

    fn observe(&mut self, transition: &Transition<'_>) -> Result<(), RlError> {
        self.experience.observe(transition, self.config.terminal_on_truncation)
    }

    fn store_demonstration(&mut self, transition: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        self.experience.store_demonstration(transition, bc, self.config.terminal_on_truncation)
    }

    fn update(&mut self) -> Result<Option<UpdateStats>, RlError> {
        self.update_with(None)
    }

    fn save(&self, dir: &Path) -> Result<(), RlError> {
        save_net(dir, "actor", &self.actor, Some(&self.actor_opt))?;
        self.critics.save(dir)?;
        self.experience.buffer.save(&dir.join("replay.bin"))?;
        let state = SacState {
            algo: "sac".into(),
            config: self.config.clone(),
            obs_dim: self.obs_dim,
            act_dim: self.act_dim,
            num_timesteps: self.experience.num_timesteps,
            n_updates: self.n_updates,
            log_alpha: self.log_alpha,
            alpha_opt: self.alpha_opt.clone(),
            rng: self.rng.clone(),
        };
        write_json(&dir.join("state.json"), &state)
    }

    fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        let path = dir.join("state.json");
        let state: SacState = read_json(&path)?;
        let dims = (state.obs_dim, state.act_dim);
        check_saved(&path, &state.algo, dims, state.config == self.config, self.identity())?;
        load_net(dir, "actor", &mut self.actor, Some(&mut self.actor_opt))?;
        self.critics.load(dir)?;
        self.experience.buffer.load(&dir.join("replay.bin"))?;
        self.experience.num_timesteps = state.num_timesteps;
        self.n_updates = state.n_updates;
        self.log_alpha = state.log_alpha;
        self.alpha_opt = state.alpha_opt;
        self.rng = state.rng;
        Ok(())
    }

    fn save_actor(&self, path: &Path) -> Result<(), RlError> {
        Ok(self.actor.save_safetensors(path)?)
    }
}

/// SAC's action for `obs` into `action`: uniform while `warming` (exploration only), else the
/// squashed Gaussian of `actor` (its mean when `deterministic`), every draw from `rng`.
#[allow(clippy::too_many_arguments)]
fn sample_action(
    actor: &mut Mlp,
    obs1: &mut [f32],
    (obs_dim, act_dim): (usize, usize),
    warming: bool,
    deterministic: bool,
    rng: &mut ChaCha8Rng,
    obs: &[f64],
    action: &mut [f32],
) -> Result<(), RlError> {
    check_action_len(action, act_dim)?;
    obs_to_f32(obs, obs1)?;
    if !deterministic && warming {
        uniform_action(rng, action);
        return Ok(());
    }
    let out = actor.forward(rows(obs1, 1, obs_dim));
    for (j, x) in action.iter_mut().enumerate() {
        let mean = *out.get(0, j);
        *x = if deterministic {
            mean.tanh()
        } else {
            let std = out.get(0, act_dim + j).clamp(LOG_STD_MIN, LOG_STD_MAX).exp();
            let eps: f32 = rng.sample(StandardNormal);
            (mean + std * eps).tanh()
        };
    }
    Ok(())
}

#[cfg(test)]
#[path = "sac_tests.rs"]
mod tests;

#[path = "sac_sample.rs"]
mod sample;

#[cfg(test)]
#[path = "sac_bootstrap_tests.rs"]
mod bootstrap_tests;
