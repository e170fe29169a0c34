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
        // PyTorch's hyperparameters are Python floats: compute with the f64 the user's decimal
        // denotes (0.9, not 0.9f32 = 0.89999998) and round to f32 where torch does.
        let (lr64, beta1_64, beta2_64) = (decimal_f64(lr), decimal_f64(beta1), decimal_f64(beta2));
        let t = self.step as f64;
        let bias_correction1 = 1.0 - beta1_64.powf(t);
        let bias_correction2 = 1.0 - beta2_64.powf(t);
        let step_size = (lr64 / bias_correction1) as f32;
        let bias_correction2_sqrt = bias_correction2.sqrt() as f32;
        let w1 = (1.0 - beta1_64) as f32;
        let w2 = (1.0 - beta2_64) as f32;
        let (params, grads) = mlp.params_and_grads_mut();
        let (exp_avg, exp_avg_sq) = (&mut self.exp_avg, &mut self.exp_avg_sq);
        crate::simd::vectorized(
            #[inline(always)]
            || {
                for (((p, g), m), v) in
                    params.iter_mut().zip(grads).zip(exp_avg.iter_mut()).zip(exp_avg_sq.iter_mut())
                {
                    *m += w1 * (*g - *m);
                    *v = *v * beta2 + w2 * *g * *g;
                    let denom = v.sqrt() / bias_correction2_sqrt + eps;
                    *p -= step_size * (*m / denom);
                }
            },
        );
    }
}

/// The f64 nearest to the shortest decimal that round-trips `x` (what a user who wrote the
/// f32 literal meant, and what Python holds): `decimal_f64(0.9) == 0.9f64`. No allocation.
fn decimal_f64(x: f32) -> f64 {
    use std::fmt::Write;
    struct Buf {
        bytes: [u8; 48],
        len: usize,
    }
    impl Write for Buf {
        fn write_str(&mut self, s: &str) -> std::fmt::Result {
            let end = self.len + s.len();
            self.bytes.get_mut(self.len..end).ok_or(std::fmt::Error)?.copy_from_slice(s.as_bytes());
            self.len = end;
            Ok(())
        }
    }
    let mut buf = Buf { bytes: [0; 48], len: 0 };
    // `{:e}` is the shortest round-trip form and at most ~16 bytes for any f32.
    if write!(buf, "{x:e}").is_err() {
        return x as f64;
    }
    std::str::from_utf8(&buf.bytes[..buf.len]).ok().and_then(|s| s.parse().ok()).unwrap_or(x as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Activation;

    /// The vectorised loop (AVX-512 or AVX2 where available) against the same arithmetic one
    /// scalar at a time: bit-identical, including gradients of mixed magnitude and zeros.
    #[test]
    fn decimal_f64_recovers_the_literal() {
        assert_eq!(decimal_f64(0.9), 0.9f64);
        assert_eq!(decimal_f64(0.999), 0.999f64);
        assert_eq!(decimal_f64(3e-4), 3e-4f64);
        assert_eq!(decimal_f64(1e-8), 1e-8f64);
        assert_eq!(decimal_f64(f32::MAX) as f32, f32::MAX);
        assert_eq!(decimal_f64(-f32::MIN_POSITIVE) as f32, -f32::MIN_POSITIVE);
    }

    #[test]
    fn vectorised_step_is_bit_identical_to_scalar_arithmetic() {
        let mut mlp = Mlp::zeros(&[37, 29, 3], Activation::Relu, Activation::Identity).unwrap();
        let n = mlp.num_params();
        for (k, p) in mlp.params_mut().iter_mut().enumerate() {
            *p = ((k * 7919) % 1000) as f32 / 500.0 - 1.0;
        }
        let cfg = AdamConfig { lr: 3e-4, ..Default::default() };
        let mut opt = Adam::new(&mlp, cfg);
        let (mut p, mut m, mut v) = (mlp.params().to_vec(), vec![0.0f32; n], vec![0.0f32; n]);
        for t in 1..=4u64 {
            for (k, g) in mlp.grads_mut().iter_mut().enumerate() {
                let x = ((k as u64 * 31 + t * 17) % 101) as f32 - 50.0;
                *g = if k % 11 == 0 { 0.0 } else { x * 10f32.powi((k % 9) as i32 - 6) };
            }
            opt.step(&mut mlp);
            let bc1 = 1.0 - 0.9f64.powf(t as f64);
            let bc2_sqrt = (1.0 - 0.999f64.powf(t as f64)).sqrt() as f32;
            let step_size = (3e-4f64 / bc1) as f32;
            let (w1, w2) = ((1.0 - 0.9f64) as f32, (1.0 - 0.999f64) as f32);
            for k in 0..n {
                let g = mlp.grads()[k];
                m[k] += w1 * (g - m[k]);
                v[k] = v[k] * 0.999 + w2 * g * g;
                p[k] -= step_size * (m[k] / (v[k].sqrt() / bc2_sqrt + 1e-8));
            }
            assert!(mlp.params().iter().zip(&p).all(|(a, b)| a.to_bits() == b.to_bits()), "step {t}");
            assert!(opt.exp_avg_sq().iter().zip(&v).all(|(a, b)| a.to_bits() == b.to_bits()), "step {t}");
        }
    }
}
