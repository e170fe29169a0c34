//! `defender demos collect`: demonstrations as in the paper: train a SAC agent and, after every
//! training episode, record one episode of the current (deterministic) policy. Which episodes
//! become demonstrations, and how N of each group are spread over the run, is the `defender`
//! crate's rule (`defender::collection`); this command drives it with SAC on a MuJoCo task.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use defender::collection::{Candidates, CollectionTarget};
use defender::{EpisodeRecorder, Meta};
use defender_mujoco::MujocoEnv;
use defender_rl::{
    Agent, AlgoConfig, Budget, Env, EpisodeRecord, HookError, Hooks, SacConfig, SeedPurpose, TimeLimit,
    Trainer, TrainerConfig, derive_seed,
};

use crate::progress;
use defender_config::profile::Profile;

/// `defender demos` subcommands.
#[derive(Debug, Subcommand)]
pub enum DemosCommand {
    /// Train SAC and record one episode of the current policy after every training episode.
    #[command(after_help = "Examples:
  defender demos collect --env InvertedDoublePendulum-v5 --out data/demos/InvertedDoublePendulum-v5.npz
  defender demos collect --env Hopper-v5 --safe 50 --unsafe 50 --seed 1 --out hopper-s1.npz
  defender demos collect --profile authors --env Hopper-v5 --episodes 5000 --out hopper-authors.npz

A demonstration is unsafe when the environment terminated it before the horizon (it crashed),
safe otherwise. Episodes are recorded once SAC has started learning (after --learning-starts
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
}

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
    /// Seed of the SAC agent and of every reset.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Where to write the demonstration set (.npz, SPEC section 8).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs a `demos` subcommand.
pub fn run(cmd: DemosCommand) -> Result<()> {
    match cmd {
        DemosCommand::Collect(args) => match args.profile {
            Profile::Spec | Profile::KeepsLearning => collect(&args),
            Profile::Authors => super::demos_authors::collect(&args),
        },
    }
}

/// The task with the horizon `--max-episode-steps` gives (the task's own by default).
pub(crate) fn make_env(args: &CollectArgs) -> Result<TimeLimit<MujocoEnv>> {
    let env = defender_mujoco::make(&args.env)?;
    Ok(match args.max_episode_steps {
        Some(0) => bail!("--max-episode-steps must be >= 1"),
        Some(n) => TimeLimit::new(env.into_inner(), n),
        None => env,
    })
}

/// Records one episode of the agent's policy (deterministic or stochastic) on `env`, reset with
/// `seed`, into `recorder` (left to be finished by the caller); returns whether the environment
/// terminated it.
pub(crate) fn record_episode(
    env: &mut TimeLimit<MujocoEnv>,
    agent: &mut dyn Agent,
    recorder: &mut EpisodeRecorder,
    seed: u64,
    deterministic: bool,
) -> Result<bool> {
    let mut obs = env.reset(Some(seed))?;
    recorder.start(&obs);
    let space = env.action_space().clone();
    let mut action = vec![0.0f32; space.dim()];
    let mut env_action = vec![0.0f64; space.dim()];
    loop {
        agent.act(&obs, deterministic, &mut action)?;
        // [-1, 1] -> the action bounds, as the trainer does.
        space.unscale(&action, &mut env_action);
        let step = env.step(&env_action)?;
        recorder.step(&env_action, step.reward, &step.obs)?;
        if step.done() {
            return Ok(step.terminated);
        }
        obs = step.obs;
    }
}

fn collect(args: &CollectArgs) -> Result<()> {
    for (flag, given) in
        [("--episodes", args.episodes.is_some()), ("--demonstrate-every", args.demonstrate_every.is_some())]
    {
        if given {
            bail!(
                "{flag} is for --profile authors (this rule stops once both groups have enough candidates)"
            );
        }
    }
    let (safe, unsafe_) = (args.safe.unwrap_or(50), args.unsafe_.unwrap_or(50));
    if safe == 0 || unsafe_ == 0 {
        bail!("--safe and --unsafe must be >= 1 (DEFENDER needs both groups)");
    }
    let max_steps = args.max_steps.unwrap_or(1_000_000);
    // A collection trains for up to a million steps: refuse an unwritable --out before that.
    crate::run_dir::check_writable(&args.out).context("--out")?;
    let env = make_env(args)?;
    let (obs_dim, act_dim) = (env.observation_space().dim(), env.action_space().dim());
    let mut sac = SacConfig::default();
    if let Some(n) = args.learning_starts {
        sac.learning_starts = n;
    }
    let learning_starts = sac.learning_starts;
    let agent = AlgoConfig::Sac(sac).build(obs_dim, act_dim, args.seed)?;
    let eval_env = make_env(args)?;
    let mut config = TrainerConfig::new(args.seed, Budget::Steps(max_steps));
    config.final_eval_episodes = 1;
    let mut trainer = Trainer::new(agent, env, eval_env, config)?;
    let pool_meta = Meta {
        env_id: Some(args.env.clone()),
        obs_dim: Some(obs_dim),
        act_dim: Some(act_dim),
        ..Meta::default()
    };
    let target = CollectionTarget { safe, unsafe_, learning_starts, min_steps: args.min_steps.unwrap_or(0) };
    let mut hooks = Collector {
        args,
        target,
        demo_env: make_env(args)?,
        candidates: Candidates::new(target, pool_meta, obs_dim, act_dim)?,
        recorder: EpisodeRecorder::new(),
        total_steps: 0,
        bar: progress::bar(max_steps, "steps"),
    };
    trainer.run(&mut hooks)?;
    hooks.bar.finish_and_clear();
    let steps = trainer.total_steps();
    let provenance = format!(
        "defender demos collect: SAC (seed {}) trained {steps} steps; after every training \
         episode that ended past its {learning_starts} random steps, one episode of the deterministic policy was \
         recorded ({} candidates)",
        args.seed,
        hooks.candidates.len()
    );
    let set = hooks
        .candidates
        .select(steps, provenance)
        .with_context(|| format!("{}: raise --max-steps or ask for fewer demonstrations", args.env))?;
    set.save(&args.out).with_context(|| format!("cannot write {}", args.out.display()))?;
    let (safe, unsafe_) = set.group_sizes();
    say!(
        "{}: {safe} safe and {unsafe_} unsafe demonstrations ({} transitions) from {} candidates over {steps} \
         training steps -> {}",
        args.env,
        set.transitions(),
        hooks.candidates.len(),
        args.out.display()
    );
    Ok(())
}

/// Records a demonstration after every training episode and decides when there are enough.
struct Collector<'a> {
    args: &'a CollectArgs,
    /// The groups' sizes; SAC's first update comes after `learning_starts` steps, no candidate
    /// before it.
    target: CollectionTarget,
    demo_env: TimeLimit<MujocoEnv>,
    candidates: Candidates,
    recorder: EpisodeRecorder,
    total_steps: u64,
    bar: indicatif::ProgressBar,
}

impl Collector<'_> {
    /// One episode of the deterministic policy, recorded into the pool.
    fn demonstrate(&mut self, after_episode: u64, agent: &mut dyn Agent) -> Result<()> {
        let seed = derive_seed(self.args.seed, SeedPurpose::Demonstration, after_episode);
        let terminated = record_episode(&mut self.demo_env, agent, &mut self.recorder, seed, true)?;
        // SPEC section 6: crashed = the environment terminated it before the horizon.
        self.candidates.add(&mut self.recorder, terminated, after_episode)?;
        Ok(())
    }
}

impl Hooks for Collector<'_> {
    fn on_step(&mut self, total_steps: u64) {
        self.total_steps = total_steps;
        self.bar.set_position(total_steps);
    }

    fn after_episode(&mut self, record: &EpisodeRecord, agent: &mut dyn Agent) -> Result<(), HookError> {
        if !self.candidates.is_candidate(record.total_steps) {
            // The untrained policy: the same demonstration every time (`defender::collection`).
            self.bar.set_message(format!(
                "random steps until {} (SAC's learning_starts)",
                self.target.learning_starts
            ));
            return Ok(());
        }
        self.demonstrate(record.episode, agent)?;
        let (safe, unsafe_) = self.candidates.group_sizes();
        self.bar.set_message(format!(
            "safe {safe}/{} unsafe {unsafe_}/{} (last training return {:.0})",
            self.target.safe, self.target.unsafe_, record.episode_return
        ));
        Ok(())
    }

    fn should_stop(&mut self) -> bool {
        self.candidates.enough(self.total_steps)
    }
}
