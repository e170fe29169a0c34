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
use crate::nets::{copy_out, load_net, new_mlp, rows, save_net, widths};

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
    /// A fresh critic for `input` values per row (PyTorch's initialisation, drawn from `init`);
    /// the target starts as a copy.
    pub(crate) fn new(
        input: usize,
        net_arch: &[usize],
        adam: AdamConfig,
        batch_size: usize,
        init: &mut ChaCha8Rng,
    ) -> Result<Self, RlError> {
        Self::with_output(input, net_arch, adam, batch_size, init, Activation::Identity)
    }

    /// As [`Critic::new`] with `output` on the critic's output.
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
        self.net.zero_grad();
        self.forward(input, b);
        for ((g, &q), &y) in self.grad[..b].iter_mut().zip(&self.q).zip(y) {
            *g = dloss(q - y);
        }
        self.net.backward_params(rows(&self.grad, b, 1));
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
