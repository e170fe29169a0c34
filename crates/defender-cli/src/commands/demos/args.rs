//! The arguments of `defender demos collect`, shared by both rules.

use std::path::PathBuf;

use clap::Args;
use defender_config::profile::Profile;

/// Arguments of `defender demos collect`.
#[derive(Debug, Args)]
pub struct CollectArgs {
    /// Gymnasium id of the task.
    #[arg(long)]
    pub env: String,
    /// spec (the default rule above) or authors: their SAC, interval, grouping and order;
    /// keeps-learning collects as spec (it changes how a run filters and learns, not the demos).
    #[arg(long, value_enum, default_value = "spec")]
    pub profile: Profile,
    /// Safe demonstrations to keep [default: 50] (not with --profile authors: it keeps all).
    #[arg(long)]
    pub safe: Option<usize>,
    /// Unsafe demonstrations to keep [default: 50] (not with --profile authors).
    #[arg(long = "unsafe")]
    pub unsafe_: Option<usize>,
    /// Stop training after this many environment steps even if a group is short (then it fails)
    /// [default: 1000000]. The shipped sets needed 62,898 (InvertedDoublePendulum-v5), 202,389
    /// (Hopper-v5) and 370,537 (Walker2d-v5) steps with seed 0. Not with --profile authors.
    #[arg(long)]
    pub max_steps: Option<u64>,
    /// Train at least this many steps before stopping (more candidates to spread over).
    #[arg(long)]
    pub min_steps: Option<u64>,
    /// SAC's random-action steps before its first update; recording starts after them
    /// [default: SAC's learning_starts, 5000]. Not with --profile authors (no warm-up).
    #[arg(long)]
    pub learning_starts: Option<u64>,
    /// --profile authors: training episodes [default: 5000, theirs].
    #[arg(long)]
    pub episodes: Option<u64>,
    /// --profile authors: training episodes between two demonstrations [default: 50, theirs].
    #[arg(long)]
    pub demonstrate_every: Option<u64>,
    /// Horizon of the training and demonstration episodes [default: the task's, 1000].
    #[arg(long)]
    pub max_episode_steps: Option<usize>,
    /// On a task with a per-step cost (`defender env list`): an episode is unsafe once its cost
    /// passes this limit, and its demonstration ends on that step [default: the task's, 25].
    /// Not on a crash task.
    #[arg(long)]
    pub episode_cost_limit: Option<f64>,
    /// The agent that learns while demonstrations are recorded [default: sac on a crash task;
    /// lagrangian on a cost task, Lagrangian SAC keeping the episode cost under the limit, so that
    /// policies under the limit for the whole horizon (the safe group) come up at all].
    #[arg(long, value_enum)]
    pub learner: Option<Learner>,
    /// Seed of the SAC agent and of every reset.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Where to write the demonstration set (.npz, SPEC section 8).
    #[arg(long)]
    pub out: PathBuf,
}

/// `--learner`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Learner {
    /// SAC.
    Sac,
    /// Lagrangian SAC (OmniSafe's SACLag rule) with the episode cost limit as its `cost_limit`.
    Lagrangian,
}
