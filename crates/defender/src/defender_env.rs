//! `DefenderEnv`: DEFENDER as an environment wrapper (the paper's Algorithm 1, SPEC sections 4-6).
//! Any agent trains on it unchanged: it sees an [`Env`].

use std::path::{Path, PathBuf};
use std::sync::MutexGuard;

use rand::Rng;
use serde::{Deserialize, Serialize};

use defender_rl::{BoxSpace, Env, EnvError, Outcome, Step, StepInfo};

use crate::adaptive_filter::AdaptiveFilter;
use crate::demonstrations::{CostOptions, Demonstrations};
use crate::dynamics::{DynamicsConfig, DynamicsModel};
use crate::dynamics_worker::{DynamicsHandle, TrainedDynamics};
use crate::episode_set::EpisodeSet;
use crate::error::{DefenderError, Result};
use crate::filter::{Decision, Filter};
use crate::filter_options::FilterOptions;
use crate::strategy::{Mode, Strategy};
use crate::trigger::{Gate, RiskSignal, TriggerKind};
use crate::violation::UnsafeRule;

/// The largest `|R_task|` accepted: far beyond any task's per-step reward, small enough that
/// Q-learning targets stay finite in f32.
pub const MAX_ABS_R_TASK: f64 = 1e6;

/// DEFENDER's settings (the `[defender]` section of a run's configuration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DefenderConfig {
    /// `SAFE/UNSAFE` (SPEC section 3); default `MeanDemoW5/MeanDemoW10`, the paper's best for
    /// reward with state trajectories.
    #[serde(default = "default_strategy")]
    pub strategy: Strategy,
    /// `state` (default) or `state-action`.
    #[serde(default)]
    pub mode: Mode,
    /// Demonstrations used per group: the first N of each group in file order; all when `None`.
    #[serde(default)]
    pub num_demos: Option<usize>,
    /// The reward of a filtered step; `None`: the lowest per-step reward of the demonstrations
    /// used (both groups), SPEC section 5.
    #[serde(default)]
    pub r_task: Option<f64>,
    /// Options of the alignment cost (off by default).
    #[serde(default)]
    pub cost: CostOptions,
    /// The filter's precision options (`[defender.filter]`; off by default).
    #[serde(default, skip_serializing_if = "FilterOptions::is_spec")]
    pub filter: FilterOptions,
    /// On a task whose safety is a cost: an episode is unsafe once its cost passes this limit
    /// (docs/SPEC.md, section 13; Safety-Gymnasium's 25). `None`: unsafe is a crash.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub episode_cost_limit: Option<f64>,
    /// What a filtered step costs the learner (docs/SPEC.md, section 14): `none` (SPEC sections
    /// 12-13: nothing reached the environment) or `violation` (the violation it prevented).
    #[serde(default, skip_serializing_if = "FilteredCost::is_none")]
    pub filtered_cost: FilteredCost,
    /// The dynamics model.
    #[serde(default)]
    pub dynamics: DynamicsConfig,
}

/// What a filtered step costs the learner. The recorded episode cost never includes it: it is
/// [`StepInfo::charged_cost`], not [`Step::cost`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilteredCost {
    /// Nothing (SPEC sections 12-13).
    #[default]
    None,
    /// The violation the filter prevented: the episode's cost so far is topped up to one unit
    /// above the episode limit `L` (0 on a crash task), `L + 1 - C`, so that a learner of the
    /// costs sees a filtered episode as one that broke the limit (a crash costs 1).
    Violation,
    /// The cost the filter prevented, by one sample: the run checks every intervention
    /// (`[counterfactual] every = 1`) and the trainer charges the learner the unfiltered
    /// continuation's task cost (`defender_rl::CheckConfig::charge`); the environment itself
    /// charges nothing.
    Continuation,
}

impl FilteredCost {
    /// Whether it is the SPEC's `none` (left out of a saved configuration).
    pub fn is_none(&self) -> bool {
        *self == Self::None
    }
}

fn default_strategy() -> Strategy {
    Strategy::new(
        crate::method::Method::new(crate::method::Aggregation::Mean, crate::window::Window::DemoW5),
        crate::method::Method::new(crate::method::Aggregation::Mean, crate::window::Window::DemoW10),
    )
}

impl Default for DefenderConfig {
    fn default() -> Self {
        Self {
            strategy: default_strategy(),
            mode: Mode::State,
            num_demos: None,
            r_task: None,
            cost: CostOptions::default(),
            filter: FilterOptions::default(),
            episode_cost_limit: None,
            filtered_cost: FilteredCost::None,
            dynamics: DynamicsConfig::default(),
        }
    }
}

/// Counters of a [`DefenderEnv`] since it was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DefenderStats {
    /// Steps the agent took (filtered ones included).
    pub steps: u64,
    /// Steps that were filtered (the action was not executed).
    pub filtered_steps: u64,
    /// Steps sent to the wrapped environment.
    pub real_steps: u64,
    /// Episodes that ended.
    pub episodes: u64,
    /// Episodes DEFENDER ended (not crashes).
    pub filtered_episodes: u64,
    /// Episodes the environment terminated (SPEC section 6).
    pub crashed_episodes: u64,
    /// Episodes that reached the horizon.
    pub truncated_episodes: u64,
}

/// Wraps any environment with DEFENDER. At each step the trajectory element (`s_t`, or
/// `concat(s_t, a_t)`) goes to the [`Filter`]:
///
/// * executed (`Safe(tau) < Unsafe(tau)`): the inner environment steps, and the dynamics model
///   learns from the real transition;
/// * filtered: the inner environment is **not** stepped; the step returns the dynamics model's
///   prediction as the observation, reward `R_task`, `terminated = true`, `info.filtered = true`.
///
/// Outcomes follow SPEC section 6: a filtered episode is not a crash; an episode the inner
/// environment terminated is a crash (also when the time limit falls on that same step, as the
/// trainer counts it); one it only truncated reached the horizon.
#[derive(Debug)]
pub struct DefenderEnv<E> {
    inner: E,
    filter: AdaptiveFilter,
    dynamics: TrainedDynamics,
    config: DefenderConfig,
    r_task: f64,
    obs: Vec<f64>,
    pred: Vec<f64>,
    needs_reset: bool,
    episode_steps: usize,
    last_decision: Option<Decision>,
    last_outcome: Option<Outcome>,
    stats: DefenderStats,
    /// The task's cost of the episode under way (for [`FilteredCost::Violation`]).
    episode_cost: f64,
    /// What decides to end the episode (`[defender.filter] trigger`).
    gate: Gate,
    /// The last decision's score under a trigger other than `dtw` (a probability, a failure
    /// proximity, the episode's cost; 1 or 0 for the risk critic's signal).
    last_score: Option<f64>,
}

impl<E: Env> DefenderEnv<E> {
    /// Wraps `inner` with the demonstrations `demos` (both groups needed; the first
    /// `config.num_demos` of each are used). The dynamics model's weights and sampling RNG are
    /// drawn from `rng`; with `config.dynamics.background` its thread starts here.
    ///
    /// # Errors
    /// Demonstrations that do not fit the environment (dimensions, `meta.env_id`), a missing group,
    /// too few demonstrations, an invalid configuration, or a thread that cannot start.
    pub fn new<R: Rng + ?Sized>(
        inner: E,
        demos: &EpisodeSet,
        config: DefenderConfig,
        rng: &mut R,
    ) -> Result<Self> {
        let (obs_dim, act_dim) = (inner.observation_space().dim(), inner.action_space().dim());
        demos.check_env(inner.id(), obs_dim, act_dim)?;
        let rule = UnsafeRule::from_limit(config.episode_cost_limit)?;
        rule.check_demos(demos)?;
        let selected;
        let demos = match config.num_demos {
            Some(n) => {
                selected = demos.select_demos(n)?;
                &selected
            }
            None => demos,
        };
        let prepared = Demonstrations::new(demos, config.mode, config.cost)?;
        let r_task = match config.r_task {
            Some(r) if r.is_finite() && r.abs() <= MAX_ABS_R_TASK => r,
            Some(r) => {
                return Err(DefenderError::Config(format!(
                    "r_task = {r} is out of range: it must be finite and at most {MAX_ABS_R_TASK:e} in \
                     absolute value (it becomes a learning target; a huge value makes the critics diverge)"
                )));
            }
            None => f64::from(prepared.min_reward()),
        };
        let filter = AdaptiveFilter::new(&prepared, config.strategy, config.filter)?.with_rule(rule);
        let model = DynamicsModel::new(obs_dim, act_dim, config.dynamics.clone(), rng)?;
        // Drawn after the model's weights, so that a `dtw` run's streams are as they always were.
        let gate = match config.filter.trigger {
            TriggerKind::Dtw => Gate::Dtw,
            TriggerKind::Margin => {
                if inner.failure_proximity(&vec![0.0; obs_dim]).is_none() {
                    return Err(DefenderError::Config(format!(
                        "[defender.filter] trigger = \"margin\": {} has no failure condition to tighten \
                         (the margin trigger reads Hopper's, Walker2d's and InvertedDoublePendulum's)",
                        inner.id()
                    )));
                }
                Gate::Margin { threshold: 1.0 - config.filter.task_margin.unwrap_or(0.0) }
            }
            TriggerKind::Violation => match config.episode_cost_limit {
                Some(limit) => Gate::Violation { limit },
                None => {
                    return Err(DefenderError::Config(format!(
                        "[defender.filter] trigger = \"violation\" ends an episode once its cost passes \
                         the limit: {} is a crash task (no episode_cost_limit), where the violation \
                         already ends the episode",
                        inner.id()
                    )));
                }
            },
            TriggerKind::RiskCritic => Gate::RiskCritic(None),
            TriggerKind::Classifier => Gate::Classifier(Box::new(crate::classifier::Classifier::new(
                demos,
                config.mode,
                config.filter.classifier.unwrap_or_default(),
                config.filter.own_episodes.map(|o| o.keep),
                rng,
            )?)),
        };
        let dynamics = TrainedDynamics::new(model, config.dynamics.background)?;
        Ok(Self {
            inner,
            filter,
            dynamics,
            config,
            r_task,
            obs: vec![0.0; obs_dim],
            pred: vec![0.0; obs_dim],
            needs_reset: true,
            episode_steps: 0,
            last_decision: None,
            last_outcome: None,
            stats: DefenderStats::default(),
            episode_cost: 0.0,
            gate,
            last_score: None,
        })
    }

    /// What decides to end the episode.
    pub fn trigger(&self) -> TriggerKind {
        self.config.filter.trigger
    }

    /// The signal by which a Recovery RL agent's safety critic ends episodes (the `risk-critic`
    /// trigger); the agent holds a clone (`defender_rl::safety::recovery::Recovery::ending_episodes`).
    ///
    /// # Errors
    /// [`DefenderError::Config`] when the trigger is not `risk-critic`.
    pub fn set_risk_signal(&mut self, signal: RiskSignal) -> Result<()> {
        match &mut self.gate {
            Gate::RiskCritic(slot) => {
                *slot = Some(signal);
                Ok(())
            }
            _ => Err(DefenderError::Config(format!(
                "a risk signal ends episodes under trigger = \"risk-critic\" only; this run's is \"{}\"",
                self.config.filter.trigger.as_str()
            ))),
        }
    }

    /// The last step's score under a trigger other than `dtw` (the classifier's probability, the
    /// state's failure proximity, the episode's cost so far, or 1 / 0 for the risk critic's
    /// signal); `None` under `dtw` ([`DefenderEnv::last_decision`] holds its costs).
    pub fn last_score(&self) -> Option<f64> {
        self.last_score
    }

    /// The reward of a filtered step, as used.
    pub fn r_task(&self) -> f64 {
        self.r_task
    }

    /// The configuration (with `r_task` as given; see [`DefenderEnv::r_task`] for the value used).
    pub fn config(&self) -> &DefenderConfig {
        &self.config
    }

    /// Counters since construction.
    pub fn stats(&self) -> DefenderStats {
        self.stats
    }

    /// The filter's decision on the last step.
    pub fn last_decision(&self) -> Option<Decision> {
        self.last_decision
    }

    /// How the last finished episode ended.
    pub fn last_outcome(&self) -> Option<Outcome> {
        self.last_outcome
    }

    /// Steps taken in the current episode.
    pub fn episode_steps(&self) -> usize {
        self.episode_steps
    }

    /// The filter as it stands (with own episodes on, its groups grow between episodes).
    pub fn filter(&self) -> &Filter {
        self.filter.filter()
    }

    /// The filter with its precision options (margin in use, own episodes kept).
    pub fn adaptive_filter(&self) -> &AdaptiveFilter {
        &self.filter
    }

    /// The dynamics model (its prediction error, counters; [`DynamicsModel::set_parallelism`]),
    /// once it has learnt from every real step so far (with `background`, this waits for its
    /// thread). Release the guard before the next step.
    ///
    /// # Errors
    /// With `background`: the model's thread stopped (it panicked).
    pub fn dynamics(&self) -> Result<MutexGuard<'_, DynamicsModel>> {
        self.dynamics.model()
    }

    /// A handle that reads the dynamics model apart from the environment (e.g. to log its
    /// prediction error while a trainer owns the environment); it follows
    /// [`DefenderEnv::set_dynamics`].
    pub fn dynamics_handle(&self) -> DynamicsHandle {
        self.dynamics.handle()
    }

    /// Replaces the dynamics model (e.g. by one restored from a checkpoint).
    ///
    /// # Errors
    /// Its dimensions differ from the environment's; or as [`DefenderEnv::dynamics`].
    pub fn set_dynamics(&mut self, model: DynamicsModel) -> Result<()> {
        let act_dim = self.inner.action_space().dim();
        if (model.obs_dim(), model.act_dim()) != (self.obs.len(), act_dim) {
            return Err(DefenderError::Mismatch {
                what: "dynamics model dimensions (obs, act)".into(),
                expected: format!("({}, {act_dim})", self.obs.len()),
                got: format!("({}, {})", model.obs_dim(), model.act_dim()),
            });
        }
        self.dynamics.replace(model)
    }

    /// Restores the counters (checkpoint resume).
    pub fn set_stats(&mut self, stats: DefenderStats) {
        self.stats = stats;
    }

    /// The wrapped environment.
    pub fn inner(&self) -> &E {
        &self.inner
    }

    /// The wrapped environment, mutably.
    pub fn inner_mut(&mut self) -> &mut E {
        &mut self.inner
    }

    /// Unwraps.
    pub fn into_inner(self) -> E {
        self.inner
    }

    fn end_episode(&mut self, outcome: Outcome) -> Result<()> {
        self.needs_reset = true;
        self.last_outcome = Some(outcome);
        self.stats.episodes += 1;
        match outcome {
            Outcome::Filtered => self.stats.filtered_episodes += 1,
            Outcome::Crashed => self.stats.crashed_episodes += 1,
            Outcome::Truncated => self.stats.truncated_episodes += 1,
        }
        match &mut self.gate {
            Gate::Dtw => self.filter.end(outcome),
            Gate::Classifier(c) => {
                c.end(outcome);
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Whether the trigger ends the episode before `action` runs from the current state.
    fn decide(&mut self, action: &[f64]) -> Result<bool> {
        self.last_score = None;
        let filtered = match &mut self.gate {
            Gate::Dtw => {
                let decision = self.filter.push(&self.obs, action)?;
                self.last_decision = Some(decision);
                return Ok(decision.filtered);
            }
            Gate::Margin { threshold } => {
                let p = self.inner.failure_proximity(&self.obs).unwrap_or(0.0);
                self.last_score = Some(p);
                p > *threshold
            }
            Gate::Violation { limit } => {
                self.last_score = Some(self.episode_cost);
                self.episode_cost > *limit
            }
            Gate::RiskCritic(signal) => {
                let raised = signal
                    .as_ref()
                    .ok_or_else(|| {
                        DefenderError::Config(
                            "trigger = \"risk-critic\" needs a Recovery RL agent's signal \
                             (DefenderEnv::set_risk_signal): none was set"
                                .into(),
                        )
                    })?
                    .take();
                self.last_score = Some(if raised { 1.0 } else { 0.0 });
                raised
            }
            Gate::Classifier(c) => {
                let p = c.push(&self.obs, action)?;
                self.last_score = Some(p);
                p > c.options().threshold
            }
        };
        Ok(filtered)
    }
}

fn env_error(e: DefenderError) -> EnvError {
    match e {
        DefenderError::Env(e) => e,
        other => EnvError::Simulator(format!("DEFENDER: {other}")),
    }
}

impl<E: Env> Env for DefenderEnv<E> {
    fn id(&self) -> &str {
        self.inner.id()
    }

    fn observation_space(&self) -> &BoxSpace {
        self.inner.observation_space()
    }

    fn action_space(&self) -> &BoxSpace {
        self.inner.action_space()
    }

    fn max_episode_steps(&self) -> Option<usize> {
        self.inner.max_episode_steps()
    }

    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        let obs = self.inner.reset(seed)?;
        self.inner.observation_space().check("observation from reset", &obs)?;
        self.obs.copy_from_slice(&obs);
        match &mut self.gate {
            Gate::Dtw => self.filter.begin(&obs),
            Gate::Classifier(c) => c.begin(),
            _ => {}
        }
        self.needs_reset = false;
        self.episode_steps = 0;
        self.episode_cost = 0.0;
        self.last_decision = None;
        Ok(obs)
    }

    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        if self.needs_reset {
            return Err(EnvError::NeedsReset);
        }
        self.inner.action_space().check("action", action)?;
        // tau <- tau + s_t (or (s_t, a_t)); Safe(tau) < Unsafe(tau) ?
        let filtered = self.decide(action).map_err(env_error)?;
        self.stats.steps += 1;
        self.episode_steps += 1;
        if filtered {
            // s', r, done = theta(s, a), R_task, True: the action never reaches the environment.
            self.dynamics
                .model()
                .and_then(|mut model| model.predict_into(&self.obs, action, &mut self.pred))
                .map_err(env_error)?;
            self.stats.filtered_steps += 1;
            self.end_episode(Outcome::Filtered).map_err(env_error)?;
            let charged_cost = match self.config.filtered_cost {
                FilteredCost::None | FilteredCost::Continuation => 0.0,
                FilteredCost::Violation => {
                    (self.config.episode_cost_limit.unwrap_or(0.0) + 1.0 - self.episode_cost).max(0.0)
                }
            };
            return Ok(Step {
                obs: self.pred.clone(),
                reward: self.r_task,
                // Nothing reached the environment: no violation happened.
                cost: 0.0,
                terminated: true,
                truncated: false,
                info: StepInfo { filtered: true, charged_cost, ..StepInfo::default() },
            });
        }
        let step = self.inner.step(action)?;
        self.stats.real_steps += 1;
        self.episode_cost += step.cost;
        // The dynamics model learns from real transitions only; an unstable step's observation
        // is not a transition of the task.
        if !step.info.unstable && step.obs.iter().all(|v| v.is_finite()) && step.obs.len() == self.obs.len() {
            self.dynamics.observe(&self.obs, action, &step.obs).map_err(env_error)?;
            if matches!(self.gate, Gate::Dtw) {
                self.filter.executed(action, step.reward, &step.obs).map_err(env_error)?;
            }
            self.obs.copy_from_slice(&step.obs);
        }
        if matches!(self.gate, Gate::Dtw) {
            self.filter.real_step(step.cost, step.terminated);
        }
        if step.terminated {
            self.end_episode(Outcome::Crashed).map_err(env_error)?;
        } else if step.truncated {
            self.end_episode(Outcome::Truncated).map_err(env_error)?;
        }
        Ok(step)
    }

    /// The dynamics model (weights, optimiser, its transition buffer, RNG) goes into
    /// `dir/dynamics/`, the counters into `dir/defender_stats.json`, the filter's margin and own
    /// episodes (crate::adaptive_filter) beside them, and the inner environment's own state (if
    /// any) into `dir/inner/`. The trajectory needs nothing: it restarts every episode and
    /// checkpoints are taken at episode boundaries.
    fn save_state(&self, dir: &Path) -> defender_rl::Result<()> {
        let state_err = |path: PathBuf, reason: String| EnvError::State { path, reason };
        self.dynamics
            .model()
            .and_then(|model| model.save(dir.join("dynamics")))
            .map_err(|e| state_err(dir.join("dynamics"), e.to_string()))?;
        let stats_path = dir.join("defender_stats.json");
        let text = serde_json::to_vec_pretty(&self.stats)
            .map_err(|e| state_err(stats_path.clone(), e.to_string()))?;
        std::fs::write(&stats_path, text).map_err(|e| state_err(stats_path.clone(), e.to_string()))?;
        self.filter.save(dir).map_err(|e| state_err(dir.to_path_buf(), e.to_string()))?;
        if let Gate::Classifier(c) = &self.gate {
            c.save(dir).map_err(|e| state_err(dir.to_path_buf(), e.to_string()))?;
        }
        let inner = dir.join("inner");
        std::fs::create_dir_all(&inner).map_err(|e| state_err(inner.clone(), e.to_string()))?;
        self.inner.save_state(&inner)
    }

    fn load_state(&mut self, dir: &Path) -> defender_rl::Result<()> {
        let state_err = |path: PathBuf, reason: String| EnvError::State { path, reason };
        let model_dir = dir.join("dynamics");
        let model =
            DynamicsModel::load(&model_dir).map_err(|e| state_err(model_dir.clone(), e.to_string()))?;
        self.set_dynamics(model).map_err(|e| state_err(model_dir.clone(), e.to_string()))?;
        let stats_path = dir.join("defender_stats.json");
        let text = std::fs::read(&stats_path).map_err(|e| state_err(stats_path.clone(), e.to_string()))?;
        self.stats =
            serde_json::from_slice(&text).map_err(|e| state_err(stats_path.clone(), e.to_string()))?;
        self.filter.load(dir).map_err(|e| state_err(dir.to_path_buf(), e.to_string()))?;
        if let Gate::Classifier(c) = &mut self.gate {
            c.load(dir).map_err(|e| state_err(dir.to_path_buf(), e.to_string()))?;
        }
        self.needs_reset = true;
        self.inner.load_state(&dir.join("inner"))
    }

    /// The filter as it stands, copied ([`crate::FilterShield`]): evaluations keep it without
    /// touching this one, which sees training steps only.
    fn shield(&self) -> Option<Box<dyn defender_rl::Shield>> {
        match &self.gate {
            Gate::Dtw => Some(Box::new(crate::shield::FilterShield::new(self.filter.filter().clone()))),
            Gate::Margin { threshold } => {
                Some(Box::new(crate::shield::MarginShield::new(self.inner.fork()?, *threshold)))
            }
            Gate::Classifier(c) => Some(Box::new(crate::shield::ClassifierShield::new((**c).clone()))),
            // The risk critic lives in the agent, and the violation needs the costs: neither is
            // a shield of (observation, action).
            Gate::RiskCritic(_) | Gate::Violation { .. } => None,
        }
    }

    /// The wrapped simulator as it stands: after a filtered step, the state the action was
    /// not executed from.
    fn fork(&self) -> Option<Box<dyn Env>> {
        self.inner.fork()
    }

    fn failure_proximity(&self, obs: &[f64]) -> Option<f64> {
        self.inner.failure_proximity(obs)
    }
}
