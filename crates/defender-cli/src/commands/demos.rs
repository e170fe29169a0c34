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

/// `defender demos` subcommands.
#[derive(Debug, Subcommand)]
pub enum DemosCommand {
    /// Train SAC and record one episode of the current policy after every training episode.
    #[command(after_help = "Examples:
  defender demos collect --env InvertedDoublePendulum-v5 --out data/demos/InvertedDoublePendulum-v5.npz
  defender demos collect --env Hopper-v5 --safe 50 --unsafe 50 --seed 1 --out hopper-s1.npz

A demonstration is unsafe when the environment terminated it before the horizon (it crashed),
safe otherwise. Episodes are recorded once SAC has started learning (after --learning-starts
random steps); N of each group are picked at evenly spaced positions among the candidates, so
that both groups span the training run; see the file's meta for the rule and the source episodes.")]
    Collect(CollectArgs),
}

/// Arguments of `defender demos collect`.
#[derive(Debug, Args)]
pub struct CollectArgs {
    /// Gymnasium id of the task.
    #[arg(long)]
    pub env: String,
    /// Safe demonstrations to keep.
    #[arg(long, default_value_t = 50)]
    pub safe: usize,
    /// Unsafe demonstrations to keep.
    #[arg(long = "unsafe", default_value_t = 50)]
    pub unsafe_: usize,
    /// Stop training after this many environment steps even if a group is short (then it fails).
    /// The shipped sets needed 62,898 (InvertedDoublePendulum-v5), 202,389 (Hopper-v5) and
    /// 370,537 (Walker2d-v5) steps with seed 0.
    #[arg(long, default_value_t = 1_000_000)]
    pub max_steps: u64,
    /// Train at least this many steps before stopping (more candidates to spread over).
    #[arg(long, default_value_t = 0)]
    pub min_steps: u64,
    /// SAC's random-action steps before its first update; recording starts after them
    /// [default: SAC's learning_starts, 5000].
    #[arg(long)]
    pub learning_starts: Option<u64>,
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
        DemosCommand::Collect(args) => collect(&args),
    }
}

fn collect(args: &CollectArgs) -> Result<()> {
    if args.safe == 0 || args.unsafe_ == 0 {
        bail!("--safe and --unsafe must be >= 1 (DEFENDER needs both groups)");
    }
    // A collection trains for up to a million steps: refuse an unwritable --out before that.
    crate::run_dir::check_writable(&args.out).context("--out")?;
    let make = || -> Result<TimeLimit<MujocoEnv>> {
        let env = defender_mujoco::make(&args.env)?;
        Ok(match args.max_episode_steps {
            Some(0) => bail!("--max-episode-steps must be >= 1"),
            Some(n) => TimeLimit::new(env.into_inner(), n),
            None => env,
        })
    };
    let env = make()?;
    let (obs_dim, act_dim) = (env.observation_space().dim(), env.action_space().dim());
    let mut sac = SacConfig::default();
    if let Some(n) = args.learning_starts {
        sac.learning_starts = n;
    }
    let learning_starts = sac.learning_starts;
    let agent = AlgoConfig::Sac(sac).build(obs_dim, act_dim, args.seed)?;
    let eval_env = make()?;
    let mut config = TrainerConfig::new(args.seed, Budget::Steps(args.max_steps));
    config.final_eval_episodes = 1;
    let mut trainer = Trainer::new(agent, env, eval_env, config)?;
    let pool_meta = Meta {
        env_id: Some(args.env.clone()),
        obs_dim: Some(obs_dim),
        act_dim: Some(act_dim),
        ..Meta::default()
    };
    let target = CollectionTarget {
        safe: args.safe,
        unsafe_: args.unsafe_,
        learning_starts,
        min_steps: args.min_steps,
    };
    let mut hooks = Collector {
        args,
        learning_starts,
        demo_env: make()?,
        candidates: Candidates::new(target, pool_meta, obs_dim, act_dim)?,
        recorder: EpisodeRecorder::new(),
        action: vec![0.0; act_dim],
        env_action: vec![0.0; act_dim],
        total_steps: 0,
        bar: progress::bar(args.max_steps, "steps"),
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
    println!(
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
    /// SAC's first update comes after this many steps; no candidate before it.
    learning_starts: u64,
    demo_env: TimeLimit<MujocoEnv>,
    candidates: Candidates,
    recorder: EpisodeRecorder,
    action: Vec<f32>,
    env_action: Vec<f64>,
    total_steps: u64,
    bar: indicatif::ProgressBar,
}

impl Collector<'_> {
    /// One episode of the deterministic policy, recorded into the pool.
    fn demonstrate(&mut self, after_episode: u64, agent: &mut dyn Agent) -> Result<()> {
        let seed = derive_seed(self.args.seed, SeedPurpose::Demonstration, after_episode);
        let mut obs = self.demo_env.reset(Some(seed))?;
        self.recorder.start(&obs);
        let space = self.demo_env.action_space().clone();
        loop {
            agent.act(&obs, true, &mut self.action)?;
            // [-1, 1] -> the action bounds, as the trainer does.
            space.unscale(&self.action, &mut self.env_action);
            let step = self.demo_env.step(&self.env_action)?;
            self.recorder.step(&self.env_action, step.reward, &step.obs)?;
            if step.done() {
                // SPEC section 6: crashed = the environment terminated it before the horizon.
                self.candidates.add(&mut self.recorder, step.terminated, after_episode)?;
                return Ok(());
            }
            obs = step.obs;
        }
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
            self.bar
                .set_message(format!("random steps until {} (SAC's learning_starts)", self.learning_starts));
            return Ok(());
        }
        self.demonstrate(record.episode, agent)?;
        let (safe, unsafe_) = self.candidates.group_sizes();
        self.bar.set_message(format!(
            "safe {safe}/{} unsafe {unsafe_}/{} (last training return {:.0})",
            self.args.safe, self.args.unsafe_, record.episode_return
        ));
        Ok(())
    }

    fn should_stop(&mut self) -> bool {
        self.candidates.enough(self.total_steps)
    }
}
