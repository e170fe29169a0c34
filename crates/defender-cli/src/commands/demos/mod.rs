//! `defender demos collect`: demonstrations as in the paper (`spec.rs`: SPEC's rule, the default)
//! or as the authors' code made them (`authors.rs`), from the same arguments (`args.rs`) and the
//! same recording of one episode of the current policy (`record.rs`). `defender demos
//! risk-horizon`: how far ahead of a crash Recovery RL's safety critic, pretrained on them, warns
//! (`risk_horizon.rs`, `risk_measure.rs`, `risk_csv.rs`).

mod args;
mod authors;
mod record;
mod risk_csv;
mod risk_horizon;
mod risk_measure;
mod spec;

use anyhow::Result;
use clap::Subcommand;

pub use args::{CollectArgs, Learner};
use defender_config::profile::Profile;
pub use risk_horizon::RiskHorizonArgs;

/// `defender demos` subcommands.
#[derive(Debug, Subcommand)]
pub enum DemosCommand {
    /// Train SAC and record one episode of the current policy after every training episode.
    #[command(after_help = "Examples:
  defender demos collect --env InvertedDoublePendulum-v5 --out data/demos/InvertedDoublePendulum-v5.npz
  defender demos collect --env Hopper-v5 --safe 50 --unsafe 50 --seed 1 --out hopper-s1.npz
  defender demos collect --profile authors --env Hopper-v5 --episodes 5000 --out hopper-authors.npz
  defender demos collect --env SafetyHopperVelocity-v1 --out data/demos/SafetyHopperVelocity-v1.npz

A demonstration is unsafe when the environment terminated it before the horizon (it crashed),
safe otherwise. On a task whose safety is a per-step cost (SafetyHopperVelocity-v1 and the other
velocity tasks: `defender env list`), it is unsafe once its cost passes the episode cost limit
(--episode-cost-limit, the task's 25 by default) and ends on that step, safe when it reaches the
horizon within the limit; one that ends earlier under the limit is dropped; the learner is then
Lagrangian SAC with that limit (docs/SPEC.md, section 13). Episodes are recorded once SAC has started learning (after --learning-starts
random steps); N of each group are picked at evenly spaced positions among the candidates, so
that both groups span the training run; see the file's meta for the rule and the source episodes.

--profile authors collects as the paper's authors' code did (docs/SPEC.md, section 10): their bare
SAC (no warm-up, alpha 0.5, episode ends terminal) trains for --episodes; after every
--demonstrate-every (50) training episodes one episode of the current stochastic policy is
recorded; it is safe when it lasted the horizon, unsafe when shorter. Every demonstration is
kept (theirs all went into the DEFENDER agent's replay buffer and R_task, the lowest per-step
reward, was taken over all of them), each group written in their diversity order (farthest-point
over pairwise FastDTW L1 of the state sequences), so that the first N of a group are the N they
chose: train with `num_demos = N` (their n_demos, 50) to filter with their choice.")]
    Collect(CollectArgs),
    /// How many steps and seconds before a crash Recovery RL's pretrained safety critic passes
    /// eps_risk, on held-out demonstrations.
    RiskHorizon(RiskHorizonArgs),
}

/// Runs a `demos` subcommand.
pub fn run(cmd: DemosCommand) -> Result<()> {
    match cmd {
        DemosCommand::Collect(args) => match args.profile {
            Profile::Spec | Profile::KeepsLearning => spec::collect(&args),
            Profile::Authors => authors::collect(&args),
        },
        DemosCommand::RiskHorizon(args) => risk_horizon::run(&args),
    }
}
