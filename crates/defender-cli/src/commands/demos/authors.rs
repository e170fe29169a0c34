//! `defender demos collect --profile authors`: demonstrations as the paper's authors' code made
//! them (`defender::authors_collection`): their bare SAC (the authors' profile's SAC settings)
//! trains for a number of episodes, and after every `--demonstrate-every` of them one episode of
//! the current stochastic policy is recorded.

use anyhow::{Context, Result, bail};
use defender::authors_collection::{AUTHORS_EVERY, AuthorsCollection};
use defender::{EpisodeRecorder, Meta};
use defender_mujoco::MujocoEnv;
use defender_rl::{
    Agent, AlgoConfig, Budget, Env, EpisodeRecord, HookError, Hooks, SacConfig, SeedPurpose, TimeLimit,
    Trainer, TrainerConfig, derive_seed,
};

use super::CollectArgs;
use super::record::{make_env, record_episode, unsafe_rule};
use crate::progress;
use defender::UnsafeRule;
use defender_config::profile::Profile;

/// Their training budget, in episodes (`HyperParams.num_episodes`).
const AUTHORS_EPISODES: u64 = 5000;

/// The SAC of the authors' profile for a bare run: no warm-up, alpha 0.5, episode ends terminal.
fn authors_sac() -> Result<SacConfig> {
    let settings = Profile::Authors.settings("sac", false);
    let table = settings.get("sac").cloned().context("the authors' profile sets no [sac] keys")?;
    table.try_into().context("the authors' profile's [sac] keys")
}

/// Runs the authors' collection.
pub fn collect(args: &CollectArgs) -> Result<()> {
    for (flag, given) in [
        ("--safe", args.safe.is_some()),
        ("--unsafe", args.unsafe_.is_some()),
        ("--max-steps", args.max_steps.is_some()),
        ("--min-steps", args.min_steps.is_some()),
        ("--learning-starts", args.learning_starts.is_some()),
    ] {
        if given {
            bail!(
                "{flag} is not for --profile authors: their collection keeps every demonstration of a run of \
                 --episodes training episodes (their SAC has no warm-up)"
            );
        }
    }
    let episodes = args.episodes.unwrap_or(AUTHORS_EPISODES);
    let every = args.demonstrate_every.unwrap_or(AUTHORS_EVERY);
    if episodes == 0 || every == 0 {
        bail!("--episodes and --demonstrate-every must be >= 1");
    }
    if every > episodes {
        bail!("--demonstrate-every {every} > --episodes {episodes}: no demonstration would be recorded");
    }
    crate::run_dir::check_writable(&args.out).context("--out")?;
    let env = make_env(args)?;
    if unsafe_rule(args, &env)? != UnsafeRule::Crash || args.learner.is_some() {
        bail!(
            "--profile authors collects as the paper's code did, on a crash task with their SAC: {}              needs the spec rule (leave --profile, --episode-cost-limit and --learner out)",
            args.env
        );
    }
    let horizon = env.max_episode_steps().context("the task has no horizon")?;
    let (obs_dim, act_dim) = (env.observation_space().dim(), env.action_space().dim());
    let agent = AlgoConfig::Sac(authors_sac()?).build(obs_dim, act_dim, args.seed)?;
    let eval_env = make_env(args)?;
    let mut config = TrainerConfig::new(args.seed, Budget::Episodes(episodes));
    config.final_eval_episodes = 1;
    let mut trainer = Trainer::new(agent, env, eval_env, config)?;
    let meta = Meta {
        env_id: Some(args.env.clone()),
        obs_dim: Some(obs_dim),
        act_dim: Some(act_dim),
        ..Meta::default()
    };
    let mut hooks = Demonstrator {
        seed: args.seed,
        demo_env: make_env(args)?,
        collection: AuthorsCollection::new(every, horizon, meta, obs_dim, act_dim)?,
        recorder: EpisodeRecorder::new(),
        bar: progress::bar(episodes, "episodes"),
    };
    trainer.run(&mut hooks)?;
    hooks.bar.finish_and_clear();
    let provenance = format!(
        "defender demos collect --profile authors: the authors' bare SAC (seed {}) trained {episodes} episodes \
         ({} steps); after every {every} of them one episode of the stochastic policy was recorded",
        args.seed,
        trainer.total_steps()
    );
    let set = hooks.collection.finish(episodes, provenance).with_context(|| {
        format!(
            "{}: raise --episodes (or lower --demonstrate-every) for demonstrations of both groups",
            args.env
        )
    })?;
    set.save(&args.out).with_context(|| format!("cannot write {}", args.out.display()))?;
    let (safe, unsafe_) = set.group_sizes();
    let r_task = set.min_reward().unwrap_or(f32::NAN);
    say!(
        "{}: {safe} safe and {unsafe_} unsafe demonstrations ({} transitions, lowest reward {r_task}) over \
         {episodes} training episodes -> {}",
        args.env,
        set.transitions(),
        args.out.display()
    );
    say!(
        "each group is in the authors' diversity order: num_demos = N filters with their choice of N; their \
         R_task is the lowest reward of all {} (a run with fewer takes it over those it uses: give r_task = \
         {r_task} to keep theirs)",
        set.len()
    );
    Ok(())
}

/// Records a demonstration of the stochastic policy after every `every`-th training episode.
struct Demonstrator {
    seed: u64,
    demo_env: TimeLimit<MujocoEnv>,
    collection: AuthorsCollection,
    recorder: EpisodeRecorder,
    bar: indicatif::ProgressBar,
}

impl Hooks for Demonstrator {
    fn after_episode(&mut self, record: &EpisodeRecord, agent: &mut dyn Agent) -> Result<(), HookError> {
        self.bar.set_position(record.episode + 1);
        if !self.collection.is_due(record.episode) {
            return Ok(());
        }
        let seed = derive_seed(self.seed, SeedPurpose::Demonstration, record.episode);
        // Their `choose_action` samples the policy: a stochastic episode.
        record_episode(&mut self.demo_env, agent, &mut self.recorder, seed, false, UnsafeRule::Crash)?;
        self.collection.add(&mut self.recorder, record.episode)?;
        let (safe, unsafe_) = self.collection.group_sizes();
        self.bar.set_message(format!(
            "safe {safe} unsafe {unsafe_} (last training return {:.0})",
            record.episode_return
        ));
        Ok(())
    }
}
