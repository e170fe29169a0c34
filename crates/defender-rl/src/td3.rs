//! Twin Delayed DDPG (Fujimoto et al. 2018), as Stable-Baselines3's `TD3` computes it: a
//! deterministic tanh policy, twin critics, target policy smoothing, delayed actor updates.
//!
//! One gradient step (SB3 `TD3.train`):
//!
//! ```text
//! n_updates += 1
//! a' = clip(pi_t(s') + clip(N(0, target_policy_noise), -c, c), -1, 1)
//! y  = r + gamma (1 - terminated) min_i Qt_i(s', a')
//! critic step on sum_i mean (Q_i(s, a) - y)^2
//! every policy_delay updates:
//!     actor step on -mean Q_1(s, pi(s));  Qt_i <- tau Q_i + (1 - tau) Qt_i;  pi_t <- tau pi + (1 - tau) pi_t
//! ```
//!
//! Exploration adds `N(0, exploration_noise)` to the policy's action and clips to [-1, 1].

use std::path::Path;

use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::agent::{Agent, UpdateStats};
use crate::checkpoint::{read_json, write_json};
use crate::config::Td3Config;
use crate::critics::TwinCritics;
use crate::error::RlError;
use crate::nets::{
    check_action_len, concat_rows, copy_out, load_net, new_mlp, obs_to_f32, rows, save_net, widths,
};
use crate::off_policy::{Experience, Identity, Schedule, check_saved, uniform_action};
use crate::replay::{Batch, ReplayBuffer, Transition};
use crate::seed::{SeedPurpose, derive_seed};

/// Buffers of one gradient step, allocated once.
#[derive(Debug, Clone)]
struct Workspace {
    batch: Batch,
    /// Target actions `a'`, then policy actions `pi(s)`, `b x a`.
    act: Vec<f32>,
    /// `[s' | a']` rows, then `[s | pi(s)]` rows.
    next_in: Vec<f32>,
    /// `[s | a]` rows (replayed actions).
    critic_in: Vec<f32>,
    target: Vec<f32>,
    /// The actor loss's gradient with respect to the first critic's output.
    grad: Vec<f32>,
    dact: Vec<f32>,
    obs1: Vec<f32>,
}

/// What `state.json` holds besides the networks and the buffer.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Td3State {
    algo: String,
    config: Td3Config,
    obs_dim: usize,
    act_dim: usize,
    num_timesteps: u64,
    n_updates: u64,
    rng: ChaCha8Rng,
}

/// A TD3 agent.
#[derive(Debug, Clone)]
pub struct Td3 {
    config: Td3Config,
    obs_dim: usize,
    act_dim: usize,
    /// `obs -> net_arch -> act` with a tanh output.
    actor: Mlp,
    actor_target: Mlp,
    actor_opt: Adam,
    /// The twin critics with their targets.
    critics: TwinCritics,
    experience: Experience,
    rng: ChaCha8Rng,
    n_updates: u64,
    ws: Workspace,
}

impl Td3 {
    /// A fresh agent for observations of `obs_dim` and actions of `act_dim` values; weights
    /// and sampling derive from `seed`.
    ///
    /// # Errors
    /// [`RlError::Config`] if the configuration is out of range.
    pub fn new(config: Td3Config, obs_dim: usize, act_dim: usize, seed: u64) -> Result<Self, RlError> {
        config.validate()?;
        let (o, a, b) = (obs_dim, act_dim, config.batch_size);
        let mut init = ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Init, 0));
        let actor = new_mlp(&widths(o, &config.net_arch, a), Activation::Tanh, &mut init)?;
        let adam = AdamConfig { lr: config.learning_rate as f32, ..AdamConfig::default() };
        let critics = TwinCritics::new(o, a, &config.net_arch, adam, b, &mut init)?;
        Ok(Self {
            actor_target: actor.clone(),
            actor_opt: Adam::new(&actor, adam),
            critics,
            experience: Experience::new(ReplayBuffer::new(config.buffer_size, o, a)?),
            rng: ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Agent, 0)),
            ws: Workspace {
                batch: Batch::new(b, o, a),
                act: vec![0.0; b * a],
                next_in: vec![0.0; b * (o + a)],
                critic_in: vec![0.0; b * (o + a)],
                target: vec![0.0; b],
                grad: vec![0.0; b],
                dact: vec![0.0; b * a],
                obs1: vec![0.0; o],
            },
            config,
            obs_dim,
            act_dim,
            actor,
            n_updates: 0,
        })
    }

    /// The hyperparameters.
    pub fn config(&self) -> &Td3Config {
        &self.config
    }

    /// How many threads the networks use (defender-nn's default is `min(2, cores)`, or
    /// `DEFENDER_NN_THREADS`): the actor's matrix products are split over them, the twin critics
    /// run side by side. Results are bit-identical for every setting; use
    /// [`Parallelism::Sequential`] to run one training per core.
    pub fn set_parallelism(&mut self, parallelism: Parallelism) {
        self.actor.set_parallelism(parallelism);
        self.actor_target.set_parallelism(parallelism);
        self.critics.set_parallelism(parallelism);
    }

    /// The replay buffer.
    pub fn buffer(&self) -> &ReplayBuffer {
        &self.experience.buffer
    }

    fn identity(&self) -> Identity {
        Identity { algo: "td3", obs_dim: self.obs_dim, act_dim: self.act_dim }
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

    /// The policy network (`obs -> action in [-1, 1]`).
    pub fn actor(&self) -> &Mlp {
        &self.actor
    }

    /// One gradient step on a fresh batch.
    fn gradient_step(&mut self) -> Result<UpdateStats, RlError> {
        let (b, o, a) = (self.config.batch_size, self.obs_dim, self.act_dim);
        let gamma = self.config.gamma as f32;
        let (sigma, clip) = (self.config.target_policy_noise as f32, self.config.target_noise_clip as f32);
        let ws = &mut self.ws;
        self.n_updates += 1;
        self.experience.buffer.sample_into(&mut self.rng, &mut ws.batch)?;

        // Target policy smoothing: clipped Gaussian noise on the target actor's action.
        copy_out(self.actor_target.forward(rows(&ws.batch.next_obs, b, o)), &mut ws.act);
        for x in &mut ws.act {
            let noise = (self.rng.sample::<f32, _>(StandardNormal) * sigma).clamp(-clip, clip);
            *x = (*x + noise).clamp(-1.0, 1.0);
        }
        concat_rows(&mut ws.next_in, &ws.batch.next_obs, &ws.act, b, o, a);
        let next_in = &ws.next_in;
        self.critics.each(|_, c| c.forward_target(next_in, b));
        let (qt1, qt2) = (&self.critics[0].q, &self.critics[1].q);
        for i in 0..b {
            // Bootstrap only if the episode did not terminate (truncation bootstraps).
            ws.target[i] = ws.batch.rewards[i] + (1.0 - ws.batch.terminated[i]) * gamma * qt1[i].min(qt2[i]);
        }

        // Critics: sum_i mse(Q_i(s, a), y) (no 0.5 here, unlike SAC); d/dQ_i = 2 (Q_i - y) / b.
        concat_rows(&mut ws.critic_in, &ws.batch.obs, &ws.batch.actions, b, o, a);
        let (critic_in, target) = (&ws.critic_in, &ws.target);
        self.critics.each(|_, c| c.train_step(critic_in, target, b, &|diff| 2.0 * diff / b as f32));
        let (mut qf_loss, mut qf1_mean) = (0.0f32, 0.0f32);
        for (k, values) in [&self.critics[0].q, &self.critics[1].q].into_iter().enumerate() {
            for (&q, &y) in values.iter().zip(target) {
                let diff = q - y;
                qf_loss += diff * diff / b as f32;
                if k == 0 {
                    qf1_mean += q / b as f32;
                }
            }
        }

        // Delayed policy update: maximise Q_1(s, pi(s)), then move all targets.
        let mut actor_loss = None;
        if self.n_updates.is_multiple_of(self.config.policy_delay) {
            copy_out(self.actor.forward(rows(&ws.batch.obs, b, o)), &mut ws.act);
            concat_rows(&mut ws.next_in, &ws.batch.obs, &ws.act, b, o, a);
            let q1 = self.critics.alone(0);
            q1.forward(&ws.next_in, b);
            actor_loss = Some(-q1.q[..b].iter().sum::<f32>() / b as f32);
            ws.grad.fill(-1.0 / b as f32);
            q1.backward_input(&ws.grad, b);
            for i in 0..b {
                for j in 0..a {
                    ws.dact[i * a + j] = q1.dinput[i * (o + a) + o + j];
                }
            }
            // The actor's own tanh is inside the network: backward_params differentiates it.
            self.actor.zero_grad();
            self.actor.backward_params(rows(&ws.dact, b, a));
            self.actor_opt.step(&mut self.actor);
            let tau = self.config.tau as f32;
            self.critics.polyak(tau);
            self.actor_target.polyak_update(&self.actor, tau);
        }
        if !qf_loss.is_finite() || actor_loss.is_some_and(|l| !l.is_finite()) {
            return Err(RlError::Diverged { what: "TD3 loss", update: self.n_updates });
        }
        Ok(UpdateStats {
            n_updates: self.n_updates,
            qf_loss,
            qf1_mean,
            actor_loss,
            alpha: None,
            alpha_loss: None,
            recovery_steps: None,
            cost_critic_loss: None,
            lagrange_multiplier: None,
            qc_mean: None,
        })
    }
}

impl Agent for Td3 {
    fn algo(&self) -> &'static str {
        "td3"
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
        let sigma = self.config.exploration_noise as f32;
        let ws = &mut self.ws.obs1;
        sample_action(
            &mut self.actor,
            ws,
            self.obs_dim,
            (warming, deterministic, sigma),
            &mut self.rng,
            obs,
            action,
        )
    }

    fn act_with(&mut self, obs: &[f64], rng: &mut ChaCha8Rng, action: &mut [f32]) -> Result<(), RlError> {
        let warming = self.config.warmup && self.experience.warming_up(self.config.learning_starts);
        let sigma = self.config.exploration_noise as f32;
        sample_action(
            &mut self.actor,
            &mut self.ws.obs1,
            self.obs_dim,
            (warming, false, sigma),
            rng,
            obs,
            action,
        )
    }

    fn observe(&mut self, transition: &Transition<'_>) -> Result<(), RlError> {
        self.experience.observe(transition, self.config.terminal_on_truncation)
    }

    fn store_demonstration(&mut self, transition: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        self.experience.store_demonstration(transition, bc, self.config.terminal_on_truncation)
    }

    fn update(&mut self) -> Result<Option<UpdateStats>, RlError> {
        let buffer_len = self.experience.buffer.len();
        self.schedule().run(self.experience.num_timesteps, buffer_len, || self.gradient_step())
    }

    fn save(&self, dir: &Path) -> Result<(), RlError> {
        save_net(dir, "actor", &self.actor, Some(&self.actor_opt))?;
        save_net(dir, "actor_target", &self.actor_target, None)?;
        self.critics.save(dir)?;
        self.experience.buffer.save(&dir.join("replay.bin"))?;
        let state = Td3State {
            algo: "td3".into(),
            config: self.config.clone(),
            obs_dim: self.obs_dim,
            act_dim: self.act_dim,
            num_timesteps: self.experience.num_timesteps,
            n_updates: self.n_updates,
            rng: self.rng.clone(),
        };
        write_json(&dir.join("state.json"), &state)
    }

    fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        let path = dir.join("state.json");
        let state: Td3State = read_json(&path)?;
        let dims = (state.obs_dim, state.act_dim);
        check_saved(&path, &state.algo, dims, state.config == self.config, self.identity())?;
        load_net(dir, "actor", &mut self.actor, Some(&mut self.actor_opt))?;
        load_net(dir, "actor_target", &mut self.actor_target, None)?;
        self.critics.load(dir)?;
        self.experience.buffer.load(&dir.join("replay.bin"))?;
        self.experience.num_timesteps = state.num_timesteps;
        self.n_updates = state.n_updates;
        self.rng = state.rng;
        Ok(())
    }

    fn save_actor(&self, path: &Path) -> Result<(), RlError> {
        Ok(self.actor.save_safetensors(path)?)
    }
}

/// TD3's action for `obs`: uniform while warming up (exploration only), else the actor's, with
/// Gaussian noise of `sigma` unless `deterministic`; every draw from `rng`.
fn sample_action(
    actor: &mut Mlp,
    obs1: &mut [f32],
    obs_dim: usize,
    (warming, deterministic, sigma): (bool, bool, f32),
    rng: &mut ChaCha8Rng,
    obs: &[f64],
    action: &mut [f32],
) -> Result<(), RlError> {
    check_action_len(action, actor.out_dim())?;
    obs_to_f32(obs, obs1)?;
    if !deterministic && warming {
        uniform_action(rng, action);
        return Ok(());
    }
    let out = actor.forward(rows(obs1, 1, obs_dim));
    for (j, x) in action.iter_mut().enumerate() {
        *x = *out.get(0, j);
        if !deterministic {
            *x = (*x + sigma * rng.sample::<f32, _>(StandardNormal)).clamp(-1.0, 1.0);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filled(terminated: bool) -> Td3 {
        let config =
            Td3Config { net_arch: vec![8], batch_size: 16, learning_starts: 0, ..Td3Config::default() };
        let mut td3 = Td3::new(config, 2, 1, 0).unwrap();
        for i in 0..20 {
            let x = f64::from(i) / 20.0;
            let t = Transition {
                obs: &[x, -x],
                action: &[0.5],
                reward: x,
                cost: 0.0,
                next_obs: &[x, x],
                terminated,
                truncated: !terminated,
            };
            td3.observe(&t).unwrap();
        }
        td3
    }

    #[test]
    fn terminated_transitions_do_not_bootstrap_and_truncated_ones_do() {
        let mut td3 = filled(true);
        td3.gradient_step().unwrap();
        assert_eq!(td3.ws.target, td3.ws.batch.rewards, "terminated: y = r");
        let mut td3 = filled(false);
        td3.gradient_step().unwrap();
        assert!(
            td3.ws.target.iter().zip(&td3.ws.batch.rewards).all(|(y, r)| y != r),
            "truncated: y = r + gamma Q"
        );
    }

    #[test]
    fn the_actor_and_targets_move_every_policy_delay_updates() {
        let mut td3 = filled(false);
        let actor0 = td3.actor.params().to_vec();
        let target0 = td3.critics[0].target.params().to_vec();
        assert!(td3.gradient_step().unwrap().actor_loss.is_none());
        assert_eq!(td3.actor.params(), &actor0[..]);
        assert_eq!(td3.critics[0].target.params(), &target0[..]);
        assert!(td3.gradient_step().unwrap().actor_loss.is_some());
        assert_ne!(td3.actor.params(), &actor0[..]);
        assert_ne!(td3.critics[0].target.params(), &target0[..]);
    }
}
