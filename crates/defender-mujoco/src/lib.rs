#![doc = include_str!("../README.md")]

mod env;
mod logging;
mod replay;
mod task;

pub use defender_rl::{EnvError, Result};
pub use env::{MujocoEnv, make};
pub use replay::{Rollout, replay};
pub use task::{TASKS, Task, TaskSpec, registry};
