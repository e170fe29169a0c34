//! The environment trait.

use crate::error::Result;
use crate::shield::Shield;
use crate::space::BoxSpace;

/// What happened besides the reward: flags that algorithms ignore and bookkeeping reads.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepInfo {
    /// The simulator became unstable (NaN/Inf accelerations) and the episode was ended; the
    /// step is marked `terminated` so that the episode stops, and a warning was logged.
    pub unstable: bool,
    /// A wrapper vetoed the action and did not send it to the environment (DEFENDER); the
    /// observation is a prediction and the step is `terminated`. Plain environments leave it false.
    pub filtered: bool,
    /// A cost the learner is charged that the task did not incur (DEFENDER's filtered step under
    /// `filtered_cost = "violation"`, docs/SPEC.md section 14): the trainer adds it to the cost
    /// of the transition the agent learns from, never to the episode's recorded cost. 0 otherwise.
    pub charged_cost: f64,
}

/// The result of one environment step.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// Observation after the step.
    pub obs: Vec<f64>,
    /// Reward of the step.
    pub reward: f64,
    /// Cost of the step, safe RL's constraint signal beside the reward (docs/SPEC.md, "12. Costs"):
    /// 0 unless the task defines one. On Hopper, Walker2d and InvertedDoublePendulum a crash step
    /// (the environment terminated the episode) costs 1; a step DEFENDER filtered costs 0, as it
    /// never reached the environment.
    pub cost: f64,
    /// The episode reached an absorbing state (e.g. the robot fell): do not bootstrap.
    pub terminated: bool,
    /// The episode was cut by a time limit: bootstrap as usual.
    pub truncated: bool,
    /// Side flags.
    pub info: StepInfo,
}

impl Step {
    /// Whether the episode is over (terminated or truncated).
    pub fn done(&self) -> bool {
        self.terminated || self.truncated
    }
}

/// A Gymnasium-style environment with continuous observations and actions.
///
/// Object safe, so that an environment chosen by id at run time is a `Box<dyn Env>`.
pub trait Env {
    /// The Gymnasium id (e.g. `Hopper-v5`).
    fn id(&self) -> &str;

    /// The observation space.
    fn observation_space(&self) -> &BoxSpace;

    /// The action space (bounded).
    fn action_space(&self) -> &BoxSpace;

    /// The episode horizon, if the environment has one (set by [`crate::TimeLimit`]).
    fn max_episode_steps(&self) -> Option<usize> {
        None
    }

    /// Starts a new episode and returns its first observation. `Some(seed)` re-seeds the
    /// environment's own random generator (as Gymnasium's `reset(seed=...)`); `None` continues it.
    ///
    /// # Errors
    /// The simulator failed to reset.
    fn reset(&mut self, seed: Option<u64>) -> Result<Vec<f64>>;

    /// Applies `action` and advances one step.
    ///
    /// # Errors
    /// The action has the wrong length or non-finite values, or the environment needs a reset.
    fn step(&mut self, action: &[f64]) -> Result<Step>;

    /// Writes whatever a checkpoint needs beyond the reset seed (a wrapper's learned model, its
    /// optimiser and data) into the existing, empty directory `dir`. The trainer calls it at
    /// episode boundaries only. Plain simulators keep no such state: the default writes nothing.
    ///
    /// # Errors
    /// [`crate::EnvError::State`] if a file cannot be written.
    fn save_state(&self, dir: &std::path::Path) -> Result<()> {
        let _ = dir;
        Ok(())
    }

    /// Restores what [`Env::save_state`] wrote into `dir`. The default reads nothing.
    ///
    /// # Errors
    /// [`crate::EnvError::State`] if a file is missing or does not fit.
    fn load_state(&mut self, dir: &std::path::Path) -> Result<()> {
        let _ = dir;
        Ok(())
    }

    /// A copy of what this environment uses to stop actions, to keep at evaluation (a DEFENDER
    /// environment: its filter as it stands): the trainer evaluates the policy with it too
    /// (crate::evaluation). The copy is the caller's; using it changes nothing here. Plain
    /// environments and wrappers that stop nothing: `None`.
    fn shield(&self) -> Option<Box<dyn Shield>> {
        None
    }

    /// A copy of the simulator as it stands, with nothing that stops actions (a DEFENDER
    /// environment: a copy of the environment it wraps, as its last step left it): stepping the
    /// copy changes nothing here. It answers "what would have happened" after an intervention
    /// (docs/SPEC.md, section 15). Environments that cannot be copied: `None`.
    fn fork(&self) -> Option<Box<dyn Env>> {
        None
    }

    /// How close `obs` lies to the task's own failure condition: 0 at the task's initial state,
    /// 1 on the boundary of its healthy range (past it the task terminates), the largest over
    /// the task's conditions. `None` where the task has no such condition (no crash) or the
    /// environment does not know it. The `margin` trigger reads it (docs/SPEC.md, section 15).
    fn failure_proximity(&self, obs: &[f64]) -> Option<f64> {
        let _ = obs;
        None
    }
}

impl<E: Env + ?Sized> Env for Box<E> {
    fn id(&self) -> &str {
        (**self).id()
    }
    fn observation_space(&self) -> &BoxSpace {
        (**self).observation_space()
    }
    fn action_space(&self) -> &BoxSpace {
        (**self).action_space()
    }
    fn max_episode_steps(&self) -> Option<usize> {
        (**self).max_episode_steps()
    }
    fn reset(&mut self, seed: Option<u64>) -> Result<Vec<f64>> {
        (**self).reset(seed)
    }
    fn step(&mut self, action: &[f64]) -> Result<Step> {
        (**self).step(action)
    }
    fn save_state(&self, dir: &std::path::Path) -> Result<()> {
        (**self).save_state(dir)
    }
    fn load_state(&mut self, dir: &std::path::Path) -> Result<()> {
        (**self).load_state(dir)
    }
    fn shield(&self) -> Option<Box<dyn Shield>> {
        (**self).shield()
    }
    fn fork(&self) -> Option<Box<dyn Env>> {
        (**self).fork()
    }
    fn failure_proximity(&self, obs: &[f64]) -> Option<f64> {
        (**self).failure_proximity(obs)
    }
}
