//! One episode of an episode set, borrowed: its arrays, transitions and sequence (SPEC section 1).

use crate::strategy::Mode;

/// One episode of a set, borrowed.
#[derive(Debug, Clone, Copy)]
pub struct Episode<'a> {
    /// Position in the set (file order).
    pub index: usize,
    /// `N + 1` observations, row-major `[(N + 1) * obs_dim]`.
    pub obs: &'a [f32],
    /// `N` actions, row-major `[N * act_dim]`.
    pub act: &'a [f32],
    /// `N` rewards.
    pub rew: &'a [f32],
    /// The environment terminated it before the horizon.
    pub crashed: bool,
    /// Observation dimension.
    pub obs_dim: usize,
    /// Action dimension.
    pub act_dim: usize,
}

impl Episode<'_> {
    /// Number of transitions `N`.
    pub fn len(&self) -> usize {
        self.rew.len()
    }

    /// Whether the episode has no transition (never true for a validated set).
    pub fn is_empty(&self) -> bool {
        self.rew.is_empty()
    }

    /// Observation `i` (`0 ..= N`).
    pub fn observation(&self, i: usize) -> &[f32] {
        &self.obs[i * self.obs_dim..(i + 1) * self.obs_dim]
    }

    /// Action `i` (`0 .. N`).
    pub fn action(&self, i: usize) -> &[f32] {
        &self.act[i * self.act_dim..(i + 1) * self.act_dim]
    }

    /// Number of elements of the episode's sequence: `N + 1` in state mode, `N` in state-action
    /// mode (SPEC section 1).
    pub fn sequence_len(&self, mode: Mode) -> usize {
        match mode {
            Mode::State => self.len() + 1,
            Mode::StateAction => self.len(),
        }
    }

    /// The episode's sequence (SPEC section 1), row-major: `[o_0 .. o_N]` in state mode,
    /// `[concat(o_i, a_i) for i < N]` in state-action mode.
    pub fn sequence(&self, mode: Mode) -> Vec<f32> {
        match mode {
            Mode::State => self.obs.to_vec(),
            Mode::StateAction => {
                let mut out = Vec::with_capacity(self.len() * (self.obs_dim + self.act_dim));
                for i in 0..self.len() {
                    out.extend_from_slice(self.observation(i));
                    out.extend_from_slice(self.action(i));
                }
                out
            }
        }
    }
}
