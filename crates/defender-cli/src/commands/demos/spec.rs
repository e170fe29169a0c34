//! SPEC's rule: train a SAC agent and, after every training episode, record one episode of the
//! current (deterministic) policy. Which episodes become demonstrations, and how N of each group
//! are spread over the run, is the `defender` crate's rule (`defender::collection`); this drives it
//! with SAC on a MuJoCo task.

use anyhow::{Context, Result, bail};
use defender::collection::{Candidates, CollectionTarget};
use defender::{EpisodeRecorder, Meta};
use defender_mujoco::MujocoEnv;
use defender_rl::{
    Agent, AlgoConfig, Budget, Env, EpisodeRecord, HookError, Hooks, SacConfig, SeedPurpose, TimeLimit,
    Trainer, TrainerConfig, derive_seed,
};

use super::record::{make_env, record_episode, unsafe_rule};
use super::{CollectArgs, Learner};
use crate::progress;
use defender::UnsafeRule;

pub(super) fn collect(args: &CollectArgs) -> Result<()> {
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
    let rule = unsafe_rule(args, &env)?;
    let (obs_dim, act_dim) = (env.observation_space().dim(), env.action_space().dim());
    let mut sac = SacConfig::default();
    if let Some(n) = args.learning_starts {
        sac.learning_starts = n;
    }
    let learning_starts = sac.learning_starts;
    let learner = args.learner.unwrap_or(match rule {
        UnsafeRule::Crash => Learner::Sac,
        UnsafeRule::CostAbove(_) => Learner::Lagrangian,
    });
    let agent: Box<dyn Agent> = match (learner, rule) {
        (Learner::Sac, _) => AlgoConfig::Sac(sac).build(obs_dim, act_dim, args.seed)?,
        (Learner::Lagrangian, UnsafeRule::CostAbove(limit)) => {
            let lagrangian =
                defender_rl::safety::LagrangianConfig { cost_limit: limit, ..Default::default() };
            Box::new(defender_rl::safety::lagrangian::LagrangianSac::new(
                sac, lagrangian, obs_dim, act_dim, args.seed,
            )?)
        }
        (Learner::Lagrangian, UnsafeRule::Crash) => bail!(
            "--learner lagrangian is for a task with a per-step cost; {} counts crashes (use sac)",
            args.env
        ),
    };
    let eval_env = make_env(args)?;
    let mut config = TrainerConfig::new(args.seed, Budget::Steps(max_steps));
    config.final_eval_episodes = 1;
    let mut trainer = Trainer::new(agent, env, eval_env, config)?;
    let mut pool_meta = Meta {
        env_id: Some(args.env.clone()),
        obs_dim: Some(obs_dim),
        act_dim: Some(act_dim),
        ..Meta::default()
    };
    if let UnsafeRule::CostAbove(limit) = rule {
        // What makes these demonstrations unsafe: a run checks it against its own rule.
        pool_meta.extra.insert(defender::EPISODE_COST_LIMIT_KEY.into(), limit.into());
    }
    let target = CollectionTarget { safe, unsafe_, learning_starts, min_steps: args.min_steps.unwrap_or(0) };
    let mut hooks = Collector {
        args,
        target,
        rule,
        demo_env: make_env(args)?,
        candidates: Candidates::new(target, pool_meta, obs_dim, act_dim)?,
        recorder: EpisodeRecorder::new(),
        total_steps: 0,
        bar: progress::bar(max_steps, "steps"),
    };
    trainer.run(&mut hooks)?;
    hooks.bar.finish_and_clear();
    let steps = trainer.total_steps();
    let learner_name = match learner {
        Learner::Sac => "SAC".to_string(),
        Learner::Lagrangian => "Lagrangian SAC".to_string(),
    };
    let labels = match rule {
        UnsafeRule::Crash => "unsafe: terminated before the horizon".to_string(),
        UnsafeRule::CostAbove(l) => format!(
            "unsafe: cut on the step where the episode cost passed {l}; safe: reached the horizon with \
             cost <= {l}; episodes that ended early under the limit were dropped"
        ),
    };
    let provenance = format!(
        "defender demos collect: {learner_name} (seed {}) trained {steps} steps; after every training \
         episode that ended past its {learning_starts} random steps, one episode of the deterministic policy was \
         recorded ({} candidates; {labels})",
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
    /// What makes a recorded episode unsafe.
    rule: UnsafeRule,
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
        let label = record_episode(&mut self.demo_env, agent, &mut self.recorder, seed, true, self.rule)?;
        // SPEC sections 6 and 13: unsafe = crashed, or past the episode cost limit on a cost task.
        if let Some(unsafe_) = label {
            self.candidates.add(&mut self.recorder, unsafe_, after_episode)?;
        }
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
