//! Reinforcement-learning substrate of defender: the environment API ([`Env`], [`Step`],
//! [`BoxSpace`], [`TimeLimit`]), and (as they land) the replay buffer, SAC, TD3 and the trainer.
//!
//! The API follows Gymnasium's: `reset(seed)` returns the first observation; `step(action)`
//! returns the next observation, the reward, and `terminated` (the task ended in an absorbing
//! state: bootstrap with zero) kept apart from `truncated` (a time limit: bootstrap as usual).

mod env;
mod error;
mod space;
mod time_limit;

pub use env::{Env, Step, StepInfo};
pub use error::{EnvError, Result};
pub use space::BoxSpace;
pub use time_limit::TimeLimit;
