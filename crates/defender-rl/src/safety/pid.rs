//! PID Lagrangian SAC's multiplier (Stooke, Achiam and Abbeel, "Responsive Safety in
//! Reinforcement Learning by PID Lagrangian Methods", ICML 2020), as OmniSafe 0.5's
//! `PIDLagrangian.pid_update` computes it, in f64 as its Python floats:
//!
//! ```text
//! delta   = J_c - d
//! I       = max(0, I + K_i delta)                    (clamped to [0, 1] with diff_norm)
//! P       = a_p P + (1 - a_p) delta                   (an EMA of the error)
//! D_cost  = a_d D_cost + (1 - a_d) J_c                (an EMA of the cost)
//! deriv   = max(0, D_cost - D_cost d_delay updates ago (0 before))
//! lambda  = max(0, K_p P + I + K_d deriv)             (<= 1 with diff_norm; <= penalty_max
//!                                                      unless sum_norm or diff_norm)
//! ```
//!
//! One update per environment step once learning has started, `J_c` the mean cost of the last
//! `window` training episodes (OmniSafe's `_update` runs every step after its warm-up epochs and
//! reads its logger's mean episode cost). The actor's loss is then Lagrangian SAC's, with this
//! `lambda` (OmniSafe's `SACPID._loss_pi`).

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use super::PidConfig;
use super::episode_costs::EpisodeCosts;

/// The controller's state and the episode costs it reads. All of it is kept by checkpoints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PidMultiplier {
    config: PidConfig,
    /// The integral term `I` (OmniSafe's `_pid_i`).
    pid_i: f64,
    /// `D_cost` of the last `d_delay` updates, oldest first (starts as `[0]`).
    cost_ds: VecDeque<f64>,
    /// `P` (OmniSafe's `_delta_p`).
    delta_p: f64,
    /// `D_cost` (OmniSafe's `_cost_d`).
    cost_d: f64,
    /// `lambda` (OmniSafe's `_cost_penalty`; 0 before the first update, as theirs).
    penalty: f64,
    episodes: EpisodeCosts,
    updates: u64,
}

impl PidMultiplier {
    /// `I = lambda_init`, `lambda = 0` until the first update (OmniSafe's initial state).
    pub fn new(config: &PidConfig) -> Self {
        Self {
            pid_i: config.lambda_init,
            cost_ds: VecDeque::from([0.0]),
            delta_p: 0.0,
            cost_d: 0.0,
            penalty: 0.0,
            episodes: EpisodeCosts::new(config.window),
            updates: 0,
            config: config.clone(),
        }
    }

    /// `lambda`, as the actor's loss reads it.
    pub fn lambda(&self) -> f32 {
        self.penalty as f32
    }

    /// `J_c` (`None` before the first finished episode).
    pub fn mean_episode_cost(&self) -> Option<f64> {
        self.episodes.mean()
    }

    /// Updates taken so far.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// Counts one training step's `cost`; once `learning` and an episode has finished, one
    /// update with `J_c`.
    pub fn observe(&mut self, cost: f64, episode_end: bool, learning: bool) {
        self.episodes.observe(cost, episode_end);
        if learning && let Some(j_c) = self.episodes.mean() {
            self.update(j_c);
        }
    }

    /// OmniSafe's `pid_update(ep_cost_avg)`.
    pub fn update(&mut self, j_c: f64) {
        let c = &self.config;
        let delta = j_c - c.cost_limit;
        self.pid_i = (self.pid_i + delta * c.ki).max(0.0);
        if c.diff_norm {
            self.pid_i = self.pid_i.clamp(0.0, 1.0);
        }
        self.delta_p = self.delta_p * c.delta_p_ema_alpha + (1.0 - c.delta_p_ema_alpha) * delta;
        self.cost_d = self.cost_d * c.delta_d_ema_alpha + (1.0 - c.delta_d_ema_alpha) * j_c;
        let pid_d = (self.cost_d - self.cost_ds[0]).max(0.0);
        let pid_o = c.kp * self.delta_p + self.pid_i + c.kd * pid_d;
        self.penalty = pid_o.max(0.0);
        if c.diff_norm {
            self.penalty = self.penalty.min(1.0);
        }
        if !(c.diff_norm || c.sum_norm) {
            self.penalty = self.penalty.min(c.penalty_max);
        }
        if self.cost_ds.len() == c.d_delay {
            self.cost_ds.pop_front();
        }
        self.cost_ds.push_back(self.cost_d);
        self.updates += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> PidConfig {
        PidConfig {
            cost_limit: 1.0,
            lambda_init: 0.25,
            kp: 0.5,
            ki: 0.1,
            kd: 0.2,
            d_delay: 2,
            delta_p_ema_alpha: 0.5,
            delta_d_ema_alpha: 0.5,
            sum_norm: false,
            diff_norm: false,
            penalty_max: 10.0,
            ..PidConfig::default()
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn four_updates_match_the_hand_computation() {
        let mut pid = PidMultiplier::new(&config());
        assert_eq!(pid.lambda(), 0.0);
        // J_c = 3: delta 2; I = 0.25 + 0.2 = 0.45; P = 0.5 * 2 = 1; D_cost = 1.5, 0 before: deriv
        // 1.5; lambda = 0.5 + 0.45 + 0.3.
        pid.update(3.0);
        assert!(close(pid.penalty, 1.25), "{}", pid.penalty);
        // J_c = 1: delta 0; I 0.45; P 0.5; D_cost 1.25, still 0 two updates back: deriv 1.25.
        pid.update(1.0);
        assert!(close(pid.penalty, 0.25 + 0.45 + 0.25), "{}", pid.penalty);
        // J_c = 0: delta -1; I 0.35; P -0.25; D_cost 0.625 against 1.5: deriv 0.
        pid.update(0.0);
        assert!(close(pid.penalty, -0.125 + 0.35), "{}", pid.penalty);
        // J_c = 0: I 0.25; P -0.625; D_cost 0.3125 against 1.25; the sum -0.0625 clamps to 0.
        pid.update(0.0);
        assert_eq!(pid.penalty, 0.0);
        assert!(close(pid.pid_i, 0.25) && close(pid.delta_p, -0.625) && close(pid.cost_d, 0.3125));
        assert_eq!(pid.cost_ds, VecDeque::from([0.625, 0.3125]));
        assert_eq!(pid.updates(), 4);
    }

    #[test]
    fn the_integral_never_goes_below_zero() {
        let mut pid = PidMultiplier::new(&config());
        for _ in 0..10 {
            pid.update(0.0);
        }
        assert_eq!((pid.pid_i, pid.penalty), (0.0, 0.0));
    }

    #[test]
    fn penalty_max_caps_unless_a_norm_is_set_and_diff_norm_caps_at_one() {
        let big = |sum_norm, diff_norm| {
            let mut pid = PidMultiplier::new(&PidConfig { sum_norm, diff_norm, ..config() });
            pid.update(1001.0);
            pid.penalty
        };
        // I = 0.25 + 100 = 100.25, P = 500, deriv = 500.5: 700.35 uncapped.
        assert_eq!(big(false, false), 10.0);
        assert!(close(big(true, false), 0.5 * 500.0 + 100.25 + 0.2 * 500.5));
        assert_eq!(big(false, true), 1.0);
    }

    #[test]
    fn it_updates_every_learning_step_once_an_episode_has_ended() {
        let mut pid = PidMultiplier::new(&config());
        pid.observe(2.0, false, true);
        assert_eq!(pid.updates(), 0, "no J_c before the first episode ends");
        pid.observe(1.0, true, false);
        assert_eq!((pid.updates(), pid.mean_episode_cost()), (0, Some(3.0)), "no update in the warm-up");
        pid.observe(0.0, false, true);
        pid.observe(0.0, false, true);
        assert_eq!(pid.updates(), 2);
        let back: PidMultiplier = serde_json::from_str(&serde_json::to_string(&pid).unwrap()).unwrap();
        assert_eq!(back, pid, "the controller survives a checkpoint");
    }
}
