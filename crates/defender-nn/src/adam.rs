//! Adam with PyTorch's semantics (`torch.optim.Adam`, no weight decay, no amsgrad).

use crate::Mlp;

/// Adam's hyperparameters; defaults are PyTorch's (`lr` 1e-3, betas 0.9/0.999, eps 1e-8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdamConfig {
    /// Learning rate.
    pub lr: f32,
    /// Decay of the first-moment average.
    pub beta1: f32,
    /// Decay of the second-moment average.
    pub beta2: f32,
    /// Added to `sqrt(v_hat)` in the denominator.
    pub eps: f32,
}

impl Default for AdamConfig {
    fn default() -> Self {
        AdamConfig { lr: 1e-3, beta1: 0.9, beta2: 0.999, eps: 1e-8 }
    }
}

/// The Adam optimiser for one [`Mlp`] (Adam is element-wise, so one optimiser per network is
/// the same as one over several networks' parameters).
///
/// One step, as `torch.optim.Adam` (single-tensor path) computes it, with `t` the step count:
/// `m = lerp(m, g, 1 - beta1)`, `v = beta2 v + (1 - beta2) g^2`,
/// `p -= lr / (1 - beta1^t) * m / (sqrt(v) / sqrt(1 - beta2^t) + eps)`; the bias corrections
/// are computed in f64 as Python does.
#[derive(Debug, Clone, PartialEq)]
pub struct Adam {
    pub(crate) config: AdamConfig,
    pub(crate) step: u64,
    pub(crate) exp_avg: Vec<f32>,
    pub(crate) exp_avg_sq: Vec<f32>,
    pub(crate) widths: Vec<usize>,
}

impl Adam {
    /// A fresh optimiser (zero moments, step 0) for `mlp`'s parameters.
    pub fn new(mlp: &Mlp, config: AdamConfig) -> Self {
        let n = mlp.num_params();
        Adam {
            config,
            step: 0,
            exp_avg: vec![0.0; n],
            exp_avg_sq: vec![0.0; n],
            widths: mlp.widths().to_vec(),
        }
    }

    /// The hyperparameters.
    pub fn config(&self) -> AdamConfig {
        self.config
    }

    /// The learning rate.
    pub fn lr(&self) -> f32 {
        self.config.lr
    }

    /// Sets the learning rate (takes effect at the next step; schedules call this).
    pub fn set_lr(&mut self, lr: f32) {
        self.config.lr = lr;
    }

    /// Number of steps taken (PyTorch's `state["step"]`).
    pub fn step_count(&self) -> u64 {
        self.step
    }

    /// First moments, laid out like [`Mlp::params`].
    pub fn exp_avg(&self) -> &[f32] {
        &self.exp_avg
    }

    /// Second moments, laid out like [`Mlp::params`].
    pub fn exp_avg_sq(&self) -> &[f32] {
        &self.exp_avg_sq
    }

    /// The widths of the network this optimiser was made for.
    pub fn widths(&self) -> &[usize] {
        &self.widths
    }

    /// One Adam step on `mlp`'s parameters from its accumulated gradients. Does not clear the
    /// gradients (call [`Mlp::zero_grad`], as in PyTorch).
    ///
    /// # Panics
    ///
    /// If `mlp` does not have the widths this optimiser was made for.
    #[track_caller]
    pub fn step(&mut self, mlp: &mut Mlp) {
        assert!(
            mlp.widths() == self.widths.as_slice(),
            "Adam::step: optimiser made for widths {:?}, network has {:?}",
            self.widths,
            mlp.widths()
        );
        self.step += 1;
        let AdamConfig { lr, beta1, beta2, eps } = self.config;
        let t = self.step as f64;
        let bias_correction1 = 1.0 - (beta1 as f64).powf(t);
        let bias_correction2 = 1.0 - (beta2 as f64).powf(t);
        let step_size = (lr as f64 / bias_correction1) as f32;
        let bias_correction2_sqrt = bias_correction2.sqrt() as f32;
        let w1 = (1.0 - beta1 as f64) as f32;
        let w2 = (1.0 - beta2 as f64) as f32;
        let (params, grads) = mlp.params_and_grads_mut();
        for (((p, g), m), v) in
            params.iter_mut().zip(grads).zip(self.exp_avg.iter_mut()).zip(self.exp_avg_sq.iter_mut())
        {
            *m += w1 * (*g - *m);
            *v = *v * beta2 + w2 * *g * *g;
            let denom = v.sqrt() / bias_correction2_sqrt + eps;
            *p -= step_size * (*m / denom);
        }
    }
}
