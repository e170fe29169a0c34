#![doc = include_str!("../README.md")]

mod cost;
mod env;
mod logging;
mod replay;
mod task;

pub use cost::{Cost, EPISODE_COST_LIMIT};
pub use defender_rl::{EnvError, Result};
pub use env::{MujocoEnv, make};
pub use replay::{Rollout, replay};
pub use task::{TASKS, Task, TaskSpec, registry};
