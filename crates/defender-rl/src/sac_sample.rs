//! The task policy's sampled actions for a batch of states, drawn from a caller's generator:
//! Recovery RL's safety critic bootstraps from `Q_risk(s', a')` with `a' ~ pi_task(.|s')`, as its
//! authors' code passes the task agent's policy to the safety critic's update
//! (docs/decisions-baselines.md, "Recovery RL"). The agent's own generator is not touched, so its stream
//! (exploration, batches) is the one it would draw alone.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::{LOG_STD_MAX, LOG_STD_MIN, Sac};
use crate::nets::{copy_out, rows};

impl Sac {
    /// `out <- tanh(mean + std eps)` for `b` rows of `obs` (`b x obs_dim`), the noise from `rng`
    /// (SB3's `actor.action_log_prob` without the log-probability); `scratch` holds the actor's
    /// `[mean | log_std]` rows (`b x 2 act_dim`).
    pub(crate) fn sample_actions(
        &mut self,
        obs: &[f32],
        b: usize,
        rng: &mut ChaCha8Rng,
        scratch: &mut [f32],
        out: &mut [f32],
    ) {
        let (o, a) = (self.obs_dim, self.act_dim);
        copy_out(self.actor.forward(rows(obs, b, o)), scratch);
        for i in 0..b {
            for j in 0..a {
                let mean = scratch[i * 2 * a + j];
                let std = scratch[i * 2 * a + a + j].clamp(LOG_STD_MIN, LOG_STD_MAX).exp();
                let eps: f32 = rng.sample(StandardNormal);
                out[i * a + j] = (mean + std * eps).tanh();
            }
        }
    }
}
