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

    /// The file name of the task's MuJoCo model in Gymnasium's `envs/mujoco/assets/`.
    /// Walker2d-v5 uses `walker2d_v5.xml` (feet friction 1.9), not the older `walker2d.xml`.
    pub fn xml_file(self) -> &'static str {
        match self {
            Task::Hopper => "hopper.xml",
            Task::Walker2d => "walker2d_v5.xml",
            Task::InvertedDoublePendulum => "inverted_double_pendulum.xml",
        }
    }

    /// The MuJoCo model, Gymnasium's own file (the one of Gymnasium 1.4.0 in the tests), read
    /// from the folder named by `DEFENDER_GYM_ASSETS` at run time (the `defender` command of the
    /// Python wheel sets it to the installed `gymnasium`'s assets), else at build time
    /// (`.cargo/config.toml`: the copy `make setup` extracts into `.deps/`). Read rather than
    /// embedded, so that a wheel built from source carries no copy of Gymnasium's files.
    ///
    /// # Errors
    /// [`EnvError::Simulator`] naming the file and the folders tried when it cannot be read.
    pub fn xml(self) -> Result<String> {
        let file = self.xml_file();
        let mut tried = Vec::new();
        let runtime = std::env::var_os("DEFENDER_GYM_ASSETS").filter(|d| !d.is_empty());
        let build = option_env!("DEFENDER_GYM_ASSETS").filter(|d| !d.is_empty()).map(Into::into);
        for dir in runtime.into_iter().chain(build) {
            let path = std::path::Path::new(&dir).join(file);
            match std::fs::read_to_string(&path) {
                Ok(xml) => return Ok(xml),
                Err(e) => tried.push(format!("{}: {e}", path.display())),
            }
        }
        Err(EnvError::Simulator(format!(
            "{}: cannot read Gymnasium's task file {file} ({}); install Gymnasium \
             (`pip install gymnasium`) and use the `defender` command of the defender-rl wheel, \
             or set DEFENDER_GYM_ASSETS to the folder gymnasium/envs/mujoco/assets",
            self.id(),
            if tried.is_empty() { "DEFENDER_GYM_ASSETS is not set".to_string() } else { tried.join("; ") }
        )))
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
