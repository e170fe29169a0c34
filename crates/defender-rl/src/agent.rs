//! The interface between the trainer and an off-policy algorithm.

use std::path::Path;

use crate::error::RlError;
use crate::replay::Transition;

/// What one training phase reported (the last gradient step's values), under CleanRL's metric
/// names: `losses/qf_loss`, `losses/actor_loss`, `losses/alpha`, `losses/alpha_loss`, and a
/// Lagrangian agent's `losses/qc_loss` and `train/lagrange_multiplier`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct UpdateStats {
    /// Gradient steps taken so far (SB3's `n_updates`).
    pub n_updates: u64,
    /// Sum of the two critics' losses.
    pub qf_loss: f32,
    /// Mean Q1 value over the batch.
    pub qf1_mean: f32,
    /// The actor's loss, when the actor was updated at this step (TD3 delays it).
    pub actor_loss: Option<f32>,
    /// The entropy coefficient used (SAC).
    pub alpha: Option<f32>,
    /// The entropy coefficient's loss (SAC with `ent_coef = "auto"`).
    pub alpha_loss: Option<f32>,
    /// Environment steps so far in which Recovery RL's recovery policy acted instead of the
    /// task policy (`None` for the other agents).
    pub recovery_steps: Option<u64>,
    /// The cost critic's loss (Lagrangian SAC: `losses/qc_loss`).
    pub cost_critic_loss: Option<f32>,
    /// The Lagrange multiplier used (Lagrangian SAC: `train/lagrange_multiplier`).
    pub lagrange_multiplier: Option<f32>,
    /// The mean `Q_c` at the batch's states and the actor's actions (a Lagrangian agent's cost
    /// critic, as the actor's loss reads it).
    pub qc_mean: Option<f32>,
}

/// An off-policy agent as the trainer drives it: pick an action, store the transition, learn.
///
/// Actions are in the normalised box `[-1, 1]^act_dim`; the trainer rescales them to the
/// environment's bounds (SB3's `unscale_action`) and stores the normalised action. The agent
/// owns its replay buffer, its random generator and its schedule (`learning_starts`,
/// `train_freq`, `gradient_steps`), so that the trainer stays algorithm-agnostic.
pub trait Agent {
    /// `"sac"` or `"td3"` (the run directory's `algo`).
    fn algo(&self) -> &'static str;

    /// Observation dimension.
    fn obs_dim(&self) -> usize;

    /// Action dimension.
    fn act_dim(&self) -> usize;

    /// Environment steps observed so far (SB3's `num_timesteps`).
    fn num_timesteps(&self) -> u64;

    /// Writes the action for `obs` into `action` (`act_dim` values in `[-1, 1]`).
    /// `deterministic` is the evaluation policy (the mean action, no noise); otherwise the
    /// exploration policy, which is uniform random before `learning_starts`.
    ///
    /// # Errors
    /// `obs` or `action` has the wrong length, or `obs` is not finite.
    fn act(&mut self, obs: &[f64], deterministic: bool, action: &mut [f32]) -> Result<(), RlError>;

    /// The exploration action for `obs`, as [`Agent::act`] with `deterministic = false` gives it,
    /// but with every draw from `rng`: the agent's own generator and state are left as they
    /// were, so that a run that asks it for actions on the side (the counterfactual check of an
    /// intervention, crate::counterfactual) goes on exactly as one that does not.
    ///
    /// # Errors
    /// As [`Agent::act`].
    fn act_with(
        &mut self,
        obs: &[f64],
        rng: &mut rand_chacha::ChaCha8Rng,
        action: &mut [f32],
    ) -> Result<(), RlError>;

    /// Stores one transition (and counts the step).
    ///
    /// # Errors
    /// A vector has the wrong length or a non-finite value.
    fn observe(&mut self, transition: &Transition<'_>) -> Result<(), RlError>;

    /// Stores a demonstration's transition in the replay buffer before training, without
    /// counting a step; `bc` marks a safe demonstration's for a behaviour-cloning term.
    ///
    /// # Errors
    /// A vector has the wrong length or a non-finite value.
    fn store_demonstration(&mut self, transition: &Transition<'_>, bc: bool) -> Result<(), RlError>;

    /// Runs the gradient steps the schedule asks for after the last observed step, if any.
    ///
    /// # Errors
    /// [`RlError::Diverged`] if a loss became non-finite.
    fn update(&mut self) -> Result<Option<UpdateStats>, RlError>;

    /// Writes the complete agent state (networks, optimisers, replay buffer, RNG, counters)
    /// into the existing directory `dir`.
    ///
    /// # Errors
    /// [`RlError::Io`] or [`RlError::Nn`].
    fn save(&self, dir: &Path) -> Result<(), RlError>;

    /// Restores a state written by [`Agent::save`] by an agent of the same configuration.
    ///
    /// # Errors
    /// [`RlError::Checkpoint`] if a file is missing or does not fit this agent.
    fn load(&mut self, dir: &Path) -> Result<(), RlError>;

    /// Saves the deterministic policy network alone (PyTorch `nn.Sequential` names).
    ///
    /// # Errors
    /// [`RlError::Nn`].
    fn save_actor(&self, path: &Path) -> Result<(), RlError>;
}

impl<A: Agent + ?Sized> Agent for Box<A> {
    fn algo(&self) -> &'static str {
        (**self).algo()
    }
    fn obs_dim(&self) -> usize {
        (**self).obs_dim()
    }
    fn act_dim(&self) -> usize {
        (**self).act_dim()
    }
    fn num_timesteps(&self) -> u64 {
        (**self).num_timesteps()
    }
    fn act(&mut self, obs: &[f64], deterministic: bool, action: &mut [f32]) -> Result<(), RlError> {
        (**self).act(obs, deterministic, action)
    }
    fn act_with(
        &mut self,
        obs: &[f64],
        rng: &mut rand_chacha::ChaCha8Rng,
        action: &mut [f32],
    ) -> Result<(), RlError> {
        (**self).act_with(obs, rng, action)
    }
    fn observe(&mut self, transition: &Transition<'_>) -> Result<(), RlError> {
        (**self).observe(transition)
    }
    fn store_demonstration(&mut self, transition: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        (**self).store_demonstration(transition, bc)
    }
    fn update(&mut self) -> Result<Option<UpdateStats>, RlError> {
        (**self).update()
    }
    fn save(&self, dir: &Path) -> Result<(), RlError> {
        (**self).save(dir)
    }
    fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        (**self).load(dir)
    }
    fn save_actor(&self, path: &Path) -> Result<(), RlError> {
        (**self).save_actor(path)
    }
}
