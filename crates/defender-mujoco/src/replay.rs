//! Replaying a sequence of actions from a given state (the parity tests and `defender env replay`).

use defender_rl::{Env, EnvError, Result};

use crate::env::MujocoEnv;

/// What a replay produced: observations, rewards, costs and termination flags, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Rollout {
    /// Observation dimension (the row length of `obs`).
    pub obs_dim: usize,
    /// `[steps + 1, obs_dim]`: the observation of the given state, then one per step.
    pub obs: Vec<f64>,
    /// `[steps]`: the reward of each step.
    pub rewards: Vec<f64>,
    /// `[steps]`: the cost of each step (the task's [`Cost`](crate::Cost) rule; all 0 for a
    /// task without one).
    pub costs: Vec<f64>,
    /// `[steps]`: whether each step terminated (only the last one can).
    pub terminated: Vec<bool>,
    /// Whether the last step ended because MuJoCo became unstable.
    pub unstable: bool,
}

impl Rollout {
    /// Number of steps taken.
    pub fn steps(&self) -> usize {
        self.rewards.len()
    }

    /// Observation `t` (0 = the given state; `t` in `0..=steps`).
    ///
    /// # Panics
    /// If `t > steps`.
    pub fn obs_row(&self, t: usize) -> &[f64] {
        &self.obs[t * self.obs_dim..(t + 1) * self.obs_dim]
    }
}

/// Starts `env` from `qpos`/`qvel` (with [`MujocoEnv::reset_to`]: MuJoCo's data reset, then the
/// state set) and applies `actions` in order, stopping after the first terminated step (or
/// after the last action). `actions` is row-major `[T, act_dim]`. No time limit applies.
///
/// # Errors
/// [`EnvError::LengthMismatch`] if `qpos`/`qvel` have the wrong length or `actions.len()` is
/// not a multiple of the action dimension; [`EnvError::NonFinite`] for a NaN or infinite
/// value in any of them (nothing is stepped then).
pub fn replay(env: &mut MujocoEnv, qpos: &[f64], qvel: &[f64], actions: &[f64]) -> Result<Rollout> {
    let act_dim = env.action_space().dim();
    if !actions.len().is_multiple_of(act_dim) {
        return Err(EnvError::LengthMismatch {
            name: format!("actions (row-major [T, {act_dim}])"),
            expected: actions.len().div_ceil(act_dim) * act_dim,
            got: actions.len(),
        });
    }
    if let Some((index, &value)) = actions.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(EnvError::NonFinite {
            name: format!("actions (row {}, column {})", index / act_dim, index % act_dim),
            index,
            value,
        });
    }
    let steps = actions.len() / act_dim;
    let first = env.reset_to(qpos, qvel)?;
    let obs_dim = first.len();
    let mut rollout = Rollout {
        obs_dim,
        obs: Vec::with_capacity((steps + 1) * obs_dim),
        rewards: Vec::with_capacity(steps),
        costs: Vec::with_capacity(steps),
        terminated: Vec::with_capacity(steps),
        unstable: false,
    };
    rollout.obs.extend_from_slice(&first);
    for action in actions.chunks_exact(act_dim) {
        let step = env.step(action)?;
        rollout.obs.extend_from_slice(&step.obs);
        rollout.rewards.push(step.reward);
        rollout.costs.push(step.cost);
        rollout.terminated.push(step.terminated);
        rollout.unstable = step.info.unstable;
        if step.terminated {
            break;
        }
    }
    Ok(rollout)
}
