#![doc = include_str!("../README.md")]

mod agent;
mod algo;
pub mod checkpoint;
pub mod classic;
mod config;
pub mod counterfactual;
mod critics;
mod env;
mod error;
mod evaluation;
mod nets;
mod off_policy;
mod replay;
mod sac;
pub mod safety;
mod seed;
mod shield;
mod space;
mod td3;
mod time_limit;
mod trainer;

pub use agent::{Agent, UpdateStats};
pub use algo::{Algo, AlgoConfig};
pub use config::{BcForm, EntCoef, MAX_BATCH_SIZE, SacConfig, Td3Config, check_batch_size, check_layers};
pub use counterfactual::{CheckConfig, InterventionRecord};
/// How many threads the networks' GEMMs use (`Sac::set_parallelism`, `Td3::set_parallelism`).
pub use defender_nn::Parallelism;
pub use env::{Env, Step, StepInfo};
pub use error::{EnvError, Result, RlError, check_vector};
pub use evaluation::{EvalRecord, ShieldedEval};
pub use replay::{Batch, ReplayBuffer, Transition};
pub use sac::Sac;
pub use safety::SafetyConfig;
pub use safety::risk_signal::RiskSignal;
pub use seed::{SeedPurpose, derive_seed};
pub use shield::Shield;
pub use space::BoxSpace;
pub use td3::Td3;
pub use time_limit::TimeLimit;
pub use trainer::{
    Budget, EpisodeRecord, HookError, Hooks, NoHooks, Outcome, RunEnd, Trainer, TrainerConfig,
};
