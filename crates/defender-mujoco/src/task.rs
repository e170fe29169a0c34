//! The tasks and their registry: Gymnasium ids, model files, dimensions, horizons.

use defender_rl::{EnvError, Result};

/// One of the Gymnasium v5 MuJoCo tasks this crate implements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Task {
    /// `Hopper-v5`: a one-legged hopper; 11-dimensional observation, 3 torques.
    Hopper,
    /// `Walker2d-v5`: a planar biped; 17-dimensional observation, 6 torques.
    Walker2d,
    /// `InvertedDoublePendulum-v5`: two poles on a cart; 9-dimensional observation, 1 force.
    InvertedDoublePendulum,
}

/// What the registry knows about a task without building it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TaskSpec {
    /// The task.
    pub task: Task,
    /// The Gymnasium id (`Hopper-v5`, ...).
    pub id: &'static str,
    /// Observation dimension.
    pub obs_dim: usize,
    /// Action dimension.
    pub act_dim: usize,
    /// `max_episode_steps` of Gymnasium's registration (the `TimeLimit` horizon).
    pub max_episode_steps: usize,
    /// MuJoCo physics steps per environment step (Gymnasium's `frame_skip`).
    pub frame_skip: usize,
}

/// Every task, in a stable order (the order of `defender env list`).
pub const TASKS: [TaskSpec; 3] = [
    TaskSpec {
        task: Task::Hopper,
        id: "Hopper-v5",
        obs_dim: 11,
        act_dim: 3,
        max_episode_steps: 1000,
        frame_skip: 4,
    },
    TaskSpec {
        task: Task::Walker2d,
        id: "Walker2d-v5",
        obs_dim: 17,
        act_dim: 6,
        max_episode_steps: 1000,
        frame_skip: 4,
    },
    TaskSpec {
        task: Task::InvertedDoublePendulum,
        id: "InvertedDoublePendulum-v5",
        obs_dim: 9,
        act_dim: 1,
        max_episode_steps: 1000,
        frame_skip: 5,
    },
];

/// The registry: every task with its id, dimensions and horizon.
pub fn registry() -> &'static [TaskSpec] {
    &TASKS
}

impl Task {
    /// The task with Gymnasium id `id` (exact, case-sensitive, as `gymnasium.make`).
    ///
    /// # Errors
    /// [`EnvError::UnknownEnv`] listing the known ids.
    pub fn from_id(id: &str) -> Result<Self> {
        TASKS.iter().find(|s| s.id == id).map(|s| s.task).ok_or_else(|| EnvError::UnknownEnv {
            id: id.to_owned(),
            known: TASKS.iter().map(|s| s.id).collect::<Vec<_>>().join(", "),
        })
    }

    /// The registry entry of this task.
    pub fn spec(self) -> &'static TaskSpec {
        match self {
            Task::Hopper => &TASKS[0],
            Task::Walker2d => &TASKS[1],
            Task::InvertedDoublePendulum => &TASKS[2],
        }
    }

    /// The Gymnasium id.
    pub fn id(self) -> &'static str {
        self.spec().id
    }

    /// The MuJoCo model, Gymnasium 1.4.0's own file, embedded at compile time. Walker2d-v5
    /// uses `walker2d_v5.xml` (feet friction 1.9), not the older `walker2d.xml`.
    pub fn xml(self) -> &'static str {
        match self {
            Task::Hopper => include_str!(concat!(env!("DEFENDER_GYM_ASSETS"), "/hopper.xml")),
            Task::Walker2d => include_str!(concat!(env!("DEFENDER_GYM_ASSETS"), "/walker2d_v5.xml")),
            Task::InvertedDoublePendulum => {
                include_str!(concat!(env!("DEFENDER_GYM_ASSETS"), "/inverted_double_pendulum.xml"))
            }
        }
    }

    /// Scale of the initial-state noise (`reset_noise_scale`): 5e-3 for Hopper and Walker2d,
    /// 0.1 for InvertedDoublePendulum.
    pub fn reset_noise_scale(self) -> f64 {
        match self {
            Task::Hopper | Task::Walker2d => 5e-3,
            Task::InvertedDoublePendulum => 0.1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_unknown_ids_list_the_known_ones() {
        for spec in registry() {
            assert_eq!(Task::from_id(spec.id).unwrap(), spec.task);
            assert_eq!(spec.task.spec(), spec);
        }
        let err = Task::from_id("hopper-v5").unwrap_err().to_string();
        assert!(
            err.contains("hopper-v5") && err.contains("Hopper-v5, Walker2d-v5, InvertedDoublePendulum-v5")
        );
    }
}
