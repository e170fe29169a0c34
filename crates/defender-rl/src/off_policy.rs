//! What SAC and TD3 share around their gradient steps, as SB3's `OffPolicyAlgorithm` does: the
//! replay buffer with the step counter, the training schedule, the warm-up policy, and the
//! check that a saved state belongs to the agent loading it. Each algorithm's gradient step stays
//! in its own file.

use std::path::Path;

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::agent::UpdateStats;
use crate::error::RlError;
use crate::replay::{ReplayBuffer, Transition};

/// The transitions seen so far: the replay buffer and SB3's `num_timesteps`.
#[derive(Debug, Clone)]
pub(crate) struct Experience {
    pub(crate) buffer: ReplayBuffer,
    pub(crate) num_timesteps: u64,
}

impl Experience {
    pub(crate) fn new(buffer: ReplayBuffer) -> Self {
        Self { buffer, num_timesteps: 0 }
    }

    /// Stores one transition and counts the step; `terminal_on_truncation` stores a time-limit
    /// cut as terminal (the authors' code).
    pub(crate) fn observe(
        &mut self,
        transition: &Transition<'_>,
        terminal_on_truncation: bool,
    ) -> Result<(), RlError> {
        self.buffer.push(&as_stored(transition, terminal_on_truncation))?;
        self.num_timesteps += 1;
        Ok(())
    }

    /// Stores a demonstration's transition without counting a step (`bc`: a safe
    /// demonstration's, for behaviour cloning).
    pub(crate) fn store_demonstration(
        &mut self,
        transition: &Transition<'_>,
        bc: bool,
        terminal_on_truncation: bool,
    ) -> Result<(), RlError> {
        self.buffer.push_demonstration(&as_stored(transition, terminal_on_truncation), bc)
    }

    /// Still in the warm-up, where actions are uniform over the action space (SB3 samples the
    /// space itself before `learning_starts`).
    pub(crate) fn warming_up(&self, learning_starts: u64) -> bool {
        self.num_timesteps < learning_starts
    }
}

/// The transition as the buffer keeps it: a time-limit cut becomes terminal if asked.
fn as_stored<'a>(t: &Transition<'a>, terminal_on_truncation: bool) -> Transition<'a> {
    Transition { terminated: t.terminated || (terminal_on_truncation && t.truncated), ..*t }
}

/// SB3's training schedule: after every `train_freq` environment steps, once more than
/// `learning_starts` were taken, `gradient_steps` gradient steps. Without a warm-up, also not
/// before the buffer holds `min_buffer` transitions (a batch: the authors' rule).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Schedule {
    pub(crate) learning_starts: u64,
    pub(crate) train_freq: u64,
    pub(crate) gradient_steps: u64,
    pub(crate) min_buffer: usize,
}

impl Schedule {
    /// Runs `step` as often as the schedule asks after `num_timesteps` steps; the last step's
    /// statistics, or `None` when no step was due.
    pub(crate) fn run(
        self,
        num_timesteps: u64,
        buffer_len: usize,
        mut step: impl FnMut() -> Result<UpdateStats, RlError>,
    ) -> Result<Option<UpdateStats>, RlError> {
        if num_timesteps <= self.learning_starts
            || !num_timesteps.is_multiple_of(self.train_freq)
            || buffer_len < self.min_buffer
        {
            return Ok(None);
        }
        let mut last = None;
        for _ in 0..self.gradient_steps {
            last = Some(step()?);
        }
        Ok(last)
    }
}

/// A uniformly random action in `[-1, 1]^act_dim` (the warm-up policy).
pub(crate) fn uniform_action(rng: &mut ChaCha8Rng, action: &mut [f32]) {
    for x in action.iter_mut() {
        *x = rng.random_range(-1.0..=1.0);
    }
}

/// The identity of an agent as its `state.json` records it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Identity {
    pub(crate) algo: &'static str,
    pub(crate) obs_dim: usize,
    pub(crate) act_dim: usize,
}

/// Refuses a saved state (`path`) written by another algorithm, for other dimensions, or with
/// another configuration (`same_config` false) than the agent `this`.
pub(crate) fn check_saved(
    path: &Path,
    saved_algo: &str,
    saved_dims: (usize, usize),
    same_config: bool,
    this: Identity,
) -> Result<(), RlError> {
    if saved_algo == this.algo && same_config && saved_dims == (this.obs_dim, this.act_dim) {
        return Ok(());
    }
    Err(RlError::checkpoint(
        path,
        format!(
            "saved by {saved_algo} with dims {}/{} and another configuration than this agent's ({}, {}/{})",
            saved_dims.0, saved_dims.1, this.algo, this.obs_dim, this.act_dim
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_waits_for_learning_starts_and_every_train_freq_steps() {
        let schedule = Schedule { learning_starts: 10, train_freq: 4, gradient_steps: 2, min_buffer: 0 };
        let mut calls = 0;
        let mut step = || {
            calls += 1;
            Ok(UpdateStats { n_updates: calls, ..UpdateStats::default() })
        };
        for n in [0, 4, 8, 10] {
            assert_eq!(schedule.run(n, 100, &mut step).unwrap(), None, "step {n}");
        }
        assert_eq!(schedule.run(11, 100, &mut step).unwrap(), None, "not a multiple of train_freq");
        assert_eq!(schedule.run(12, 100, &mut step).unwrap().map(|s| s.n_updates), Some(2));
        assert_eq!(calls, 2);
        // Without a warm-up, not before the buffer holds a batch.
        let schedule = Schedule { learning_starts: 0, train_freq: 1, gradient_steps: 1, min_buffer: 8 };
        let mut step = || Ok(UpdateStats::default());
        assert_eq!(schedule.run(3, 7, &mut step).unwrap(), None);
        assert!(schedule.run(4, 8, &mut step).unwrap().is_some());
    }

    #[test]
    fn a_state_of_another_agent_is_refused() {
        let this = Identity { algo: "sac", obs_dim: 3, act_dim: 1 };
        let path = Path::new("state.json");
        assert!(check_saved(path, "sac", (3, 1), true, this).is_ok());
        for (algo, dims, same) in [("td3", (3, 1), true), ("sac", (3, 2), true), ("sac", (3, 1), false)] {
            let err = check_saved(path, algo, dims, same, this).unwrap_err().to_string();
            assert!(err.contains("saved by"), "{err}");
        }
    }
}
