//! `defender train`: SAC or TD3 on a MuJoCo task, bare or with DEFENDER, into a run directory.

use std::path::Path;

use anyhow::{Context, Result, bail};
use defender_report::{OutcomeCounts, Summary};
use defender_rl::{
    Agent, Algo, Budget, Env, EpisodeRecord, EvalRecord, HookError, Hooks, RunEnd, Trainer, TrainerConfig,
    Transition,
};

use crate::eval_line::eval_line;
use crate::progress;
use crate::run_dir::{self, RunDir};
use crate::setup::{self, TrainingRecorder};
use crate::signals::{StopRequest, Stopped};
use crate::tensorboard::board::{self, TrainingBoard};
use crate::update_log::{self, UpdateLog};
use defender_config::resume;
use defender_config::run_config::{
    DefenderSection, RunConfig, default_checkpoint_seconds, five, read_config, with_profile,
};

pub use super::train_args::TrainArgs;

/// Resolves flags over an optional configuration file: a flag wins over the file, and fills
/// what a partial file leaves out (`env`, `algo`).
fn resolve(args: &TrainArgs) -> Result<RunConfig> {
    let config = match &args.config {
        Some(path) => read_partial_config(path, args)?,
        None => RunConfig {
            profile: Default::default(),
            demos: None,
            demos_sha256: None,
            env: args
                .env
                .clone()
                .context("--env is required (e.g. --env Hopper-v5; see `defender env list`)")?,
            algo: args.algo.unwrap_or(Algo::Sac),
            seed: 0,
            total_steps: 0,
            total_episodes: 0,
            eval_freq: 0,
            eval_episodes: five(),
            checkpoint_every_episodes: 0,
            checkpoint_every_seconds: default_checkpoint_seconds(),
            record_episodes: None,
            defender: None,
            sac: None,
            td3: None,
            safety: None,
            log: Default::default(),
            counterfactual: Default::default(),
        },
    };
    let config = apply_flags(config, args)?;
    // The profile again, now that the flags may have set the algorithm or a strategy: it fills
    // what the file (or nothing) gave, never a key the file set.
    let mut given = match &args.config {
        Some(path) => toml::from_str(&defender_io::read_input_to_string(path)?)?,
        None => toml::Table::new(),
    };
    if let Some(profile) = args.profile {
        given.insert("profile".into(), profile.name().into());
    }
    given_by_flags(&mut given, args, config.algo);
    defender_config::profile::default_for_new_run(&mut given);
    let written = toml::Table::try_from(&config)?;
    let config = with_profile(&written, &given)?;
    config.validate()?;
    Ok(config)
}

/// Marks the settings that flags give as given, so that a profile fills around them and never
/// replaces them (`--margin 0` under `keeps-learning` is SPEC's decision rule).
fn given_by_flags(given: &mut toml::Table, args: &TrainArgs, algo: Algo) {
    if args.learn_from_demos {
        // The learner `--learn-from-demos` names, whatever a profile would fill (the authors'
        // cloning form).
        merge_demos_learner(given, algo);
    }
    let mut filter = toml::Table::new();
    if let Some(m) = args.margin {
        filter.insert("margin".into(), m.into());
    }
    if args.filter_budget.is_some() {
        filter.insert("budget".into(), toml::Table::new().into());
    }
    if let Some(keep) = args.own_episodes {
        let mut own = toml::Table::new();
        own.insert("keep".into(), i64::try_from(keep).unwrap_or(i64::MAX).into());
        filter.insert("own_episodes".into(), own.into());
    }
    if filter.is_empty() {
        return;
    }
    let section = given.entry("defender").or_insert_with(|| toml::Table::new().into());
    if let Some(section) = section.as_table_mut() {
        let into = section.entry("filter").or_insert_with(|| toml::Table::new().into());
        if let Some(into) = into.as_table_mut() {
            into.extend(filter);
        }
    }
}

/// A `--config` file with the keys it leaves out that flags give (`env` from `--env`, `algo`
/// from `--algo`, else `sac`) filled in before it is read, so that `--config base.toml --env
/// Hopper-v5` works; flags then override the rest ([`apply_flags`]).
fn read_partial_config(path: &Path, args: &TrainArgs) -> Result<RunConfig> {
    let text =
        defender_io::read_input_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut table: toml::Table = toml::from_str(&text)
        .with_context(|| format!("{}: not a valid run configuration", path.display()))?;
    if !table.contains_key("env") {
        let env = args.env.clone().with_context(|| {
            format!("{}: no `env`; add env = \"Hopper-v5\" to the file or give --env", path.display())
        })?;
        table.insert("env".into(), env.into());
    }
    if !table.contains_key("algo") {
        table.insert("algo".into(), args.algo.unwrap_or(Algo::Sac).as_str().into());
    }
    table.try_into().with_context(|| format!("{}: not a valid run configuration", path.display()))
}

/// Applies the command's flags over `config`.
fn apply_flags(mut config: RunConfig, args: &TrainArgs) -> Result<RunConfig> {
    if let Some(env) = &args.env {
        config.env.clone_from(env);
    }
    if let Some(algo) = args.algo {
        config.algo = algo;
    }
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    if let Some(steps) = args.steps {
        (config.total_steps, config.total_episodes) = (steps, 0);
    }
    if let Some(episodes) = args.episodes {
        (config.total_steps, config.total_episodes) = (0, episodes);
    }
    if let Some(f) = args.eval_freq {
        config.eval_freq = f;
    }
    if let Some(c) = args.checkpoint_every {
        config.checkpoint_every_episodes = c;
    }
    if let Some(c) = args.checkpoint_seconds {
        config.checkpoint_every_seconds = c;
    }
    if args.record_episodes.is_some() {
        config.record_episodes.clone_from(&args.record_episodes);
    }
    args.safety.apply(&mut config)?;
    let wants_defender = args.strategy.is_some()
        || (args.demos.is_some() && !args.learn_from_demos)
        || args.num_demos.is_some()
        || args.mode.is_some()
        || args.r_task.is_some()
        || args.charge_filtered
        || args.margin.is_some()
        || args.filter_budget.is_some()
        || args.own_episodes.is_some()
        || args.dynamics_thread
        || args.dynamics_spec_schedule;
    if args.wants_trigger() && config.defender.is_none() {
        // A trigger other than DTW reads no strategy; the default keeps the section valid.
        let strategy = args.strategy.unwrap_or(defender::selection::StrategyChoice::Fixed(
            defender::DefenderConfig::default().strategy,
        ));
        config.defender = Some(DefenderSection::new(strategy));
    }
    if wants_defender && config.defender.is_none() {
        let strategy = args.strategy.context(
            "--demos, --num-demos, --mode, --r-task, --charge-filtered, --margin, --filter-budget, --own-episodes, \
             --dynamics-thread and --dynamics-spec-schedule configure DEFENDER: give --strategy \
             SAFE/UNSAFE too (or, for --demos, --learn-from-demos: the demonstrations without the filter)",
        )?;
        config.defender = Some(DefenderSection::new(strategy));
    }
    args.apply_trigger_and_counts(&mut config);
    if let Some(section) = &mut config.defender {
        apply_defender_flags(section, args);
    } else if args.learn_from_demos && args.demos.is_some() {
        // Without a filter the set is the run's top-level `demos`, as Recovery RL's.
        config.demos.clone_from(&args.demos);
    }
    match config.algo {
        Algo::Sac => {
            config.sac.get_or_insert_with(Default::default);
            config.td3 = None;
        }
        Algo::Td3 => {
            config.td3.get_or_insert_with(Default::default);
            config.sac = None;
        }
    }
    if args.learn_from_demos {
        let mut table = toml::Table::try_from(&config)?;
        merge_demos_learner(&mut table, config.algo);
        config = table.try_into()?;
    }
    config.budget()?;
    Ok(config)
}

/// Sets the default profile's learner keys (`profile::demos_learner`) in the `[sac]` or `[td3]`
/// section of `table`, a run configuration as TOML.
fn merge_demos_learner(table: &mut toml::Table, algo: Algo) {
    let section = table.entry(algo.as_str()).or_insert_with(|| toml::Table::new().into());
    if let Some(section) = section.as_table_mut() {
        section.extend(defender_config::profile::demos_learner(algo.as_str()));
    }
}

/// Applies the flags that configure DEFENDER over a `[defender]` section.
fn apply_defender_flags(section: &mut DefenderSection, args: &TrainArgs) {
    if let Some(choice) = args.strategy {
        section.strategy = choice;
        section.selection = None;
    }
    if let Some(mode) = args.mode {
        section.mode = mode;
    }
    if args.r_task.is_some() {
        section.r_task = args.r_task;
    }
    if args.charge_filtered {
        section.filtered_cost = defender::FilteredCost::Violation;
    }
    if args.num_demos.is_some() {
        section.num_demos = args.num_demos;
    }
    if args.demos.is_some() {
        section.demos.clone_from(&args.demos);
    }
    if let Some(m) = args.margin {
        section.filter.margin = m;
    }
    if let Some(share) = args.filter_budget {
        let episodes = section.filter.budget.map_or(100, |b| b.episodes);
        section.filter.budget = Some(defender::Budget { share, episodes });
    }
    if let Some(keep) = args.own_episodes {
        section.filter.own_episodes = Some(defender::OwnEpisodes { keep });
    }
    if args.dynamics_thread {
        section.dynamics.background = true;
    }
    if args.dynamics_spec_schedule {
        let spec = defender::DynamicsConfig::spec_schedule();
        let d = &mut section.dynamics;
        (d.train_freq, d.gradient_steps, d.batch_size, d.learning_rate) =
            (spec.train_freq, spec.gradient_steps, spec.batch_size, spec.learning_rate);
    }
}

/// Runs `defender train`.
pub fn run(args: TrainArgs) -> Result<()> {
    let stop = StopRequest::install()?;
    // A new run is resolved, and what it reads and writes checked, before its directory exists.
    let requested = if args.resume { None } else { Some(crate::run_inputs::check(resolve(&args)?, &args)?) };
    let _lock = run_dir::claim(&args.out)?;
    let checkpoint_dir = args.out.join("checkpoint");
    let has_checkpoint = defender_io::resolve_dir(&checkpoint_dir).is_some();
    let mut config = if args.resume {
        crate::run_inputs::check(resumed_config(&args)?, &args)?
    } else {
        if has_checkpoint || args.out.join("summary.json").exists() {
            bail!(
                "{} already holds a run; use --resume to continue it, or another --out",
                args.out.display()
            );
        }
        requested.map_or_else(|| resolve(&args), Ok)?
    };
    let resuming = args.resume && has_checkpoint;
    if args.resume && !has_checkpoint {
        crate::resumable::restart_or_refuse(&args.out, &config)?;
    }
    for warning in defender_config::inert::warnings(&config) {
        note!("warning: {warning}");
    }
    let built = setup::build(&config)?;
    // What was resolved (R_task, the demonstrations, an automatic strategy) is what config.toml
    // records.
    config.defender = built.defender;
    if let Some((path, sha256)) = built.replay_demos {
        (config.demos, config.demos_sha256) = (Some(path), Some(sha256));
    }
    if let Some(path) = &config.record_episodes {
        run_dir::check_writable(path).context("--record-episodes")?;
    }
    let recorder = match &config.record_episodes {
        Some(_) => Some(TrainingRecorder::new(
            &config.env,
            built.env.observation_space().dim(),
            built.env.action_space().dim(),
            format!("training episodes of `defender train` ({} seed {})", config.algo.as_str(), config.seed),
        )?),
        None => None,
    };
    let budget = config.budget()?;
    let mut trainer_config = TrainerConfig::new(config.seed, budget);
    trainer_config.eval_freq = config.eval_freq;
    trainer_config.eval_episodes = config.eval_episodes;
    trainer_config.checkpoint_every_episodes = config.checkpoint_every_episodes;
    trainer_config.checkpoint_every_seconds = config.checkpoint_every_seconds;
    trainer_config.counterfactual = config.counterfactual;
    // A cost task's failure is passing its limit (the run's, resolved by setup), not a fall.
    trainer_config.counterfactual.cost_limit = config.defender.as_ref().and_then(|d| d.episode_cost_limit);
    if config.defender.as_ref().is_some_and(|d| d.filtered_cost == defender::FilteredCost::Continuation) {
        trainer_config.counterfactual.charge_max = config.safety.as_ref().and_then(|s| s.cost_max());
    }

    let mut trainer = Trainer::new(built.agent, built.env, built.eval_env, trainer_config)?
        .with_checkpoint_dir(&checkpoint_dir);
    let run_dir = if resuming {
        RunDir::reopen(&args.out, built.dynamics.is_some())?
    } else {
        RunDir::create(&args.out, &[], &[], 0, built.dynamics.is_some())?
    };
    let mut hooks = TrainHooks::new(run_dir, &config, budget, stop.clone(), recorder, built.dynamics);
    hooks.costs = built.costs;
    if resuming {
        trainer.resume(&checkpoint_dir, &mut hooks)?;
        if trainer.config().budget != budget {
            trainer.set_budget(budget).context("--resume")?;
        }
        hooks.restart(trainer.episodes(), trainer.evaluations(), trainer.total_steps())?;
    } else if config.log.tensorboard {
        let r_task = config.defender.as_ref().and_then(|d| d.r_task);
        hooks.board = Some(TrainingBoard::create(&args.out, hooks.costs.clone(), r_task)?);
    }
    hooks.run_dir.write_config(&config)?;
    hooks.write_summary(&trainer, None)?;

    let end = trainer.run(&mut hooks)?;
    hooks.bar.finish_and_clear();
    if let Some(board) = &mut hooks.board {
        board.flush()?;
    }
    let final_eval = match &end {
        RunEnd::Complete(eval) => Some(eval.clone()),
        RunEnd::Stopped => None,
    };
    let summary = hooks.write_summary(&trainer, final_eval.as_ref())?;
    if let RunEnd::Complete(_) = end {
        let actor = args.out.join("actor.safetensors");
        trainer.agent().save_actor(&actor).with_context(|| format!("cannot save {}", actor.display()))?;
        if let (Some(path), Some(recorder)) = (&config.record_episodes, hooks.recorder.take()) {
            recorder.save(path)?;
            note!("recorded {} training episodes into {}", recorder.len(), path.display());
        }
    }
    print_summary(&args.out, &summary, &config, trainer.evaluations(), matches!(end, RunEnd::Stopped));
    if config.defender.is_some() {
        say!("{}", crate::intervention_line::line(trainer.episodes(), trainer.interventions()));
    }
    match (&end, stop.exit_code()) {
        (RunEnd::Stopped, Some(code)) => Err(Stopped { code }.into()),
        _ => Ok(()),
    }
}

/// The configuration of a run continued with `--resume`: its `config.toml`, with a larger
/// budget if one is given; any other flag that would change it is refused.
fn resumed_config(args: &TrainArgs) -> Result<RunConfig> {
    let path = args.out.join("config.toml");
    let saved = read_config(&path).with_context(|| format!("--resume needs {}", path.display()))?;
    // A `--config` file is read as a new run's request is (its profile, or the default for new
    // runs, filling what it leaves out), so that the file the run started from resumes it.
    let requested = match &args.config {
        Some(_) => resolve(args)?,
        None => apply_flags(saved.clone(), args)?,
    }
    .keeping_automatic_choice_of(&saved);
    resume::refuse_changes(&args.out, &saved, &requested)?;
    let mut config = saved;
    config.total_steps = requested.total_steps;
    config.total_episodes = requested.total_episodes;
    Ok(config)
}

/// `config`: for the run's `[safety]` baseline and whether its learner takes the demonstrations,
/// which `summary.json` does not record, so that a penalty, Lagrangian, recovery or
/// demonstrations-alone run is not called bare.
fn print_summary(out: &Path, s: &Summary, config: &RunConfig, evals: &[EvalRecord], stopped: bool) {
    let acc = s.acc_reward.map_or("-".to_string(), |v| format!("{v:.1}"));
    let demos = config.algo_config().demos_in_replay();
    // A trigger other than DTW reads no strategy: the line names the trigger instead.
    let trigger = config.defender.as_ref().map(|d| d.filter.trigger).filter(|t| !t.is_dtw());
    let strategy = s.strategy.map(|st| trigger.map_or(st.to_string(), |t| format!("trigger {}", t.as_str())));
    let what = match (strategy, config.safety.as_ref().map(defender_rl::SafetyConfig::method)) {
        (None, None) if demos => "learning from the demonstrations".to_string(),
        (None, None) => "bare".to_string(),
        (None, Some(method)) if demos => format!("{method} + learning from the demonstrations"),
        (None, Some(method)) => method.to_string(),
        (Some(st), None) => format!("DEFENDER {st}"),
        (Some(st), Some(method)) => format!("DEFENDER {st} + {method}"),
    };
    // A task with an episode cost limit (a velocity task) is judged by its cost: the training cost,
    // per environment step (a filtered step is not one) and per episode. Its terminated episodes
    // are falls, which are not its violations.
    let safety = match s.episode_cost_limit {
        Some(limit) => {
            let v = &s.violations;
            let per_episode = if s.episodes == 0 { 0.0 } else { v.cost / s.episodes as f64 };
            format!(
                "training cost {:.0} ({:.3} per env step, {per_episode:.1} per episode; limit {limit} an episode), falls {:.1}%",
                v.cost, v.cost_rate, s.crash_pct
            )
        }
        None => format!("crash {:.1}%", s.crash_pct),
    };
    say!(
        "{} {} {what} seed {}: {} steps, {} episodes, Acc Reward {acc}, {safety}, filtered {:.1}%, {:.0} steps/s, {:.1}s",
        s.env,
        s.algo,
        s.seed,
        s.steps,
        s.episodes,
        s.filtered_pct,
        s.steps_per_second,
        s.wall_seconds
    );
    if let Some(line) = eval_line(evals, s.episode_cost_limit) {
        say!("{line}");
    }
    if stopped {
        say!("stopped; continue with: defender train --out {} --resume", out.display());
    } else {
        say!("run directory: {}", out.display());
    }
}

/// Writes the run directory as training goes, draws the progress bar, and stops on Ctrl-C.
struct TrainHooks {
    run_dir: RunDir,
    config: RunConfig,
    bar: indicatif::ProgressBar,
    by_steps: bool,
    stop: StopRequest,
    /// The episodes so far, for the progress line.
    counts: OutcomeCounts,
    recorder: Option<TrainingRecorder>,
    updates: UpdateLog,
    dynamics: Option<defender::DynamicsHandle>,
    /// The TensorBoard event file (none with `[log] tensorboard = false`).
    board: Option<TrainingBoard>,
    /// What the checkpoint being resumed recorded of the event file.
    board_saved: Option<board::Saved>,
    costs: Option<crate::cost_meter::SharedCosts>,
    error: Option<anyhow::Error>,
}

impl TrainHooks {
    fn new(
        run_dir: RunDir,
        config: &RunConfig,
        budget: Budget,
        stop: StopRequest,
        recorder: Option<TrainingRecorder>,
        dynamics: Option<defender::DynamicsHandle>,
    ) -> Self {
        let (total, unit, by_steps) = match budget {
            Budget::Steps(s) => (s, "steps", true),
            Budget::Episodes(e) => (e, "episodes", false),
        };
        Self {
            run_dir,
            config: config.clone(),
            bar: progress::bar(total, unit),
            by_steps,
            stop,
            counts: OutcomeCounts::default(),
            recorder,
            updates: UpdateLog::default(),
            dynamics,
            board: None,
            board_saved: None,
            costs: None,
            error: None,
        }
    }

    /// After a resume: the files restart from the checkpoint's records.
    fn restart(&mut self, episodes: &[EpisodeRecord], evals: &[EvalRecord], steps: u64) -> Result<()> {
        self.run_dir = RunDir::create(self.run_dir.root(), episodes, evals, steps, self.dynamics.is_some())?;
        if self.config.log.tensorboard {
            let r_task = self.config.defender.as_ref().and_then(|d| d.r_task);
            self.board = Some(TrainingBoard::resume(
                self.run_dir.root(),
                self.board_saved.as_ref(),
                episodes,
                evals,
                steps,
                self.costs.clone(),
                r_task,
            )?);
        }
        for r in episodes {
            self.counts.add(r.outcome());
        }
        self.bar.set_position(if self.by_steps { steps } else { episodes.len() as u64 });
        Ok(())
    }

    fn write_summary<A: Agent, E: Env, V: Env>(
        &self,
        trainer: &Trainer<A, E, V>,
        final_eval: Option<&EvalRecord>,
    ) -> Result<Summary> {
        let defender = self.config.defender.as_ref();
        let mut summary = Summary {
            env: self.config.env.clone(),
            algo: self.config.algo,
            seed: self.config.seed,
            // `auto` is resolved before the run is built: the summary names the strategy used.
            strategy: defender.and_then(|d| d.strategy.fixed()),
            mode: defender.map(|d| d.mode),
            acc_reward: final_eval.map(|e| e.mean_return),
            crash_pct: 0.0,
            filtered_pct: 0.0,
            episodes: 0,
            steps: trainer.total_steps(),
            // A filtered step always ends its episode: one per filtered episode.
            filtered_steps: self.counts.filtered,
            wall_seconds: trainer.wall_seconds(),
            steps_per_second: 0.0,
            complete: final_eval.is_some(),
            selection: defender.and_then(|d| d.selection.clone()),
            violations: Default::default(),
            // The report reads a task's cost measures against it. The run's environment was made
            // from the same registry, so the id is known; were it not, the run has no limit.
            episode_cost_limit: defender_mujoco::Task::from_id(&self.config.env)
                .ok()
                .and_then(|t| t.episode_cost_limit()),
        };
        summary.count(trainer.episodes().iter().map(|e| (e.outcome(), e.cost())));
        self.run_dir.write_summary(&summary)?;
        Ok(summary)
    }
}

impl Hooks for TrainHooks {
    fn on_update(&mut self, total_steps: u64, stats: &defender_rl::UpdateStats) {
        if let Some(row) = self.updates.add(total_steps, stats)
            && self.error.is_none()
        {
            // Hooks of a step cannot fail; the error stops the run at the episode's end.
            self.error = self.run_dir.append_updates(&row.to_csv()).err();
            if let (Some(board), None) = (&mut self.board, &self.error) {
                self.error = board.updates(&row).err();
            }
        }
    }

    fn on_step(&mut self, total_steps: u64) {
        if self.by_steps {
            self.bar.set_position(total_steps);
        }
        if self.error.is_some() || !total_steps.is_multiple_of(update_log::EVERY) {
            return;
        }
        // Only at a row: a model trained on its own thread is waited for there.
        // Hooks of a step cannot fail; the error stops the run at the episode's end.
        let row = match &self.dynamics {
            Some(handle) => match handle.read(|model| update_log::dynamics_row(total_steps, model)) {
                Ok(row) => row,
                Err(e) => {
                    self.error = Some(e.into());
                    return;
                }
            },
            None => None,
        };
        if let Some(row) = &row {
            self.error = self.run_dir.append_dynamics(&row.to_csv()).err();
        }
        if let (Some(board), None) = (&mut self.board, &self.error) {
            self.error = board.window(total_steps, row.as_ref()).err();
        }
    }

    fn on_transition(&mut self, transition: &Transition<'_>, env_action: &[f64], task_cost: f64) {
        if let (Some(recorder), None) = (&mut self.recorder, &self.error) {
            // Hooks of a step cannot fail; the error stops the run at the episode's end.
            self.error = recorder.transition(transition, env_action, task_cost).err();
        }
    }

    fn on_episode_end(&mut self, record: &EpisodeRecord) -> Result<(), HookError> {
        if let Some(error) = self.error.take() {
            return Err(error.into());
        }
        self.counts.add(record.outcome());
        self.run_dir.append_episode(record)?;
        if let Some(board) = &mut self.board {
            board.episode(record)?;
        }
        if let Some(recorder) = &mut self.recorder {
            recorder.end_episode(record)?;
        }
        if !self.by_steps {
            self.bar.set_position(self.counts.episodes);
        }
        self.bar.set_message(format!(
            "ep {} return {:.0} crash {:.1}% filtered {:.1}%",
            record.episode,
            record.episode_return,
            self.counts.crash_pct(),
            self.counts.filtered_pct()
        ));
        Ok(())
    }

    fn on_intervention(&mut self, record: &defender_rl::InterventionRecord) -> Result<(), HookError> {
        Ok(self.run_dir.append_intervention(record)?)
    }

    fn on_evaluation(&mut self, record: &EvalRecord) -> Result<(), HookError> {
        self.run_dir.append_eval(record)?;
        if let Some(board) = &mut self.board {
            board.evaluation(record)?;
        }
        Ok(())
    }

    fn on_checkpoint(&mut self, dir: &Path) -> Result<(), HookError> {
        let pinned = toml::to_string_pretty(&self.config).map_err(anyhow::Error::from)?;
        defender_io::write_bytes(&dir.join(resume::PINNED_CONFIG_FILE), pinned.as_bytes())
            .map_err(|(path, e)| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
        let updates = serde_json::to_vec(&self.updates).map_err(anyhow::Error::from)?;
        defender_io::write_bytes(&dir.join(update_log::CHECKPOINT_FILE), &updates)
            .map_err(|(path, e)| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
        if let Some(recorder) = &self.recorder {
            recorder.save_checkpoint(dir)?;
        }
        if let Some(board) = &mut self.board {
            board.save(dir)?;
        }
        Ok(())
    }

    fn on_resume(&mut self, dir: &Path) -> Result<(), HookError> {
        resume::check_pinned(dir, &self.config)?;
        let path = dir.join(update_log::CHECKPOINT_FILE);
        if path.exists() {
            let text =
                std::fs::read(&path).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
            self.updates = serde_json::from_slice(&text)
                .map_err(|e| anyhow::anyhow!("{}: not an update log: {e}", path.display()))?;
        }
        if let Some(recorder) = &mut self.recorder {
            recorder.load_checkpoint(dir)?;
        }
        self.board_saved = TrainingBoard::load(dir)?;
        Ok(())
    }

    fn should_stop(&mut self) -> bool {
        self.stop.is_requested()
    }
}
