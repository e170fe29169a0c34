//! The flags of `defender train` (`defender train --help`); `commands::train` resolves them over
//! a configuration file.

use std::path::PathBuf;

use clap::Args;
use defender::Mode;
use defender::selection::StrategyChoice;
use defender_rl::Algo;

/// Arguments of `defender train`.
#[derive(Debug, Args)]
#[command(after_help = "Examples:
  defender train --env Hopper-v5 --algo sac --steps 300000 --out runs/hopper-sac-bare
  defender train --env Hopper-v5 --algo sac --strategy MeanDemoW5/MeanDemoW10 --steps 300000 --out runs/hopper-sac-def
  defender train --config my.toml --out runs/x          (flags override the file and fill what it leaves out)
  defender train --out runs/x --resume                  (continue a stopped run)

Without --demos, DEFENDER uses the demonstrations shipped for the task (data/demos/<ENV>.npz).
The run directory gets config.toml, metrics.csv, eval.csv, summary.json, checkpoint/ and a
TensorBoard event file (`tensorboard --logdir`; [log] tensorboard = false: none) (docs/run-directory.md). Ctrl-C, SIGTERM and SIGHUP stop at the end of the current episode with
a checkpoint (exit code 130/143/129); a checkpoint is also written every 2 minutes, so --resume
continues even after a kill -9. A resumed run keeps its configuration: only --steps/--episodes
may extend its budget. Progress: a bar on a terminal, else a `progress:` line a minute
(DEFENDER_PROGRESS_INTERVAL=SECONDS or off).")]
pub struct TrainArgs {
    /// Gymnasium id of the task (see `defender env list`).
    #[arg(long)]
    pub env: Option<String>,
    /// The RL algorithm: sac or td3 [default: sac].
    #[arg(long, value_parser = parse_algo)]
    pub algo: Option<Algo>,
    /// A DEFENDER strategy SAFE/UNSAFE (e.g. MeanDemoW5/MeanDemoW10), or `auto` to choose one from
    /// the demonstrations first (`defender select`); none trains the bare algorithm.
    #[arg(long, value_parser = parse_strategy)]
    pub strategy: Option<StrategyChoice>,
    /// Demonstration set (.npz, SPEC section 8); default: the one shipped for the task.
    #[arg(long)]
    pub demos: Option<PathBuf>,
    /// Demonstrations used per group (the first N safe and the first N unsafe of the file).
    #[arg(long, value_parser = toml_usize)]
    pub num_demos: Option<usize>,
    /// Trajectory elements: states, or state-action pairs.
    #[arg(long, value_parser = parse_mode)]
    pub mode: Option<Mode>,
    /// The reward of a filtered step (default: the lowest per-step reward of the demonstrations).
    #[arg(long, allow_negative_numbers = true)]
    pub r_task: Option<f64>,
    /// Charge the learner, at a filtered step, the violation the filter prevented: the episode's
    /// cost topped up to the episode limit plus one (1 on a crash task); the recorded costs stay
    /// the task's. Needs a learner of costs (--lagrangian, --pid) ([defender] filtered_cost =
    /// "violation"; docs/SPEC.md section 14).
    #[arg(long)]
    pub charge_filtered: bool,
    /// Filter only when the trajectory is clearly closer to the unsafe group: `Unsafe <= (1 - M) *
    /// Safe`, M in [0, 1) ([defender.filter] margin; 0 is SPEC's rule).
    #[arg(long, value_name = "M")]
    pub margin: Option<f64>,
    /// Adapt the margin after every episode so that this share of episodes is filtered
    /// ([defender.filter.budget] share, time constant 100 episodes).
    #[arg(long, value_name = "SHARE")]
    pub filter_budget: Option<f64>,
    /// The agent's own episodes join the demonstrations (its crashes the unsafe group, episodes
    /// that reach the horizon the safe one), at most K per group, the oldest replaced
    /// ([defender.filter.own_episodes] keep).
    #[arg(long, value_name = "K", value_parser = toml_usize)]
    pub own_episodes: Option<usize>,
    /// What decides to end the episode: dtw (the default, SPEC's filter), classifier,
    /// risk-critic (with --recovery: Recovery RL's safety critic), margin (the task's failure
    /// condition tightened by --task-margin) or violation (a cost task's limit passed)
    /// ([defender.filter] trigger; docs/SPEC.md section 15). Without --strategy, a trigger other
    /// than dtw takes the default strategy, which it does not read.
    #[arg(long, value_name = "NAME", value_parser = parse_trigger)]
    pub trigger: Option<defender::TriggerKind>,
    /// The margin trigger's margin M in (0, 1): the episode ends when a state is past 1 - M of
    /// the way from the initial state to the task's failure boundary ([defender.filter]
    /// task_margin).
    #[arg(long, value_name = "M")]
    pub task_margin: Option<f64>,
    /// The classifier trigger's threshold on its probability of a failure within the horizon
    /// ([defender.filter.classifier] threshold; default 0.5).
    #[arg(long, value_name = "P")]
    pub classifier_threshold: Option<f64>,
    /// The classifier trigger's horizon H: a demonstration's step is unsafe when its failure is at
    /// most H steps ahead ([defender.filter.classifier] horizon; default 20).
    #[arg(long, value_name = "H", value_parser = toml_usize)]
    pub classifier_horizon: Option<usize>,
    /// Check every K-th intervention against what would have happened: the simulator copied,
    /// the stopped action run, the policy going on unfiltered to the horizon; written to
    /// interventions.csv ([counterfactual] every; 1 checks them all).
    #[arg(long, value_name = "K", value_parser = toml_u64)]
    pub check_every: Option<u64>,
    /// Episodes of each periodic evaluation (default 5; each keeps its per-episode rows).
    #[arg(long, value_name = "N", value_parser = toml_usize)]
    pub eval_episodes: Option<usize>,
    /// Train DEFENDER's dynamics model on a thread of its own, on another core while the agent
    /// updates: same results bit for bit, less wall time when a core is free
    /// ([defender.dynamics] background = true). The default already when the networks use two
    /// or more threads (DEFENDER_NN_THREADS, else min(2, cores)).
    #[arg(long)]
    pub dynamics_thread: bool,
    /// Train DEFENDER's dynamics model on SPEC section 5's schedule, one gradient step of batch
    /// 256 per real step at lr 3e-4, instead of the default, batch 64 every 2 real steps at lr
    /// 1e-3, 8x cheaper ([defender.dynamics] train_freq = 1, batch_size = 256, learning_rate =
    /// 0.0003; docs/decisions.md).
    #[arg(long)]
    pub dynamics_spec_schedule: bool,
    /// Budget in training episodes.
    #[arg(long, conflicts_with = "steps", value_parser = toml_u64)]
    pub episodes: Option<u64>,
    /// Budget in environment steps.
    #[arg(long, value_parser = toml_u64)]
    pub steps: Option<u64>,
    /// Seed of every random stream of the run.
    #[arg(long, value_parser = toml_u64)]
    pub seed: Option<u64>,
    /// Evaluate the deterministic policy every N steps (0: only at the end).
    #[arg(long, value_parser = toml_u64)]
    pub eval_freq: Option<u64>,
    /// Checkpoint every N training episodes (0: only by time, at the end and on a stop signal).
    #[arg(long, value_parser = toml_u64)]
    pub checkpoint_every: Option<u64>,
    /// Checkpoint at the first episode end N wall-clock seconds after the last one [default: 120;
    /// 0: never by time].
    #[arg(long, value_parser = toml_u64)]
    pub checkpoint_seconds: Option<u64>,
    /// A TOML configuration (the format of a run's config.toml; unknown keys are refused).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// keeps-learning [the default]: a DEFENDER run filters with a margin of 0.02 and its own
    /// episodes joining the demonstrations (50 per group), and its agent also learns from the
    /// demonstrations (replay buffer, SAC with per-row cloning; docs/results-keeps-learning.md);
    /// a bare run is plain SAC/TD3. spec: SPEC.md, the paper's text as written. authors: every
    /// setting in which the authors' code differs (FastDTW L1 over the last 20 steps, ties
    /// executed, demonstrations in the replay buffer with a behaviour-cloning term, SAC without
    /// warm-up at alpha 0.5, episode ends terminal; docs/SPEC.md). Keys the configuration and
    /// flags give win; config.toml lists every setting.
    #[arg(long, value_enum)]
    pub profile: Option<defender_config::profile::Profile>,
    /// Save the training episodes as an episode set (.npz) for `defender ablate`.
    #[arg(long)]
    pub record_episodes: Option<PathBuf>,
    /// Continue the stopped run in --out from its checkpoint (its config.toml is used).
    #[arg(long)]
    pub resume: bool,
    /// The run directory to write.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub safety: super::safety_flags::SafetyFlags,
    /// The demonstrations alone (the default profile's learner without its filter): every
    /// demonstration transition in the replay buffer and, for SAC, per-row behaviour cloning of
    /// weight 1 on the safe demonstrations' rows ([sac] demos_in_replay = true, bc_weight = 1,
    /// bc_form = "per-row"; [td3] demos_in_replay = true). The set is --demos, else the one
    /// shipped for the task.
    #[arg(long, help_heading = "Baselines")]
    pub learn_from_demos: bool,
}

impl TrainArgs {
    /// Whether a trigger flag asks for DEFENDER.
    pub fn wants_trigger(&self) -> bool {
        self.trigger.is_some()
            || self.task_margin.is_some()
            || self.classifier_threshold.is_some()
            || self.classifier_horizon.is_some()
    }

    /// The trigger flags over a `[defender]` section, and the counts of evaluation episodes and
    /// checks over the run.
    pub fn apply_trigger_and_counts(&self, config: &mut defender_config::run_config::RunConfig) {
        if let Some(n) = self.eval_episodes {
            config.eval_episodes = n;
        }
        if let Some(k) = self.check_every {
            config.counterfactual.every = k;
        }
        let Some(filter) = config.defender.as_mut().map(|d| &mut d.filter) else { return };
        if let Some(trigger) = self.trigger {
            filter.trigger = trigger;
        }
        if self.task_margin.is_some() {
            filter.task_margin = self.task_margin;
        }
        if self.classifier_threshold.is_some() || self.classifier_horizon.is_some() {
            let c = filter.classifier.get_or_insert_with(Default::default);
            c.threshold = self.classifier_threshold.unwrap_or(c.threshold);
            c.horizon = self.classifier_horizon.unwrap_or(c.horizon);
        }
    }
}

fn parse_trigger(s: &str) -> Result<defender::TriggerKind, String> {
    s.parse()
}

fn parse_algo(s: &str) -> Result<Algo, String> {
    s.parse().map_err(|_| format!("unknown algorithm '{s}'; expected sac or td3"))
}

fn parse_strategy(s: &str) -> Result<StrategyChoice, String> {
    s.parse().map_err(|e: defender::DefenderError| e.to_string())
}

fn parse_mode(s: &str) -> Result<Mode, String> {
    s.parse().map_err(|e: defender::DefenderError| e.to_string())
}

/// A value of a flag that is written into `config.toml`: TOML integers are 64-bit signed, so a
/// larger one would pass the parser and fail later, naming no flag.
pub fn toml_u64(s: &str) -> Result<u64, String> {
    let v: u64 = s.parse().map_err(|e| format!("{e} (expected a whole number)"))?;
    if i64::try_from(v).is_err() {
        return Err(format!("{v} is too large (at most {}, the largest TOML integer)", i64::MAX));
    }
    Ok(v)
}

/// [`toml_u64`] for a count.
pub fn toml_usize(s: &str) -> Result<usize, String> {
    toml_u64(s).and_then(|v| usize::try_from(v).map_err(|e| e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_written_to_toml_stay_within_its_integers() {
        assert_eq!(toml_u64("9223372036854775807"), Ok(i64::MAX as u64));
        let e = toml_u64("9223372036854775808").unwrap_err();
        assert!(e.contains("too large"), "{e}");
        assert!(toml_u64("-1").is_err() && toml_usize("x").is_err());
    }
}
