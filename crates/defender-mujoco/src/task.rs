//! The tasks and their registry: Gymnasium ids, model files, dimensions, horizons.

use defender_rl::{EnvError, Result};

use crate::cost::Cost;

/// One of the MuJoCo tasks this crate implements: Gymnasium's v5 and v4 tasks and
/// Safety-Gymnasium's velocity tasks (a v4 task with a velocity cost).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Task {
    /// `Hopper-v5`: a one-legged hopper; 11-dimensional observation, 3 torques.
    Hopper,
    /// `Walker2d-v5`: a planar biped; 17-dimensional observation, 6 torques.
    Walker2d,
    /// `InvertedDoublePendulum-v5`: two poles on a cart; 9-dimensional observation, 1 force.
    InvertedDoublePendulum,
    /// `Hopper-v4`: as `Hopper-v5` but the healthy reward is paid on the falling step too.
    HopperV4,
    /// `Walker2d-v4`: `walker2d.xml` (both feet friction 0.9), healthy reward as `Hopper-v4`.
    Walker2dV4,
    /// `HalfCheetah-v4`: a planar runner that cannot fall; 17-dimensional observation, 6 torques.
    HalfCheetahV4,
    /// `SafetyHopperVelocity-v1`: `Hopper-v4` with a cost on x-velocity above 0.7402.
    SafetyHopperVelocity,
    /// `SafetyWalker2dVelocity-v1`: `Walker2d-v4` with a cost on x-velocity above 2.3415.
    SafetyWalker2dVelocity,
    /// `SafetyHalfCheetahVelocity-v1`: `HalfCheetah-v4` with a cost on x-velocity above 3.2096.
    SafetyHalfCheetahVelocity,
}

/// The robot of a task: what fixes its model, observation, health and reset noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Body {
    Hopper,
    Walker2d,
    HalfCheetah,
    InvertedDoublePendulum,
}

/// Gymnasium's version of a task's rules where v4 and v5 differ for our tasks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Version {
    /// v4: `healthy_reward` is `float(is_healthy or terminate_when_unhealthy)`, so 1 on every
    /// step including the one that falls; Walker2d uses `walker2d.xml`.
    V4,
    /// v5: `healthy_reward` is `is_healthy`, 0 on the falling step; Walker2d uses `walker2d_v5.xml`.
    V5,
}

/// What the registry knows about a task without building it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskSpec {
    /// The task.
    pub task: Task,
    /// The Gymnasium (or Safety-Gymnasium) id (`Hopper-v5`, ...).
    pub id: &'static str,
    /// Observation dimension.
    pub obs_dim: usize,
    /// Action dimension.
    pub act_dim: usize,
    /// `max_episode_steps` of Gymnasium's registration (the `TimeLimit` horizon).
    pub max_episode_steps: usize,
    /// MuJoCo physics steps per environment step (Gymnasium's `frame_skip`).
    pub frame_skip: usize,
    /// What a step costs ([`Step::cost`](defender_rl::Step)).
    pub cost: Cost,
}

const fn spec(task: Task, id: &'static str, dims: (usize, usize), frame_skip: usize, cost: Cost) -> TaskSpec {
    TaskSpec { task, id, obs_dim: dims.0, act_dim: dims.1, max_episode_steps: 1000, frame_skip, cost }
}

/// Every task, in a stable order (the order of `defender env list`). All have Gymnasium's
/// horizon of 1000 steps (Safety-Gymnasium registers its velocity tasks with the same).
pub const TASKS: [TaskSpec; 9] = [
    spec(Task::Hopper, "Hopper-v5", (11, 3), 4, Cost::Crash),
    spec(Task::Walker2d, "Walker2d-v5", (17, 6), 4, Cost::Crash),
    spec(Task::InvertedDoublePendulum, "InvertedDoublePendulum-v5", (9, 1), 5, Cost::Crash),
    spec(Task::HopperV4, "Hopper-v4", (11, 3), 4, Cost::None),
    spec(Task::Walker2dV4, "Walker2d-v4", (17, 6), 4, Cost::None),
    spec(Task::HalfCheetahV4, "HalfCheetah-v4", (17, 6), 5, Cost::None),
    // Thresholds of safety-gymnasium 1.0.0's `safety_*_velocity_v1.py`.
    spec(
        Task::SafetyHopperVelocity,
        "SafetyHopperVelocity-v1",
        (11, 3),
        4,
        Cost::Velocity { threshold: 0.7402 },
    ),
    spec(
        Task::SafetyWalker2dVelocity,
        "SafetyWalker2dVelocity-v1",
        (17, 6),
        4,
        Cost::Velocity { threshold: 2.3415 },
    ),
    spec(
        Task::SafetyHalfCheetahVelocity,
        "SafetyHalfCheetahVelocity-v1",
        (17, 6),
        5,
        Cost::Velocity { threshold: 3.2096 },
    ),
];

/// The registry: every task with its id, dimensions, horizon and cost.
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
        // Every variant has an entry (the registry test checks it); the fallback is never taken.
        TASKS.iter().find(|s| s.task == self).unwrap_or(&TASKS[0])
    }

    /// The robot: model, observation, health and reset noise.
    pub(crate) fn body(self) -> Body {
        match self {
            Task::Hopper | Task::HopperV4 | Task::SafetyHopperVelocity => Body::Hopper,
            Task::Walker2d | Task::Walker2dV4 | Task::SafetyWalker2dVelocity => Body::Walker2d,
            Task::HalfCheetahV4 | Task::SafetyHalfCheetahVelocity => Body::HalfCheetah,
            Task::InvertedDoublePendulum => Body::InvertedDoublePendulum,
        }
    }

    /// The Gymnasium version whose rules the task follows (the velocity tasks wrap v4).
    pub(crate) fn version(self) -> Version {
        match self {
            Task::Hopper | Task::Walker2d | Task::InvertedDoublePendulum => Version::V5,
            _ => Version::V4,
        }
    }

    /// The Gymnasium id.
    pub fn id(self) -> &'static str {
        self.spec().id
    }

    /// The file name of the task's MuJoCo model in Gymnasium's `envs/mujoco/assets/`.
    /// Walker2d-v5 uses `walker2d_v5.xml` (left foot friction 1.9), v4 the older `walker2d.xml`.
    pub fn xml_file(self) -> &'static str {
        match (self.body(), self.version()) {
            (Body::Hopper, _) => "hopper.xml",
            (Body::Walker2d, Version::V5) => "walker2d_v5.xml",
            (Body::Walker2d, Version::V4) => "walker2d.xml",
            (Body::HalfCheetah, _) => "half_cheetah.xml",
            (Body::InvertedDoublePendulum, _) => "inverted_double_pendulum.xml",
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
    /// 0.1 for HalfCheetah and InvertedDoublePendulum.
    pub fn reset_noise_scale(self) -> f64 {
        match self.body() {
            Body::Hopper | Body::Walker2d => 5e-3,
            Body::HalfCheetah | Body::InvertedDoublePendulum => 0.1,
        }
    }

    /// The task's cost rule.
    pub fn cost(self) -> Cost {
        self.spec().cost
    }

    /// The episode cost limit of the task's runs ([`Cost::episode_limit`]): 25 for the velocity
    /// tasks, `None` for the crash tasks and the plain v4 tasks.
    pub fn episode_cost_limit(self) -> Option<f64> {
        self.cost().episode_limit()
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

    #[test]
    fn velocity_tasks_wrap_their_v4_base() {
        for (safety, base) in [
            (Task::SafetyHopperVelocity, Task::HopperV4),
            (Task::SafetyWalker2dVelocity, Task::Walker2dV4),
            (Task::SafetyHalfCheetahVelocity, Task::HalfCheetahV4),
        ] {
            let (s, b) = (safety.spec(), base.spec());
            assert_eq!(
                (s.obs_dim, s.act_dim, s.frame_skip, s.max_episode_steps),
                (b.obs_dim, b.act_dim, b.frame_skip, 1000)
            );
            assert_eq!(
                (safety.body(), safety.version(), safety.xml_file()),
                (base.body(), Version::V4, base.xml_file())
            );
            assert!(matches!(s.cost, Cost::Velocity { .. }) && b.cost == Cost::None);
            assert_eq!((safety.episode_cost_limit(), base.episode_cost_limit()), (Some(25.0), None));
        }
        assert_eq!(Task::Hopper.episode_cost_limit(), None, "a crash task counts crashes");
        assert_eq!(Task::Walker2dV4.xml_file(), "walker2d.xml");
        assert_eq!(Task::Walker2d.xml_file(), "walker2d_v5.xml");
    }
}
