//! The off-policy training loop: any [`Agent`] on any [`Env`], with periodic deterministic
//! evaluation on a separate environment, hooks, and checkpoints at episode boundaries.
//!
//! ```text
//! for each episode e (until the budget):
//!     obs = env.reset(seed = derive(run seed, e))        # no env RNG state to checkpoint
//!     until the episode ends (or the step budget runs out):
//!         a = agent.act(obs)                             # in [-1, 1]
//!         step = env.step(low + (a + 1) / 2 (high - low))
//!         agent.observe(obs, a, r, step.obs, terminated, truncated); agent.update()
//!         every eval_freq steps: evaluate the deterministic policy on eval_env (and, when env
//!             lends a shield, the same episodes shielded: crate::evaluation)
//!     record the episode; hooks.on_episode_end; maybe checkpoint; maybe stop
//! final evaluation (10 episodes)
//! ```
//!
//! A step budget ends the run exactly at `total_steps`; an episode cut short by the budget is
//! not recorded (as SB3's `Monitor`, which only logs finished episodes).

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::agent::{Agent, UpdateStats};
use crate::checkpoint::{read_json, resolve, write_atomic, write_json};
use crate::counterfactual::{CheckConfig, InterventionRecord, check};
use crate::env::{Env, Step};
use crate::error::RlError;
use crate::evaluation::{EvalRecord, Evaluator};
use crate::replay::Transition;
use crate::seed::{SeedPurpose, derive_seed};
use crate::space::BoxSpace;

/// How long to train.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Budget {
    /// This many environment steps (the run stops mid-episode if need be).
    Steps(u64),
    /// This many complete training episodes.
    Episodes(u64),
}

impl std::fmt::Display for Budget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Budget::Steps(n) => write!(f, "{n} steps"),
            Budget::Episodes(n) => write!(f, "{n} episodes"),
        }
    }
}

/// Trainer settings (the algorithm's are in its own config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainerConfig {
    /// The run's seed: every random stream (weights, sampling, resets) derives from it.
    pub seed: u64,
    /// How long to train.
    pub budget: Budget,
    /// Evaluate every this many environment steps (0: only the final evaluation).
    #[serde(default)]
    pub eval_freq: u64,
    /// Episodes per periodic evaluation.
    #[serde(default = "default_eval_episodes")]
    pub eval_episodes: usize,
    /// Episodes of the final evaluation (SPEC 6: 10 gives Acc Reward).
    #[serde(default = "default_final_eval_episodes")]
    pub final_eval_episodes: usize,
    /// Write a checkpoint every this many training episodes (0: only at the end and on stop).
    /// Needs a checkpoint directory ([`Trainer::with_checkpoint_dir`]).
    #[serde(default)]
    pub checkpoint_every_episodes: u64,
    /// Also write a checkpoint at the first episode end after this many wall-clock seconds since
    /// the last one (0: never by time), so that a kill -9 loses at most that much work.
    #[serde(default)]
    pub checkpoint_every_seconds: u64,
    /// The check of interventions against what would have happened (crate::counterfactual).
    #[serde(default, skip_serializing_if = "CheckConfig::is_off")]
    pub counterfactual: CheckConfig,
}

fn default_eval_episodes() -> usize {
    5
}

fn default_final_eval_episodes() -> usize {
    10
}

impl TrainerConfig {
    /// A config with the given seed and budget, and default evaluation settings (final
    /// evaluation only, 10 episodes; no periodic checkpoints).
    pub fn new(seed: u64, budget: Budget) -> Self {
        Self {
            seed,
            budget,
            eval_freq: 0,
            eval_episodes: default_eval_episodes(),
            final_eval_episodes: default_final_eval_episodes(),
            checkpoint_every_episodes: 0,
            checkpoint_every_seconds: 0,
            counterfactual: CheckConfig::default(),
        }
    }
}

/// How a training episode ended (SPEC section 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// The environment itself terminated it (unhealthy state).
    Crashed,
    /// A wrapper (DEFENDER) ended it: some step had `StepInfo::filtered`.
    Filtered,
    /// It reached the horizon.
    Truncated,
}

impl Outcome {
    /// The name in `metrics.csv`: `crashed`, `filtered` or `truncated`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Crashed => "crashed",
            Self::Filtered => "filtered",
            Self::Truncated => "truncated",
        }
    }

    /// The outcome named `text` in `metrics.csv`, if any.
    pub fn from_name(text: &str) -> Option<Self> {
        [Self::Crashed, Self::Filtered, Self::Truncated].into_iter().find(|o| o.as_str() == text)
    }
}

/// One finished training episode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    /// 0-based index.
    pub episode: u64,
    /// Environment steps taken by the end of this episode (filtered steps count).
    pub total_steps: u64,
    /// Undiscounted sum of rewards.
    #[serde(rename = "return")]
    pub episode_return: f64,
    /// Undiscounted sum of the steps' costs ([`crate::Step::cost`]). `None` only in records
    /// written before costs existed: see [`EpisodeRecord::cost`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost: Option<f64>,
    /// Steps in the episode.
    pub length: u64,
    /// The last step was `terminated`.
    pub terminated: bool,
    /// The last step was `truncated`.
    pub truncated: bool,
    /// Some step was filtered (`StepInfo::filtered`).
    pub filtered: bool,
    /// Some step was numerically unstable (`StepInfo::unstable`).
    pub unstable: bool,
    /// Wall-clock seconds since the run started (summed over resumed sessions).
    pub wall_seconds: f64,
}

impl EpisodeRecord {
    /// The episode's cost. A record from before costs existed (a checkpoint of an older run)
    /// was made on a crash task, where the cost is 1 for a crashed episode and 0 otherwise.
    pub fn cost(&self) -> f64 {
        self.cost.unwrap_or(if self.outcome() == Outcome::Crashed { 1.0 } else { 0.0 })
    }

    /// The outcome: filtered if any step was filtered, else crashed if the environment
    /// terminated it, else truncated.
    pub fn outcome(&self) -> Outcome {
        if self.filtered {
            Outcome::Filtered
        } else if self.terminated {
            Outcome::Crashed
        } else {
            Outcome::Truncated
        }
    }
}

/// The error type hooks return (anything `anyhow::Error` converts into).
pub type HookError = Box<dyn std::error::Error + Send + Sync>;

/// Callbacks for logging, progress and extra checkpoint state. Every method has a no-op default.
pub trait Hooks {
    /// After every environment step (cheap: a progress bar's `set_position`).
    fn on_step(&mut self, total_steps: u64) {
        let _ = total_steps;
    }

    /// After every environment step, with the transition as the agent stored it, the action as
    /// the environment received it (rescaled to its bounds) and the step's cost to the task
    /// ([`crate::Step::cost`]; `transition.cost` adds any cost a wrapper charged the learner, such
    /// as DEFENDER's for a filtered step): for recording episodes, which are labelled by the
    /// task's cost as the episode records are.
    fn on_transition(&mut self, transition: &Transition<'_>, env_action: &[f64], task_cost: f64) {
        let _ = (transition, env_action, task_cost);
    }

    /// After each finished training episode and its record, with the agent: for work that needs
    /// the current policy, such as recording a demonstration of it (`defender demos collect`).
    ///
    /// # Errors
    /// Stops training with [`RlError::Hook`].
    fn after_episode(&mut self, record: &EpisodeRecord, agent: &mut dyn Agent) -> Result<(), HookError> {
        let _ = (record, agent);
        Ok(())
    }

    /// After a training phase that ran gradient steps.
    fn on_update(&mut self, total_steps: u64, stats: &UpdateStats) {
        let _ = (total_steps, stats);
    }

    /// After each finished training episode (append a `metrics.csv` row here).
    ///
    /// # Errors
    /// Stops training with [`RlError::Hook`].
    fn on_episode_end(&mut self, record: &EpisodeRecord) -> Result<(), HookError> {
        let _ = record;
        Ok(())
    }

    /// A wrapper ended an episode before its action ran (every such episode; checked or not).
    ///
    /// # Errors
    /// Stops training with [`RlError::Hook`].
    fn on_intervention(&mut self, record: &InterventionRecord) -> Result<(), HookError> {
        let _ = record;
        Ok(())
    }

    /// After each evaluation, periodic and final (append an `eval.csv` row here).
    ///
    /// # Errors
    /// Stops training with [`RlError::Hook`].
    fn on_evaluation(&mut self, record: &EvalRecord) -> Result<(), HookError> {
        let _ = record;
        Ok(())
    }

    /// While a checkpoint is being written: put extra files into `dir` (an empty directory
    /// inside the temporary checkpoint; it becomes part of the atomic replacement).
    ///
    /// # Errors
    /// Aborts the checkpoint (the previous one stays) and training, with [`RlError::Hook`].
    fn on_checkpoint(&mut self, dir: &Path) -> Result<(), HookError> {
        let _ = dir;
        Ok(())
    }

    /// After a checkpoint has been written and renamed into place at `dir` (the checkpoint root).
    ///
    /// # Errors
    /// Stops training with [`RlError::Hook`].
    fn on_checkpoint_done(&mut self, dir: &Path) -> Result<(), HookError> {
        let _ = dir;
        Ok(())
    }

    /// When resuming: read back what [`Hooks::on_checkpoint`] wrote (`dir` is the same
    /// sub-directory of the checkpoint being resumed).
    ///
    /// # Errors
    /// Fails the resume with [`RlError::Hook`].
    fn on_resume(&mut self, dir: &Path) -> Result<(), HookError> {
        let _ = dir;
        Ok(())
    }

    /// Asked at every episode boundary: return true to stop (after a checkpoint, if a
    /// checkpoint directory is set), e.g. on Ctrl-C.
    fn should_stop(&mut self) -> bool {
        false
    }
}

/// Hooks that do nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoHooks;

impl Hooks for NoHooks {}

/// Counters and records: everything of the trainer a checkpoint holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct TrainerState {
    config: TrainerConfig,
    total_steps: u64,
    episodes: Vec<EpisodeRecord>,
    evaluations: Vec<EvalRecord>,
    /// Every intervention so far (episodes a wrapper ended), checked or not.
    #[serde(default)]
    interventions: Vec<InterventionRecord>,
    /// Evaluation episodes run so far (their reset seeds continue from here).
    eval_episodes_run: u64,
    wall_seconds: f64,
    complete: bool,
}

/// How [`Trainer::run`] ended.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant, reason = "returned once per run: boxing would buy nothing")]
pub enum RunEnd {
    /// The budget was spent; the final evaluation is attached.
    Complete(EvalRecord),
    /// [`Hooks::should_stop`] asked to stop; the run can be resumed from its checkpoint.
    Stopped,
}

/// Drives an [`Agent`] on a training environment and evaluates it on another.
pub struct Trainer<A, E, V> {
    agent: A,
    env: E,
    eval_env: V,
    state: TrainerState,
    checkpoint_dir: Option<PathBuf>,
    /// The training environment's action space: the agent acts in `[-1, 1]`.
    action_space: BoxSpace,
}

/// Sub-directories of a checkpoint.
const AGENT_DIR: &str = "agent";
const ENV_DIR: &str = "env";
const EXTRA_DIR: &str = "extra";
const TRAINER_FILE: &str = "trainer.json";

fn hook_err(hook: &'static str) -> impl FnOnce(HookError) -> RlError {
    move |source| RlError::Hook { hook, source }
}

/// Refuses a NaN or infinite reward or observation from the training environment, naming it:
/// stored, it would turn the agent's losses into NaN (a `Diverged` error far from its cause) and
/// the episode's return in `metrics.csv` into NaN. (The MuJoCo tasks never return one: an
/// unstable simulation ends its episode as `unstable`, with a finite observation.)
fn check_finite(step: &Step, total_steps: u64, episode: u64) -> Result<(), RlError> {
    let bad =
        |field, index, value| RlError::NonFiniteStep { field, index, value, step: total_steps, episode };
    if !step.reward.is_finite() {
        return Err(bad("reward", 0, step.reward));
    }
    if !step.cost.is_finite() {
        return Err(bad("cost", 0, step.cost));
    }
    match step.obs.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(bad("observation", i, step.obs[i])),
        None => Ok(()),
    }
}

impl<A: Agent, E: Env, V: Env> Trainer<A, E, V> {
    /// A trainer for a fresh run.
    ///
    /// # Errors
    /// [`RlError::Incompatible`] if the environments' spaces do not fit the agent or each other,
    /// or the action space is unbounded; [`RlError::Config`] for zero evaluation episodes.
    pub fn new(agent: A, env: E, eval_env: V, config: TrainerConfig) -> Result<Self, RlError> {
        let space = env.action_space();
        let incompatible = |reason: String| RlError::Incompatible { env: env.id().to_string(), reason };
        if !space.is_bounded() {
            return Err(incompatible("the action space must be bounded to rescale [-1, 1] actions".into()));
        }
        if space.dim() != agent.act_dim() || env.observation_space().dim() != agent.obs_dim() {
            return Err(incompatible(format!(
                "obs/act dims {}/{}, the agent was built for {}/{}",
                env.observation_space().dim(),
                space.dim(),
                agent.obs_dim(),
                agent.act_dim()
            )));
        }
        if eval_env.action_space() != space || eval_env.observation_space().dim() != agent.obs_dim() {
            return Err(incompatible(format!("the evaluation env '{}' has other spaces", eval_env.id())));
        }
        if config.final_eval_episodes == 0 || (config.eval_freq > 0 && config.eval_episodes == 0) {
            return Err(RlError::Config {
                field: "eval_episodes",
                value: "0".into(),
                expected: "at least 1 episode per evaluation",
            });
        }
        let action_space = space.clone();
        let state = TrainerState {
            config,
            total_steps: 0,
            episodes: Vec::new(),
            evaluations: Vec::new(),
            interventions: Vec::new(),
            eval_episodes_run: 0,
            wall_seconds: 0.0,
            complete: false,
        };
        Ok(Self { agent, env, eval_env, state, checkpoint_dir: None, action_space })
    }

    /// Writes checkpoints to `dir` (replaced atomically each time; see [`crate::checkpoint`]).
    pub fn with_checkpoint_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.checkpoint_dir = Some(dir.into());
        self
    }

    /// Restores the trainer, the agent, the training env's state and the hooks' extra state
    /// from the checkpoint at `dir` (or its interrupted replacement). The agent and env must
    /// be built as for the original run; the trainer config is the checkpoint's.
    ///
    /// # Errors
    /// [`RlError::Checkpoint`], [`RlError::Io`], or what the agent, env or hooks report.
    pub fn resume(&mut self, dir: &Path, hooks: &mut dyn Hooks) -> Result<(), RlError> {
        let dir = resolve(dir)?;
        let state: TrainerState = read_json(&dir.join(TRAINER_FILE))?;
        self.agent.load(&dir.join(AGENT_DIR))?;
        if self.agent.num_timesteps() != state.total_steps {
            return Err(RlError::checkpoint(
                &dir,
                format!("agent has {} steps, trainer {}", self.agent.num_timesteps(), state.total_steps),
            ));
        }
        self.env.load_state(&dir.join(ENV_DIR))?;
        hooks.on_resume(&dir.join(EXTRA_DIR)).map_err(hook_err("on_resume"))?;
        self.state = state;
        Ok(())
    }

    /// The agent.
    pub fn agent(&self) -> &A {
        &self.agent
    }

    /// The agent, mutably.
    pub fn agent_mut(&mut self) -> &mut A {
        &mut self.agent
    }

    /// The training environment.
    pub fn env(&self) -> &E {
        &self.env
    }

    /// The records of the finished training episodes so far.
    pub fn episodes(&self) -> &[EpisodeRecord] {
        &self.state.episodes
    }

    /// The evaluations so far (the final one last once the run is complete).
    pub fn evaluations(&self) -> &[EvalRecord] {
        &self.state.evaluations
    }

    /// Environment steps taken so far.
    pub fn total_steps(&self) -> u64 {
        self.state.total_steps
    }

    /// Wall-clock seconds of training so far (over all sessions).
    pub fn wall_seconds(&self) -> f64 {
        self.state.wall_seconds
    }

    /// The trainer settings.
    pub fn config(&self) -> &TrainerConfig {
        &self.state.config
    }

    /// Changes the budget of a run that is not complete, e.g. to extend a resumed run. The unit
    /// stays the same and the new budget may not be below what was already trained.
    ///
    /// # Errors
    /// [`RlError::Config`] naming what is wrong; the budget is then unchanged.
    pub fn set_budget(&mut self, budget: Budget) -> Result<(), RlError> {
        let done = Budget::Steps(self.state.total_steps);
        let ok = match (self.state.config.budget, budget) {
            (Budget::Steps(_), Budget::Steps(n)) => n >= self.state.total_steps,
            (Budget::Episodes(_), Budget::Episodes(n)) => n >= self.state.episodes.len() as u64,
            _ => false,
        };
        if self.state.complete && budget != self.state.config.budget {
            return Err(RlError::Config {
                field: "budget",
                value: format!("{budget:?}"),
                expected: "the budget of the complete run (its final evaluation is made); a different budget needs a new run",
            });
        }
        if !ok {
            return Err(RlError::Config {
                field: "budget",
                value: format!(
                    "{budget:?} (the run has {:?}, done: {done:?}, {} episodes)",
                    self.state.config.budget,
                    self.state.episodes.len()
                ),
                expected: "a budget in the run's unit, not less than what was already trained",
            });
        }
        self.state.config.budget = budget;
        Ok(())
    }

    /// Whether the budget has been spent and the final evaluation run.
    pub fn is_complete(&self) -> bool {
        self.state.complete
    }

    fn budget_spent(&self) -> bool {
        match self.state.config.budget {
            Budget::Steps(n) => self.state.total_steps >= n,
            Budget::Episodes(n) => self.state.episodes.len() as u64 >= n,
        }
    }

    /// Trains until the budget is spent (then runs the final evaluation and, with a checkpoint
    /// directory, writes the final checkpoint) or until [`Hooks::should_stop`] says so.
    ///
    /// # Errors
    /// What the environments, the agent, a checkpoint or a hook report.
    pub fn run(&mut self, hooks: &mut dyn Hooks) -> Result<RunEnd, RlError> {
        let started = Instant::now();
        let wall_before = self.state.wall_seconds;
        let wall = |started: &Instant| wall_before + started.elapsed().as_secs_f64();
        let act_dim = self.agent.act_dim();
        let mut action = vec![0.0f32; act_dim];
        let mut env_action = vec![0.0f64; act_dim];
        let mut last_checkpoint = Instant::now();
        while !self.state.complete && !self.budget_spent() {
            if hooks.should_stop() {
                self.state.wall_seconds = wall(&started);
                self.checkpoint(hooks)?;
                return Ok(RunEnd::Stopped);
            }
            let episode = self.state.episodes.len() as u64;
            let seed = derive_seed(self.state.config.seed, SeedPurpose::TrainEpisode, episode);
            let mut obs = self.env.reset(Some(seed))?;
            let (mut ret, mut cost, mut length, mut filtered, mut unstable) = (0.0, 0.0, 0u64, false, false);
            loop {
                self.agent.act(&obs, false, &mut action)?;
                self.rescale(&action, &mut env_action);
                let step = self.env.step(&env_action)?;
                self.state.total_steps += 1;
                check_finite(&step, self.state.total_steps, episode)?;
                // The agent stores the normalised action; `terminated` and `truncated` stay apart.
                // It learns from the task's cost plus any cost a wrapper charged it, or the check of
                // an intervention (the episode's recorded cost below is the task's alone).
                let checked_charge = match step.info.filtered {
                    true => self.intervene((episode, length + 1, cost), &env_action, hooks)?,
                    false => 0.0,
                };
                let transition = Transition {
                    obs: &obs,
                    action: &action,
                    reward: step.reward,
                    cost: step.cost + step.info.charged_cost + checked_charge,
                    next_obs: &step.obs,
                    terminated: step.terminated,
                    truncated: step.truncated,
                };
                self.agent.observe(&transition)?;
                hooks.on_transition(&transition, &env_action, step.cost);
                if let Some(stats) = self.agent.update()? {
                    hooks.on_update(self.state.total_steps, &stats);
                }
                hooks.on_step(self.state.total_steps);
                ret += step.reward;
                cost += step.cost;
                length += 1;
                filtered |= step.info.filtered;
                unstable |= step.info.unstable;
                let eval_freq = self.state.config.eval_freq;
                // The last step of a step budget gets the final evaluation instead.
                let last_step =
                    matches!(self.state.config.budget, Budget::Steps(n) if self.state.total_steps >= n);
                if eval_freq > 0 && self.state.total_steps.is_multiple_of(eval_freq) && !last_step {
                    let n = self.state.config.eval_episodes;
                    self.evaluate(n, false, hooks)?;
                }
                if step.done() {
                    let record = EpisodeRecord {
                        episode,
                        total_steps: self.state.total_steps,
                        episode_return: ret,
                        cost: Some(cost),
                        length,
                        terminated: step.terminated,
                        truncated: step.truncated,
                        filtered,
                        unstable,
                        wall_seconds: wall(&started),
                    };
                    hooks.on_episode_end(&record).map_err(hook_err("on_episode_end"))?;
                    hooks.after_episode(&record, &mut self.agent).map_err(hook_err("after_episode"))?;
                    self.state.episodes.push(record);
                    break;
                }
                obs = step.obs;
                if matches!(self.state.config.budget, Budget::Steps(n) if self.state.total_steps >= n) {
                    break; // the budget cuts this episode; it is not recorded
                }
            }
            let every = self.state.config.checkpoint_every_episodes;
            let by_episodes = every > 0 && (self.state.episodes.len() as u64).is_multiple_of(every);
            let seconds = self.state.config.checkpoint_every_seconds;
            let by_time = seconds > 0 && last_checkpoint.elapsed().as_secs() >= seconds;
            if (by_episodes || by_time) && !self.budget_spent() {
                self.state.wall_seconds = wall(&started);
                self.checkpoint(hooks)?;
                last_checkpoint = Instant::now();
            }
        }
        if !self.state.complete {
            let n = self.state.config.final_eval_episodes;
            self.evaluate(n, true, hooks)?;
            self.state.complete = true;
            self.state.wall_seconds = wall(&started);
            self.checkpoint(hooks)?;
        }
        match self.state.evaluations.last() {
            Some(last) if last.is_final => Ok(RunEnd::Complete(last.clone())),
            _ => Err(RlError::checkpoint(
                self.checkpoint_dir.clone().unwrap_or_default(),
                "run marked complete without a final evaluation",
            )),
        }
    }

    /// Records the intervention that ended `episode` after `length` steps (the stopped action
    /// `env_action` from a state the episode reached at cost `cost`), checked when it is due;
    /// the cost the learner is charged for it (the continuation's, at most `charge_max`; else 0).
    fn intervene(
        &mut self,
        at: (u64, u64, f64),
        env_action: &[f64],
        hooks: &mut dyn Hooks,
    ) -> Result<f64, RlError> {
        let (c, index) = (self.state.config.counterfactual, self.state.interventions.len() as u64);
        let record = InterventionRecord::new(index, at.0, self.state.total_steps, at.1, at.2);
        let seed = self.state.config.seed;
        let record = check(record, &self.env, &mut self.agent, &self.action_space, env_action, (seed, c))?;
        hooks.on_intervention(&record).map_err(hook_err("on_intervention"))?;
        let charge = c.charge_max.map_or(0.0, |max| record.continuation_cost.min(max));
        self.state.interventions.push(record);
        Ok(charge)
    }

    /// Every intervention so far.
    pub fn interventions(&self) -> &[InterventionRecord] {
        &self.state.interventions
    }

    /// SB3's `unscale_action`: `[-1, 1]` to the action space's bounds.
    fn rescale(&self, action: &[f32], out: &mut [f64]) {
        self.action_space.unscale(action, out);
    }

    /// Evaluates the deterministic policy on `episodes` episodes of the evaluation env and records
    /// it; a training env that lends a shield (DEFENDER's filter) gets the same episodes shielded
    /// too (crate::evaluation). Only the unfiltered pass moves the evaluation seeds on: the
    /// shielded one replays its seeds, so runs without a shield evaluate as before.
    fn evaluate(&mut self, episodes: usize, is_final: bool, hooks: &mut dyn Hooks) -> Result<(), RlError> {
        let first = self.state.eval_episodes_run;
        let seeds: Vec<u64> = (first..first + episodes as u64)
            .map(|k| derive_seed(self.state.config.seed, SeedPurpose::EvalEpisode, k))
            .collect();
        self.state.eval_episodes_run += episodes as u64;
        let shield = self.env.shield();
        let mut evaluator =
            Evaluator { agent: &mut self.agent, env: &mut self.eval_env, action_space: &self.action_space };
        let record = evaluator.evaluate(&seeds, shield, self.state.total_steps, is_final)?;
        hooks.on_evaluation(&record).map_err(hook_err("on_evaluation"))?;
        self.state.evaluations.push(record);
        Ok(())
    }

    /// Writes a checkpoint now (if a checkpoint directory is set). Called by [`Trainer::run`]
    /// at episode boundaries; callable between runs.
    ///
    /// # Errors
    /// [`RlError::Io`], or what the agent, env or hooks report; the previous checkpoint stays.
    pub fn checkpoint(&mut self, hooks: &mut dyn Hooks) -> Result<(), RlError> {
        let Some(dir) = self.checkpoint_dir.clone() else {
            return Ok(());
        };
        write_atomic(&dir, |tmp| {
            for sub in [AGENT_DIR, ENV_DIR, EXTRA_DIR] {
                std::fs::create_dir(tmp.join(sub)).map_err(|e| RlError::io(tmp.join(sub), e))?;
            }
            self.agent.save(&tmp.join(AGENT_DIR))?;
            self.env.save_state(&tmp.join(ENV_DIR))?;
            hooks.on_checkpoint(&tmp.join(EXTRA_DIR)).map_err(hook_err("on_checkpoint"))?;
            // Written last: a checkpoint directory with trainer.json is complete.
            write_json(&tmp.join(TRAINER_FILE), &self.state)
        })?;
        hooks.on_checkpoint_done(&dir).map_err(hook_err("on_checkpoint_done"))
    }
}
