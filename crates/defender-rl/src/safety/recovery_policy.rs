//! Recovery RL's model-free recovery policy (Thananjeyan et al. 2021, section 4.3): a Gaussian
//! whose mean is a tanh network of the state and whose standard deviation is one learned
//! parameter per action dimension, independent of the state, starting at 0.1 and never below
//! 1e-6, as the authors' code's `StochasticPolicy`. It learns to minimise the safety critic
//! (`mean_i max(Q1, Q2)(s_i, a_i)`, `a_i = mean(s_i) + std eps_i` reparameterised), with no
//! entropy term: it is not a second SAC actor. The executed action is clipped to [-1, 1] (the
//! agent's action box); the loss sees the unclipped sample, as theirs (docs/decisions.md,
//! "Recovery RL").

use std::path::Path;

use defender_nn::{Activation, Adam, AdamConfig, Mlp};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::RlError;
use crate::nets::{ScalarAdam, copy_out, load_net, new_mlp, rows, save_net, widths};

/// The initial standard deviation (the authors' `log(0.1)`).
const INIT_STD: f32 = 0.1;
/// The floor of the standard deviation (their clamp at `log(1e-6)`).
const MIN_STD: f32 = 1e-6;

/// The policy's scalar state, kept in the agent's `state.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct StdState {
    pub(crate) log_std: Vec<f32>,
    opt: Vec<ScalarAdam>,
}

/// The recovery policy with its optimisers and the buffers of one gradient step.
#[derive(Debug, Clone)]
pub(crate) struct RecoveryPolicy {
    /// `obs -> net_arch -> act` with a tanh output: the mean.
    pub(crate) net: Mlp,
    opt: Adam,
    /// The state-independent log standard deviation, one per action dimension, each with its
    /// Adam (element-wise, the arithmetic of one Adam over the authors' parameter vector).
    pub(crate) std: StdState,
    act_dim: usize,
    /// Noise of the last batch sample, `b x a`.
    eps: Vec<f32>,
    /// The last batch sample `mean + std eps` (unclipped), `b x a`.
    pub(crate) act: Vec<f32>,
    /// `dL/dlog_std` of the last [`RecoveryPolicy::backward`].
    pub(crate) log_std_grad: Vec<f32>,
}

impl RecoveryPolicy {
    /// A fresh policy (weights drawn from `init`) for batches of `b` rows.
    pub(crate) fn new(
        obs_dim: usize,
        act_dim: usize,
        net_arch: &[usize],
        adam: AdamConfig,
        b: usize,
        init: &mut ChaCha8Rng,
    ) -> Result<Self, RlError> {
        let net = new_mlp(&widths(obs_dim, net_arch, act_dim), Activation::Tanh, init)?;
        let lr = f64::from(adam.lr);
        Ok(Self {
            opt: Adam::new(&net, adam),
            net,
            std: StdState { log_std: vec![INIT_STD.ln(); act_dim], opt: vec![ScalarAdam::new(lr); act_dim] },
            act_dim,
            eps: vec![0.0; b * act_dim],
            act: vec![0.0; b * act_dim],
            log_std_grad: vec![0.0; act_dim],
        })
    }

    /// The standard deviation of dimension `j` (the log clamped at the floor).
    fn std(&self, j: usize) -> f32 {
        self.std.log_std[j].max(MIN_STD.ln()).exp()
    }

    /// The action for one state: the mean (deterministic) or a sample, clipped to [-1, 1].
    pub(crate) fn act(&mut self, obs: &[f32], deterministic: bool, rng: &mut ChaCha8Rng, out: &mut [f32]) {
        copy_out(self.net.forward(rows(obs, 1, obs.len())), out);
        if deterministic {
            return;
        }
        for (j, x) in out.iter_mut().enumerate() {
            let eps: f32 = rng.sample(StandardNormal);
            *x = (*x + self.std(j) * eps).clamp(-1.0, 1.0);
        }
    }

    /// Samples `a = mean(s) + std eps` for `b` rows of `obs` into [`RecoveryPolicy::act`]; the
    /// forward pass stays for [`RecoveryPolicy::step`].
    pub(crate) fn sample_batch(&mut self, obs: &[f32], b: usize, obs_dim: usize, rng: &mut ChaCha8Rng) {
        let a = self.act_dim;
        copy_out(self.net.forward(rows(obs, b, obs_dim)), &mut self.act);
        for i in 0..b {
            for j in 0..a {
                let eps: f32 = rng.sample(StandardNormal);
                self.eps[i * a + j] = eps;
                self.act[i * a + j] += self.std(j) * eps;
            }
        }
    }

    /// Leaves the gradient of a loss `L` in the network and in `log_std_grad`, given `dL/da` for
    /// the last [`RecoveryPolicy::sample_batch`] (`b x a`): `dL/dmean = dL/da` (the tanh is
    /// inside the network), `dL/dlog_std_j = sum_i dL/da_ij std_j eps_ij`, zero where the floor
    /// cut the log (as `torch.clamp`).
    pub(crate) fn backward(&mut self, dact: &[f32], b: usize) {
        let a = self.act_dim;
        self.net.zero_grad();
        self.net.backward_params(rows(dact, b, a));
        for j in 0..a {
            let log_std = self.std.log_std[j];
            self.log_std_grad[j] = if log_std >= MIN_STD.ln() {
                let std = log_std.exp();
                (0..b).map(|i| dact[i * a + j] * std * self.eps[i * a + j]).sum()
            } else {
                0.0
            };
        }
    }

    /// One Adam step on the gradient [`RecoveryPolicy::backward`] left.
    pub(crate) fn apply(&mut self) {
        self.opt.step(&mut self.net);
        for ((log_std, opt), &g) in self.std.log_std.iter_mut().zip(&mut self.std.opt).zip(&self.log_std_grad)
        {
            opt.step(log_std, g);
        }
    }

    /// The scalar state, for `state.json`.
    pub(crate) fn std_state(&self) -> &StdState {
        &self.std
    }

    /// Restores [`RecoveryPolicy::std_state`]'s value, checking its length.
    pub(crate) fn set_std_state(&mut self, state: StdState, path: &Path) -> Result<(), RlError> {
        if state.log_std.len() != self.act_dim || state.opt.len() != self.act_dim {
            return Err(RlError::checkpoint(path, "the recovery policy's log_std has another length"));
        }
        self.std = state;
        Ok(())
    }

    /// Saves the mean network and its Adam as `recovery_policy` in `dir`.
    pub(crate) fn save(&self, dir: &Path) -> Result<(), RlError> {
        save_net(dir, "recovery_policy", &self.net, Some(&self.opt))
    }

    /// Loads what [`RecoveryPolicy::save`] wrote.
    pub(crate) fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        load_net(dir, "recovery_policy", &mut self.net, Some(&mut self.opt))
    }
}
