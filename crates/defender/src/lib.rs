#![doc = include_str!("../README.md")]

mod ablation;
mod adaptive_filter;
mod atomic;
pub mod authors_collection;
pub mod collection;
mod cost;
mod cost_stream;
mod defender_env;
mod demonstrations;
pub mod diversity;
mod dynamics;
mod dynamics_worker;
mod episode_set;
mod error;
mod filter;
mod filter_options;
mod method;
pub mod npz;
mod recorder;
mod score;
mod scoring;
mod screen;
pub mod selection;
mod strategy;
pub mod synthetic;
mod violation;
mod window;

pub use ablation::{Ablation, EpisodeReplay, Progress, ablate, ablate_scored};
pub use adaptive_filter::AdaptiveFilter;
pub use atomic::write_atomic;
pub use cost::{CostOptions, DtwKind, Elements, Metric, Scaling, Ties};
pub use cost_stream::CostStream;
pub use defender_env::{DefenderConfig, DefenderEnv, DefenderStats, MAX_ABS_R_TASK};
pub use demonstrations::Demonstrations;
pub use dynamics::{DynamicsConfig, DynamicsModel, PredictionError};
pub use dynamics_worker::DynamicsHandle;
pub use episode_set::{Episode, EpisodeSet, Meta};
pub use error::{DefenderError, Result};
pub use filter::{Decision, Filter};
pub use filter_options::{Budget, FilterOptions, MAX_ADAPTIVE_MARGIN, OwnEpisodes};
pub use method::{Aggregation, Method};
pub use recorder::EpisodeRecorder;
pub use score::{
    AblationRow, CSV_HEADER, StrategyTally, csv_scoring, rank, rank_tasks, read_csv, write_csv,
    write_csv_scored,
};
pub use scoring::{AuthorsTally, Scoring};
pub use screen::{ScreenTally, screen};
pub use strategy::{Mode, Strategy};
pub use violation::{EPISODE_COST_LIMIT_KEY, UnsafeRule, ViolationTracker};
pub use window::{Span, Window};
