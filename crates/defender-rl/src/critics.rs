//! The twin Q critics SAC and TD3 share (Fujimoto et al. 2018): two networks `[s | a] -> Q`,
//! each with its Polyak target and its Adam.
//!
//! The two critics never read each other's numbers within a pass, so with two or more network
//! threads [`TwinCritics::each`] runs them side by side on rayon's pool, each critic's matrix
//! products on one thread, instead of splitting every 256-wide product of each critic over the
//! threads in turn: half the synchronisations, and the element-wise passes (bias, activation,
//! Adam) run in parallel too. (SBX and CleanRL-JAX reach the same by vectorising the pair with
//! `vmap`.) Each critic computes exactly what it computes alone, so results are bit-identical for
//! every thread count.

use std::path::Path;

use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism};
use rand_chacha::ChaCha8Rng;

use crate::error::RlError;
use crate::nets::{
    clip_coef, copy_out, grad_sq_norm, load_net, new_mlp, rows, save_net, scale_grads, widths,
};

/// One critic: the online network, its target, its optimiser, and its buffers.
#[derive(Debug, Clone)]
pub(crate) struct Critic {
    pub(crate) net: Mlp,
    pub(crate) target: Mlp,
    opt: Adam,
    /// The outputs of the last forward pass (online or target), one per row.
    pub(crate) q: Vec<f32>,
    /// `dL/dQ` of the last training step, one per row.
    grad: Vec<f32>,
    /// `dQ/d[s | a]` of the last [`Critic::backward_input`], rows of `obs_dim + act_dim`.
    pub(crate) dinput: Vec<f32>,
}

impl Critic {
    /// A fresh critic for `input` values per row with `output` on its output (PyTorch's
    /// initialisation, drawn from `init`); the target starts as a copy.
    pub(crate) fn with_output(
        input: usize,
        net_arch: &[usize],
        adam: AdamConfig,
        batch_size: usize,
        init: &mut ChaCha8Rng,
        output: Activation,
    ) -> Result<Self, RlError> {
        let net = new_mlp(&widths(input, net_arch, 1), output, init)?;
        Ok(Self {
            target: net.clone(),
            opt: Adam::new(&net, adam),
            net,
            q: vec![0.0; batch_size],
            grad: vec![0.0; batch_size],
            dinput: vec![0.0; batch_size * input],
        })
    }

    fn width(&self) -> usize {
        self.net.in_dim()
    }

    /// `q <- Q_target(input)` for `b` rows of `[s | a]`.
    pub(crate) fn forward_target(&mut self, input: &[f32], b: usize) {
        let w = self.width();
        copy_out(self.target.forward(rows(input, b, w)), &mut self.q);
    }

    /// `q <- Q(input)`; the forward pass stays for a following [`Critic::backward_input`].
    pub(crate) fn forward(&mut self, input: &[f32], b: usize) {
        let w = self.width();
        copy_out(self.net.forward(rows(input, b, w)), &mut self.q);
    }

    /// One Adam step on the regression of `Q(input)` onto `y`, where `dloss(Q - y)` is the
    /// loss's derivative with respect to each output. Leaves `Q(input)` before the step in `q`.
    pub(crate) fn train_step(
        &mut self,
        input: &[f32],
        y: &[f32],
        b: usize,
        dloss: &(dyn Fn(f32) -> f32 + Sync),
    ) {
        self.backward_step(input, y, b, dloss);
        self.apply_step();
    }

    /// [`Critic::train_step`] up to the gradient: the parameters are not yet stepped.
    pub(crate) fn backward_step(
        &mut self,
        input: &[f32],
        y: &[f32],
        b: usize,
        dloss: &(dyn Fn(f32) -> f32 + Sync),
    ) {
        self.net.zero_grad();
        self.forward(input, b);
        for ((g, &q), &y) in self.grad[..b].iter_mut().zip(&self.q).zip(y) {
            *g = dloss(q - y);
        }
        self.net.backward_params(rows(&self.grad, b, 1));
    }

    /// The Adam step on the gradient [`Critic::backward_step`] left.
    pub(crate) fn apply_step(&mut self) {
        self.opt.step(&mut self.net);
    }

    /// `dinput <- grad^T dQ/d[s | a]` through the last forward pass (parameters untouched).
    pub(crate) fn backward_input(&mut self, grad: &[f32], b: usize) {
        copy_out(self.net.backward_input(rows(grad, b, 1)), &mut self.dinput);
    }

    /// `Q_target <- tau Q + (1 - tau) Q_target`.
    pub(crate) fn polyak(&mut self, tau: f32) {
        self.target.polyak_update(&self.net, tau);
    }

    /// Saves the critic as `NAME` (with its optimiser) and `NAME_target`.
    pub(crate) fn save(&self, dir: &Path, name: &str) -> Result<(), RlError> {
        save_net(dir, name, &self.net, Some(&self.opt))?;
        save_net(dir, &format!("{name}_target"), &self.target, None)
    }

    /// Loads what [`Critic::save`] wrote.
    pub(crate) fn load(&mut self, dir: &Path, name: &str) -> Result<(), RlError> {
        load_net(dir, name, &mut self.net, Some(&mut self.opt))?;
        load_net(dir, &format!("{name}_target"), &mut self.target, None)
    }
}

/// Two critics, run side by side when there are threads for it.
#[derive(Debug, Clone)]
pub(crate) struct TwinCritics {
    critics: [Critic; 2],
    /// The agent's setting, for a critic used alone ([`TwinCritics::alone`]).
    parallelism: Parallelism,
    /// Each critic's setting when both run: side by side, half the threads each.
    each: Parallelism,
}

impl TwinCritics {
    /// Two fresh critics for `obs_dim + act_dim` inputs (PyTorch's initialisation, drawn from
    /// `init` in order: first critic, second critic); the targets start as copies.
    pub(crate) fn new(
        obs_dim: usize,
        act_dim: usize,
        net_arch: &[usize],
        adam: AdamConfig,
        batch_size: usize,
        init: &mut ChaCha8Rng,
    ) -> Result<Self, RlError> {
        Self::with_output(obs_dim, act_dim, net_arch, adam, batch_size, init, Activation::Identity)
    }

    /// As [`TwinCritics::new`] with `output` on each critic's output (a sigmoid for a
    /// probability: Recovery RL's safety critic).
    pub(crate) fn with_output(
        obs_dim: usize,
        act_dim: usize,
        net_arch: &[usize],
        adam: AdamConfig,
        batch_size: usize,
        init: &mut ChaCha8Rng,
        output: Activation,
    ) -> Result<Self, RlError> {
        let first = Critic::with_output(obs_dim + act_dim, net_arch, adam, batch_size, init, output)?;
        let second = Critic::with_output(obs_dim + act_dim, net_arch, adam, batch_size, init, output)?;
        let sequential = Parallelism::Sequential;
        let mut twins = Self { critics: [first, second], parallelism: sequential, each: sequential };
        twins.set_parallelism(Parallelism::default());
        Ok(twins)
    }

    /// With `n >= 2` threads the critics run side by side, each on `n / 2` threads; with one,
    /// one after the other.
    pub(crate) fn set_parallelism(&mut self, parallelism: Parallelism) {
        let n = parallelism.num_threads();
        self.parallelism = parallelism;
        self.each = if n >= 2 { Parallelism::threads(n / 2) } else { parallelism };
    }

    /// Runs `f(k, critic k)` for both critics: side by side on rayon's pool with threads,
    /// else first then second.
    pub(crate) fn each(&mut self, f: impl Fn(usize, &mut Critic) + Sync) {
        for c in &mut self.critics {
            c.net.set_parallelism(self.each);
            c.target.set_parallelism(self.each);
        }
        let [first, second] = &mut self.critics;
        if self.parallelism.num_threads() >= 2 {
            rayon::join(|| f(0, first), || f(1, second));
        } else {
            f(0, first);
            f(1, second);
        }
    }

    /// Both critics' [`Critic::train_step`], their joint gradient scaled to `max_grad_norm` when
    /// longer (torch's `clip_grad_norm_` over OmniSafe's `reward_critic`, which holds both).
    /// Without `max_grad_norm` exactly `each(train_step)`.
    pub(crate) fn train_step(
        &mut self,
        input: &[f32],
        y: &[f32],
        b: usize,
        dloss: &(dyn Fn(f32) -> f32 + Sync),
        max_grad_norm: Option<f32>,
    ) {
        let Some(max) = max_grad_norm else {
            self.each(|_, c| c.train_step(input, y, b, dloss));
            return;
        };
        self.each(|_, c| c.backward_step(input, y, b, dloss));
        let norm = (grad_sq_norm(&self.critics[0].net) + grad_sq_norm(&self.critics[1].net)).sqrt() as f32;
        let k = clip_coef(norm, max);
        self.each(|_, c| {
            if k < 1.0 {
                scale_grads(&mut c.net, k);
            }
            c.apply_step();
        });
    }

    /// Critic `k` alone (TD3's actor loss reads the first only), with all the agent's threads.
    pub(crate) fn alone(&mut self, k: usize) -> &mut Critic {
        let c = &mut self.critics[k];
        c.net.set_parallelism(self.parallelism);
        c.target.set_parallelism(self.parallelism);
        c
    }

    /// `Q_target <- tau Q + (1 - tau) Q_target` for both, on this thread (a few microseconds:
    /// less than handing half of it to another thread).
    pub(crate) fn polyak(&mut self, tau: f32) {
        for c in &mut self.critics {
            c.polyak(tau);
        }
    }

    /// Saves the critics as `q1`, `q2` (with their optimisers), `q1_target`, `q2_target`.
    pub(crate) fn save(&self, dir: &Path) -> Result<(), RlError> {
        for (k, c) in self.critics.iter().enumerate() {
            c.save(dir, &format!("q{}", k + 1))?;
        }
        Ok(())
    }

    /// Loads what [`TwinCritics::save`] wrote.
    pub(crate) fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        for (k, c) in self.critics.iter_mut().enumerate() {
            c.load(dir, &format!("q{}", k + 1))?;
        }
        Ok(())
    }
}

impl std::ops::Index<usize> for TwinCritics {
    type Output = Critic;
    fn index(&self, k: usize) -> &Critic {
        &self.critics[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nets::grad_sq_norm;
    use rand::SeedableRng;

    fn twins() -> TwinCritics {
        let mut init = ChaCha8Rng::seed_from_u64(3);
        TwinCritics::new(2, 1, &[8], AdamConfig::default(), 4, &mut init).unwrap()
    }

    #[test]
    fn clipping_scales_both_critics_gradients_by_one_factor_to_the_joint_norm() {
        let input = [0.5, -1.0, 0.2, 1.0, 0.3, -0.4, -0.2, 0.8, 0.1, 0.9, -0.9, 0.0];
        let y = [10.0, -8.0, 5.0, 7.0];
        let dloss = |diff: f32| diff / 4.0;
        let mut plain = twins();
        plain.train_step(&input, &y, 4, &dloss, None);
        let g: Vec<Vec<f32>> = (0..2).map(|k| plain[k].net.grads().to_vec()).collect();
        let norm = (grad_sq_norm(&plain[0].net) + grad_sq_norm(&plain[1].net)).sqrt();
        assert!(norm > 1.0, "{norm}");
        let mut clipped = twins();
        clipped.train_step(&input, &y, 4, &dloss, Some(0.5));
        let after = (grad_sq_norm(&clipped[0].net) + grad_sq_norm(&clipped[1].net)).sqrt();
        assert!((after - 0.5).abs() < 1e-4, "joint norm {after}");
        // One factor for both (torch's clip_grad_norm_ over the module holding both).
        let k = 0.5 / (norm as f32 + 1e-6);
        for c in 0..2 {
            for (a, b) in clipped[c].net.grads().iter().zip(&g[c]) {
                assert!((a - k * b).abs() <= 1e-6 * b.abs().max(1.0), "critic {c}: {a} against {}", k * b);
            }
        }
        // A bound above the norm changes nothing, bit for bit.
        let mut loose = twins();
        loose.train_step(&input, &y, 4, &dloss, Some(1e6));
        assert_eq!(loose[0].net.params(), plain[0].net.params());
        assert_eq!(loose[1].net.params(), plain[1].net.params());
    }
}
