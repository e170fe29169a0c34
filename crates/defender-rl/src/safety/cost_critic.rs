//! Lagrangian SAC's cost critic `Q_c(s, a)`: the expected discounted cost of taking `a` in `s`,
//! one network built like SAC's reward critics (same hidden layers, learning rate, Polyak rate),
//! trained as OmniSafe 0.5's `_update_cost_critic` does:
//!
//! ```text
//! y   = c + gamma (1 - terminated) Q_c'(s', a')     (no entropy term)
//! step on mean (Q_c(s, a) - y)^2                    (torch's mse_loss)
//! ```
//!
//! `a'` is the next action SAC sampled for its reward target in the same step, not the actor's
//! deterministic action OmniSafe takes (docs/decisions-baselines.md, "Lagrangian SAC").

use std::path::Path;

use defender_nn::{AdamConfig, Parallelism};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::config::SacConfig;
use crate::critics::Critic;
use crate::error::RlError;
use crate::replay::Batch;
use crate::seed::{SeedPurpose, derive_seed};

/// The cost critic, its target, its optimiser and buffers.
#[derive(Debug, Clone)]
pub(crate) struct CostCritic {
    critic: Critic,
    obs_dim: usize,
    act_dim: usize,
    batch_size: usize,
    gamma: f32,
    tau: f32,
    target_update_interval: u64,
    /// Bellman targets of the last step.
    y: Vec<f32>,
    /// `dL/dQ_c` of the actor's cost term, per row.
    grad: Vec<f32>,
    /// Gradient steps taken (for the target's update interval; kept by checkpoints).
    pub(crate) updates: u64,
    /// The loss of the last step (before it).
    pub(crate) last_loss: f32,
}

impl CostCritic {
    /// A fresh cost critic with SAC's `config` for its network and rates. Its weights come from
    /// a stream of their own (`Init`, index 1), so the actor and the reward critics start as a
    /// plain SAC's of the same seed.
    ///
    /// # Errors
    /// [`RlError::Config`] if the layers are invalid.
    pub(crate) fn new(
        config: &SacConfig,
        obs_dim: usize,
        act_dim: usize,
        seed: u64,
    ) -> Result<Self, RlError> {
        let mut init = ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Init, 1));
        let adam = AdamConfig { lr: config.learning_rate as f32, ..AdamConfig::default() };
        let b = config.batch_size;
        let critic = Critic::new(obs_dim + act_dim, &config.net_arch, adam, b, &mut init)?;
        Ok(Self {
            critic,
            obs_dim,
            act_dim,
            batch_size: b,
            gamma: config.gamma as f32,
            tau: config.tau as f32,
            target_update_interval: config.target_update_interval,
            y: vec![0.0; b],
            grad: vec![0.0; b],
            updates: 0,
            last_loss: 0.0,
        })
    }

    /// The networks' threads.
    pub(crate) fn set_parallelism(&mut self, parallelism: Parallelism) {
        self.critic.net.set_parallelism(parallelism);
        self.critic.target.set_parallelism(parallelism);
    }

    /// One step on the batch: `critic_in` its `[s | a]` rows, `next_in` its `[s' | a']` rows.
    /// Returns the loss before the step.
    ///
    /// # Errors
    /// [`RlError::Diverged`] if the loss is not finite.
    pub(crate) fn step(&mut self, batch: &Batch, critic_in: &[f32], next_in: &[f32]) -> Result<f32, RlError> {
        let b = self.batch_size;
        self.critic.forward_target(next_in, b);
        for i in 0..b {
            // As the reward critics: a truncated transition bootstraps, a terminated one does not.
            self.y[i] = batch.costs[i] + (1.0 - batch.terminated[i]) * self.gamma * self.critic.q[i];
        }
        self.critic.train_step(critic_in, &self.y, b, &|diff| 2.0 * diff / b as f32);
        let loss = self.critic.q.iter().zip(&self.y).map(|(q, y)| (q - y) * (q - y)).sum::<f32>() / b as f32;
        self.updates += 1;
        if self.updates.is_multiple_of(self.target_update_interval) {
            self.critic.polyak(self.tau);
        }
        self.last_loss = loss;
        if !loss.is_finite() {
            return Err(RlError::Diverged { what: "cost critic loss", update: self.updates });
        }
        Ok(loss)
    }

    /// Adds `weight * dQ_c/da~` to `dact` (rows of `act_dim`) for the `[s | a~]` rows `pi_in`
    /// and returns `weight * sum_i Q_c(s_i, a~_i)`.
    pub(crate) fn actor_term(&mut self, pi_in: &[f32], weight: f32, dact: &mut [f32]) -> f32 {
        let (b, o, a) = (self.batch_size, self.obs_dim, self.act_dim);
        self.critic.forward(pi_in, b);
        let sum: f32 = self.critic.q.iter().sum();
        self.grad.fill(weight);
        self.critic.backward_input(&self.grad, b);
        let d = &self.critic.dinput;
        for i in 0..b {
            for j in 0..a {
                dact[i * a + j] += d[i * (o + a) + o + j];
            }
        }
        weight * sum
    }

    /// Saves the critic as `qc` (with its optimiser) and `qc_target`.
    pub(crate) fn save(&self, dir: &Path) -> Result<(), RlError> {
        self.critic.save(dir, "qc")
    }

    /// Loads what [`CostCritic::save`] wrote.
    pub(crate) fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        self.critic.load(dir, "qc")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nets::{concat_rows, rows};
    use rand::Rng;

    /// A batch of 8 rows of 3-dim states and 2-dim actions, with costs and terminations.
    fn batch() -> (Batch, Vec<f32>, Vec<f32>) {
        let (b, o, a) = (8, 3, 2);
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut batch = Batch::new(b, o, a);
        let mut fill = |v: &mut Vec<f32>| v.iter_mut().for_each(|x| *x = rng.random_range(-1.0..1.0));
        fill(&mut batch.obs);
        fill(&mut batch.next_obs);
        fill(&mut batch.actions);
        let mut next_act = vec![0.0; b * a];
        fill(&mut next_act);
        for i in 0..b {
            batch.costs[i] = f32::from(u8::from(i % 3 == 0));
            batch.terminated[i] = f32::from(u8::from(i % 4 == 0));
        }
        let (mut critic_in, mut next_in) = (vec![0.0; b * (o + a)], vec![0.0; b * (o + a)]);
        concat_rows(&mut critic_in, &batch.obs, &batch.actions, b, o, a);
        concat_rows(&mut next_in, &batch.next_obs, &next_act, b, o, a);
        (batch, critic_in, next_in)
    }

    fn critic() -> CostCritic {
        let config = SacConfig { net_arch: vec![16, 16], batch_size: 8, ..SacConfig::default() };
        CostCritic::new(&config, 3, 2, 9).unwrap()
    }

    /// `mean (Q_c(s, a) - y)^2` for fixed targets `y`.
    fn loss(c: &mut CostCritic, critic_in: &[f32], y: &[f32]) -> f32 {
        let q = c.critic.net.forward(rows(critic_in, 8, 5));
        (0..8).map(|i| (q.get(i, 0) - y[i]).powi(2)).sum::<f32>() / 8.0
    }

    #[test]
    fn the_target_adds_the_discounted_next_value_unless_terminated() {
        let (batch, critic_in, next_in) = batch();
        let mut c = critic();
        let target = c.critic.target.forward(rows(&next_in, 8, 5));
        let next_q: Vec<f32> = (0..8).map(|i| *target.get(i, 0)).collect();
        c.step(&batch, &critic_in, &next_in).unwrap();
        for (i, (&q, &cost)) in next_q.iter().zip(&batch.costs).enumerate() {
            let expected = if i % 4 == 0 { cost } else { cost + 0.99 * q };
            assert_eq!(c.y[i], expected, "row {i}");
        }
    }

    #[test]
    fn the_cost_critic_gradient_matches_finite_differences() {
        let (batch, critic_in, next_in) = batch();
        let before = critic();
        let mut stepped = before.clone();
        let reported = stepped.step(&batch, &critic_in, &next_in).unwrap();
        let analytic = stepped.critic.net.grads().to_vec();
        let y = stepped.y.clone();
        let mut c = before;
        assert!((loss(&mut c, &critic_in, &y) - reported).abs() < 1e-6);
        let h = 2e-3f32;
        let (mut checked, mut kinks) = (0, 0);
        for k in (0..c.critic.net.num_params()).step_by(3) {
            let p = c.critic.net.params()[k];
            c.critic.net.params_mut()[k] = p + h;
            let up = loss(&mut c, &critic_in, &y);
            c.critic.net.params_mut()[k] = p - h;
            let down = loss(&mut c, &critic_in, &y);
            c.critic.net.params_mut()[k] = p;
            let numeric = (up - down) / (2.0 * h);
            // 1e-4: a few f32 roundings of the loss over 2h.
            if (numeric - analytic[k]).abs() > 1e-4 + 2e-2 * numeric.abs().max(analytic[k].abs()) {
                eprintln!("param {k}: analytic {} numeric {numeric}", analytic[k]);
                kinks += 1;
            }
            checked += 1;
        }
        // A ReLU of some row switching within +-h spoils the difference quotient of a parameter
        // now and then (1 of 134 here); a wrong gradient would spoil most.
        assert!(kinks * 50 <= checked, "{kinks} of {checked} parameters disagree");
        assert!(checked > 50 && analytic.iter().any(|g| g.abs() > 1e-3));
    }
}
