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
//!
//! Bounded (the default since the repair, docs/decisions-baselines.md, "The cost critic
//! repaired"): a discounted sum of per-step costs in `[c_lo, c_hi]` lies in
//! `[lo, hi] = [c_lo, c_hi] / (1 - gamma)`, so the network's output is a sigmoid `p` and
//! `Q_c = lo + (hi - lo) p`: the actor, which minimises `Q_c`, cannot find actions where the
//! critic extrapolates below any cost (the first runs' linear critic reached -40 to -80 there).
//! The loss is that of `Q_c` itself, `mean (Q_c - y)^2`, its gradient taken through `p`; the
//! targets are clamped into `[lo, hi]`. Unbounded, `lo = 0` and `hi - lo = 1` with a linear
//! output: exactly the first runs' arithmetic.

use std::path::Path;

use defender_nn::{Activation, AdamConfig, Parallelism};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::config::SacConfig;
use crate::critics::Critic;
use crate::error::RlError;
use crate::nets::clip_grad_norm;
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
    /// `Q_c = lo + scale p`, `p` the network's output.
    lo: f32,
    scale: f32,
    /// Whether `p` is a sigmoid and the targets are clamped (see the module's docs).
    bounded: bool,
    /// Gradient-norm clipping of the critic's own step.
    max_grad_norm: Option<f32>,
    /// Bellman targets of the last step, in `p`'s units: `(y - lo) / scale`.
    y: Vec<f32>,
    /// `dL/dQ_c` of the actor's cost term, per row.
    grad: Vec<f32>,
    /// Gradient steps taken (for the target's update interval; kept by checkpoints).
    pub(crate) updates: u64,
    /// The loss of the last step (before it).
    pub(crate) last_loss: f32,
    /// The mean `Q_c` at the batch's states and the actor's actions, of the last actor term.
    pub(crate) last_qc_mean: f32,
}

/// The range of per-step costs the cost critic learns from, and its clipping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CostRange {
    /// `[c_lo, c_hi]`: every stored cost lies within (`None`: the unbounded linear critic).
    pub(crate) per_step: Option<(f32, f32)>,
    /// Gradient-norm clipping of the critic's step.
    pub(crate) max_grad_norm: Option<f32>,
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
        range: CostRange,
    ) -> Result<Self, RlError> {
        let mut init = ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Init, 1));
        let adam = AdamConfig { lr: config.learning_rate as f32, ..AdamConfig::default() };
        let b = config.batch_size;
        let output = if range.per_step.is_some() { Activation::Sigmoid } else { Activation::Identity };
        let mut critic =
            Critic::with_output(obs_dim + act_dim, &config.net_arch, adam, b, &mut init, output)?;
        if range.per_step.is_some() && config.gamma >= 1.0 {
            // The bound is a discounted sum's, c / (1 - gamma): no bound without a discount.
            return Err(RlError::Config {
                field: "gamma",
                value: config.gamma.to_string(),
                expected: "< 1 with the bounded cost critic ([safety] bounded_cost_critic, on by default), \
                           whose range is the per-step cost over (1 - gamma)",
            });
        }
        let horizon = 1.0 / (1.0 - config.gamma);
        let (lo, scale) = match range.per_step {
            Some((c_lo, c_hi)) => {
                ((f64::from(c_lo) * horizon) as f32, (f64::from(c_hi - c_lo) * horizon) as f32)
            }
            None => (0.0, 1.0),
        };
        if range.per_step.is_some() {
            // The sigmoid would start every Q_c mid-range (50 on a crash task, whose true Q_c is
            // at most 1); start it near a cost of 0, as the linear critic starts near 0: the
            // output bias at the logit of 0's place in the range, kept off the sigmoid's flat
            // ends (at least 1e-3 of the range up). It is the network's last parameter.
            let p0 = f64::from((0.0f32.clamp(lo, lo + scale) - lo) / scale).clamp(1e-3, 0.5);
            if let Some(bias) = critic.net.params_mut().last_mut() {
                *bias = (p0 / (1.0 - p0)).ln() as f32;
            }
            critic.target.copy_params_from(&critic.net);
        }
        Ok(Self {
            lo,
            scale,
            bounded: range.per_step.is_some(),
            max_grad_norm: range.max_grad_norm,
            last_qc_mean: 0.0,
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
        let (lo, scale, gamma) = (self.lo, self.scale, self.gamma);
        self.critic.forward_target(next_in, b);
        for i in 0..b {
            // As the reward critics: a truncated transition bootstraps, a terminated one does not.
            let next = lo + scale * self.critic.q[i];
            let y = batch.costs[i] + (1.0 - batch.terminated[i]) * gamma * next;
            let p = (y - lo) / scale;
            // Not dead: exact targets lie in [lo, hi], f32 rounding can put one an ulp outside (tested).
            self.y[i] = if self.bounded { p.clamp(0.0, 1.0) } else { p };
        }
        // d/dp mean (lo + scale p - y)^2 = 2 scale^2 (p - p_y) / b (2 (Q - y) / b unbounded).
        let k = 2.0 * scale * scale;
        self.critic.backward_step(critic_in, &self.y, b, &|diff| k * diff / b as f32);
        if let Some(max) = self.max_grad_norm {
            clip_grad_norm(&mut self.critic.net, max);
        }
        self.critic.apply_step();
        let loss =
            self.critic.q.iter().zip(&self.y).map(|(q, y)| (scale * (q - y)).powi(2)).sum::<f32>() / b as f32;
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
        let sum_p: f32 = self.critic.q.iter().sum();
        let sum = b as f32 * self.lo + self.scale * sum_p;
        self.last_qc_mean = sum / b as f32;
        self.grad.fill(weight * self.scale);
        self.critic.backward_input(&self.grad, b);
        let d = &self.critic.dinput;
        for i in 0..b {
            for j in 0..a {
                dact[i * a + j] += d[i * (o + a) + o + j];
            }
        }
        weight * sum
    }

    /// `Q_c` of the `[s | a]` rows `input`, straight from the network: `lo + scale * output`.
    #[cfg(test)]
    pub(crate) fn q_values(&mut self, input: &[f32]) -> Vec<f32> {
        let b = self.batch_size;
        let out = self.critic.net.forward(crate::nets::rows(input, b, self.obs_dim + self.act_dim));
        (0..b).map(|i| self.lo + self.scale * *out.get(i, 0)).collect()
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

    /// The bounded critic of costs in `[0, 1]` (`Some`), or the first runs' linear one.
    fn critic_with(per_step: Option<(f32, f32)>) -> CostCritic {
        let config = SacConfig { net_arch: vec![16, 16], batch_size: 8, ..SacConfig::default() };
        CostCritic::new(&config, 3, 2, 9, CostRange { per_step, max_grad_norm: None }).unwrap()
    }

    const BOUNDED: Option<(f32, f32)> = Some((0.0, 1.0));

    #[test]
    fn an_undiscounted_bounded_critic_is_refused_naming_gamma() {
        let config = SacConfig { net_arch: vec![16, 16], batch_size: 8, gamma: 1.0, ..SacConfig::default() };
        let range = CostRange { per_step: BOUNDED, max_grad_norm: None };
        let e = CostCritic::new(&config, 3, 2, 9, range).err().unwrap().to_string();
        assert!(e.contains("gamma") && e.contains("bounded"), "{e}");
        let linear = CostRange { per_step: None, max_grad_norm: None };
        assert!(CostCritic::new(&config, 3, 2, 9, linear).is_ok());
    }

    /// `mean (Q_c(s, a) - y)^2` for fixed targets `y` (in the network's units), summed in f64.
    fn loss(c: &mut CostCritic, critic_in: &[f32], y: &[f32]) -> f64 {
        let scale = f64::from(c.scale);
        let q = c.critic.net.forward(rows(critic_in, 8, 5));
        (0..8).map(|i| (scale * f64::from(q.get(i, 0) - y[i])).powi(2)).sum::<f64>() / 8.0
    }

    #[test]
    fn the_target_adds_the_discounted_next_value_unless_terminated() {
        for per_step in [None, BOUNDED] {
            let (batch, critic_in, next_in) = batch();
            let mut c = critic_with(per_step);
            let target = c.critic.target.forward(rows(&next_in, 8, 5));
            let next_p: Vec<f32> = (0..8).map(|i| *target.get(i, 0)).collect();
            c.step(&batch, &critic_in, &next_in).unwrap();
            // Bounded: Q_c' = 100 p' (costs in [0, 1], gamma 0.99), targets in p's units / 100.
            let (lo, scale) = if per_step.is_some() { (0.0, 100.0) } else { (0.0, 1.0) };
            assert!((c.scale - scale).abs() < 1e-3 && c.lo == lo, "{} {}", c.lo, c.scale);
            for (i, (&p, &cost)) in next_p.iter().zip(&batch.costs).enumerate() {
                let raw = if i % 4 == 0 { cost } else { cost + 0.99 * (lo + c.scale * p) };
                let expected = (raw - lo) / c.scale;
                assert!((c.y[i] - expected).abs() < 1e-6, "row {i}: {} against {expected}", c.y[i]);
            }
        }
    }

    #[test]
    fn the_target_clamp_catches_f32_rounding_at_the_ranges_ends() {
        // Validated costs keep the exact target within [lo, hi], but at some accepted gammas the
        // f32 target of a saturated critic lands one ulp outside [0, 1]: 0.5145 with costs in
        // [0, 1] (the top end), 0.6108 with cost_normalize's [-5, 5] (both ends).
        let cases =
            [(0.5145, (0.0, 1.0), 100.0), (0.6108, (-5.0, 5.0), 100.0), (0.6108, (-5.0, 5.0), -200.0)];
        for (gamma, (c_lo, c_hi), logit) in cases {
            let config = SacConfig { net_arch: vec![16, 16], batch_size: 8, gamma, ..SacConfig::default() };
            let range = CostRange { per_step: Some((c_lo, c_hi)), max_grad_norm: None };
            let mut c = CostCritic::new(&config, 3, 2, 9, range).unwrap();
            // The target's sigmoid saturated at exactly 1 (or 0) on every row: its output bias.
            *c.critic.net.params_mut().last_mut().unwrap() = logit;
            c.critic.target.copy_params_from(&c.critic.net);
            let (mut batch, critic_in, next_in) = batch();
            let (cost, end) = if logit > 0.0 { (c_hi, 1.0) } else { (c_lo, 0.0) };
            batch.costs.fill(cost);
            batch.terminated.fill(0.0);
            // The step's arithmetic, unclamped.
            let next = c.lo + c.scale * end;
            let raw = (cost + 1.0 * c.gamma * next - c.lo) / c.scale;
            assert!(!(0.0..=1.0).contains(&raw), "gamma {gamma}: the unclamped target {raw} is in [0, 1]");
            c.step(&batch, &critic_in, &next_in).unwrap();
            assert!(c.y.iter().all(|&y| y == end), "gamma {gamma}: {:?}", c.y);
        }
    }

    #[test]
    fn a_fresh_bounded_critic_starts_near_a_cost_of_zero() {
        let (_, critic_in, _) = batch();
        // Costs in [0, 1]: Q_c in [0, 100], starting about 0.1 (not 50, mid-range).
        let q = critic_with(BOUNDED).q_values(&critic_in);
        assert!(q.iter().all(|&v| v > 0.0 && v < 0.5), "{q:?}");
        // Normalised costs in [-5, 5]: Q_c in [-500, 500], starting about 0.
        let q = critic_with(Some((-5.0, 5.0))).q_values(&critic_in);
        assert!(q.iter().all(|&v| v.abs() < 150.0), "{q:?}");
    }

    #[test]
    fn the_first_runs_linear_critic_is_unchanged() {
        // The linear critic's target is exactly `c + 0.99 Q'` (bit for bit: lagrangian-v1).
        let (batch, critic_in, next_in) = batch();
        let mut c = critic_with(None);
        let target = c.critic.target.forward(rows(&next_in, 8, 5));
        let next_q: Vec<f32> = (0..8).map(|i| *target.get(i, 0)).collect();
        c.step(&batch, &critic_in, &next_in).unwrap();
        for (i, (&q, &cost)) in next_q.iter().zip(&batch.costs).enumerate() {
            let expected = if i % 4 == 0 { cost } else { cost + 0.99 * q };
            assert_eq!(c.y[i], expected, "row {i}");
        }
    }

    #[test]
    fn the_bounded_critic_stays_within_what_a_cost_can_be_while_the_actor_drives_it() {
        // As Lagrangian SAC's actor does: the actions move down Q_c's gradient (kept in [-1, 1]
        // as tanh keeps them), the critic keeps learning from the batch's costs of 0 and 1.
        let (b, o, a) = (8, 3, 2);
        let drive = |per_step| {
            let (batch, critic_in, next_in) = batch();
            let mut c = critic_with(per_step);
            let mut acts = batch.actions.clone();
            let mut pi_in = vec![0.0; b * (o + a)];
            let (mut lowest, mut highest) = (f32::INFINITY, f32::NEG_INFINITY);
            for _ in 0..400 {
                c.step(&batch, &critic_in, &next_in).unwrap();
                concat_rows(&mut pi_in, &batch.obs, &acts, b, o, a);
                let mut dact = vec![0.0; b * a];
                c.actor_term(&pi_in, 1.0, &mut dact);
                for (x, d) in acts.iter_mut().zip(&dact) {
                    *x = (*x - 0.5 * d.signum()).clamp(-1.0, 1.0);
                }
                concat_rows(&mut pi_in, &batch.obs, &acts, b, o, a);
                let q = c.q_values(&pi_in);
                c.actor_term(&pi_in, 0.0, &mut dact);
                assert!((c.last_qc_mean - q.iter().sum::<f32>() / b as f32).abs() < 1e-3, "qc_mean");
                lowest = q.iter().fold(lowest, |m, &v| m.min(v));
                highest = q.iter().fold(highest, |m, &v| m.max(v));
            }
            (lowest, highest)
        };
        let (lowest, highest) = drive(BOUNDED);
        assert!(lowest >= 0.0 && highest <= 100.0, "bounded: Q_c in [{lowest}, {highest}]");
        // The linear critic, driven alike, leaves what a cost can be: the test can fail.
        let (lowest, _) = drive(None);
        assert!(lowest < 0.0, "linear: the lowest Q_c is {lowest}");
    }

    #[test]
    fn the_cost_critic_gradient_matches_finite_differences() {
        // Bounded with a range whose Q_c is about 1 (scale 2): with costs up to 1, Q_c near 50
        // makes the f32 loss too coarse for difference quotients over 2h.
        for per_step in [None, Some((0.0, 0.02))] {
            check_gradient(per_step);
        }
    }

    fn check_gradient(per_step: Option<(f32, f32)>) {
        let (batch, critic_in, next_in) = batch();
        let before = critic_with(per_step);
        let mut stepped = before.clone();
        let reported = stepped.step(&batch, &critic_in, &next_in).unwrap();
        let analytic = stepped.critic.net.grads().to_vec();
        let y = stepped.y.clone();
        let mut c = before;
        let reported = f64::from(reported);
        assert!((loss(&mut c, &critic_in, &y) - reported).abs() < 1e-6 * reported.max(1.0), "{reported}");
        let h = 5e-4f32;
        let (mut checked, mut kinks) = (0, 0);
        for k in (0..c.critic.net.num_params()).step_by(3) {
            let p = c.critic.net.params()[k];
            c.critic.net.params_mut()[k] = p + h;
            let up = loss(&mut c, &critic_in, &y);
            c.critic.net.params_mut()[k] = p - h;
            let down = loss(&mut c, &critic_in, &y);
            c.critic.net.params_mut()[k] = p;
            let numeric = ((up - down) / (2.0 * f64::from(h))) as f32;
            // 1e-4: a few f32 roundings of the network's outputs over 2h.
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
