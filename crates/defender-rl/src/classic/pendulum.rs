//! Gymnasium's `Pendulum-v1`, with its exact dynamics, reward and 200-step horizon.
//!
//! Source: `gymnasium/envs/classic_control/pendulum.py` (Gymnasium 1.4.0). The observation is
//! `[cos(theta), sin(theta), theta_dot]`, the action a torque in `[-2, 2]`, and the reward
//! `-(normalize(theta)^2 + 0.1 theta_dot^2 + 0.001 u^2)`; the task never terminates, only
//! truncates at 200 steps. A random policy scores about -1200 per episode, a good one about -150.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::env::{Env, Step, StepInfo};
use crate::error::{EnvError, Result};
use crate::space::BoxSpace;

const MAX_SPEED: f64 = 8.0;
const MAX_TORQUE: f64 = 2.0;
const DT: f64 = 0.05;
const G: f64 = 10.0;
const M: f64 = 1.0;
const L: f64 = 1.0;
/// Gymnasium registers `Pendulum-v1` with `max_episode_steps=200`.
const HORIZON: usize = 200;

/// `Pendulum-v1`: swing a pendulum up and keep it upright. Includes its 200-step time limit.
#[derive(Debug, Clone)]
pub struct Pendulum {
    observation_space: BoxSpace,
    action_space: BoxSpace,
    rng: ChaCha8Rng,
    theta: f64,
    theta_dot: f64,
    elapsed: usize,
    needs_reset: bool,
}

impl Default for Pendulum {
    fn default() -> Self {
        Self::new()
    }
}

impl Pendulum {
    /// A pendulum that needs a `reset` before its first step.
    pub fn new() -> Self {
        Self {
            observation_space: BoxSpace::new(vec![-1.0, -1.0, -MAX_SPEED], vec![1.0, 1.0, MAX_SPEED])
                .unwrap_or_else(|_| BoxSpace::unbounded(3)),
            action_space: BoxSpace::new(vec![-MAX_TORQUE], vec![MAX_TORQUE])
                .unwrap_or_else(|_| BoxSpace::unbounded(1)),
            rng: ChaCha8Rng::seed_from_u64(0),
            theta: 0.0,
            theta_dot: 0.0,
            elapsed: 0,
            needs_reset: true,
        }
    }

    /// The state `(theta, theta_dot)`.
    pub fn state(&self) -> (f64, f64) {
        (self.theta, self.theta_dot)
    }

    /// Sets the state (for tests against Gymnasium's numbers).
    pub fn set_state(&mut self, theta: f64, theta_dot: f64) {
        self.theta = theta;
        self.theta_dot = theta_dot;
        self.needs_reset = false;
    }

    fn obs(&self) -> Vec<f64> {
        vec![self.theta.cos(), self.theta.sin(), self.theta_dot]
    }
}

/// Python's `((x + pi) % (2 pi)) - pi` (floored modulo).
fn angle_normalize(x: f64) -> f64 {
    (x + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
}

impl Env for Pendulum {
    fn id(&self) -> &str {
        "Pendulum-v1"
    }

    fn observation_space(&self) -> &BoxSpace {
        &self.observation_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.action_space
    }

    fn max_episode_steps(&self) -> Option<usize> {
        Some(HORIZON)
    }

    fn reset(&mut self, seed: Option<u64>) -> Result<Vec<f64>> {
        if let Some(seed) = seed {
            self.rng = ChaCha8Rng::seed_from_u64(seed);
        }
        // Gymnasium: uniform in [-pi, pi] x [-1, 1].
        self.theta = self.rng.random_range(-std::f64::consts::PI..=std::f64::consts::PI);
        self.theta_dot = self.rng.random_range(-1.0..=1.0);
        self.elapsed = 0;
        self.needs_reset = false;
        Ok(self.obs())
    }

    fn step(&mut self, action: &[f64]) -> Result<Step> {
        if self.needs_reset {
            return Err(EnvError::NeedsReset);
        }
        self.action_space.check("action", action)?;
        let u = action[0].clamp(-MAX_TORQUE, MAX_TORQUE);
        let (th, thdot) = (self.theta, self.theta_dot);
        let cost = angle_normalize(th).powi(2) + 0.1 * thdot * thdot + 0.001 * u * u;
        let new_thdot = (thdot + (3.0 * G / (2.0 * L) * th.sin() + 3.0 / (M * L * L) * u) * DT)
            .clamp(-MAX_SPEED, MAX_SPEED);
        // Semi-implicit Euler: the angle moves with the new velocity.
        self.theta = th + new_thdot * DT;
        self.theta_dot = new_thdot;
        self.elapsed += 1;
        let truncated = self.elapsed >= HORIZON;
        self.needs_reset = truncated;
        Ok(Step {
            obs: self.obs(),
            reward: -cost,
            cost: 0.0,
            terminated: false,
            truncated,
            info: StepInfo::default(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_match_gymnasium() {
        // Gymnasium 1.4.0 (observations are float32 there, hence the tolerance):
        //   env = gym.make("Pendulum-v1").unwrapped; env.reset(seed=0)
        //   env.state = np.array([3.0, -0.5]); env.step(np.array([1.5], np.float32))
        //   env.state = np.array([-7.0, 7.9]); env.step(np.array([-2.5], np.float32))
        let cases = [
            (
                (3.0, -0.5, 1.5),
                [-0.9887635111808777, 0.14948821067810059, -0.16915999352931976],
                -9.027250000135973,
            ),
            (
                (-7.0, 7.9, -2.5),
                [0.9353844523429871, -0.35363247990608215, 7.107260227203369],
                -6.758823304033214,
            ),
        ];
        for ((th, thdot, u), obs, reward) in cases {
            let mut env = Pendulum::new();
            env.set_state(th, thdot);
            let s = env.step(&[u]).unwrap();
            for (a, b) in s.obs.iter().zip(obs) {
                assert!((a - b).abs() < 1e-6, "{:?} vs {obs:?}", s.obs);
            }
            assert!((s.reward - reward).abs() < 1e-9, "{} vs {reward}", s.reward);
        }
    }

    #[test]
    fn angle_is_normalised_like_python_modulo() {
        assert!((angle_normalize(4.0) - (4.0 - 2.0 * std::f64::consts::PI)).abs() < 1e-12);
        assert!((angle_normalize(-4.0) - (-4.0 + 2.0 * std::f64::consts::PI)).abs() < 1e-12);
        assert!((angle_normalize(1.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn torque_and_speed_are_clipped_and_the_horizon_truncates() {
        let mut env = Pendulum::new();
        env.reset(Some(3)).unwrap();
        let mut steps = 0;
        loop {
            let s = env.step(&[2.0]).unwrap();
            steps += 1;
            assert!(s.obs[2].abs() <= MAX_SPEED);
            assert!(!s.terminated);
            if s.truncated {
                break;
            }
        }
        assert_eq!(steps, 200);
        assert!(matches!(env.step(&[0.0]), Err(EnvError::NeedsReset)));
        // Out-of-range torque is clipped (Gymnasium clips), not refused.
        env.set_state(0.0, 0.0);
        let a = env.clone().step(&[5.0]).unwrap();
        let b = env.step(&[2.0]).unwrap();
        assert_eq!(a.obs, b.obs);
    }

    #[test]
    fn reset_with_a_seed_is_reproducible() {
        let mut a = Pendulum::new();
        let mut b = Pendulum::new();
        assert_eq!(a.reset(Some(7)).unwrap(), b.reset(Some(7)).unwrap());
        assert_ne!(a.reset(Some(8)).unwrap(), b.reset(Some(7)).unwrap());
    }
}
