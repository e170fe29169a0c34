//! A run's configuration: the format of `config.toml` (and of the pinned copy in a checkpoint,
//! `extra/run_config.toml`, and of `--config` files). Unknown keys are refused.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use defender::DefenderConfig;
use defender::selection::StrategyChoice;
use defender_rl::{Algo, AlgoConfig, Budget};
use serde::{Deserialize, Serialize};

use crate::profile::Profile;

/// The resolved configuration of a run: written to `config.toml`, readable by `--config`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// `spec` (SPEC.md), `authors` (the authors' code) or `keeps-learning`; a profile fills every
    /// setting it changes that the configuration leaves out (`crate::profile`). A new run's
    /// request without one gets `profile::NEW_RUN_DEFAULT`; a record without one (written before
    /// profiles existed) reads as `spec`, which it ran.
    #[serde(default)]
    pub profile: Profile,
    /// Gymnasium id.
    pub env: String,
    /// `sac` or `td3`.
    pub algo: Algo,
    /// The run's seed.
    #[serde(default)]
    pub seed: u64,
    /// Budget in environment steps (0 when the budget is in episodes).
    #[serde(default)]
    pub total_steps: u64,
    /// Budget in episodes (0 when the budget is in steps).
    #[serde(default)]
    pub total_episodes: u64,
    /// Evaluate every this many steps (0: only the final evaluation).
    #[serde(default)]
    pub eval_freq: u64,
    /// Episodes per periodic evaluation.
    #[serde(default = "five")]
    pub eval_episodes: usize,
    /// Checkpoint every this many episodes (0: only by time, at the end and on stop).
    #[serde(default)]
    pub checkpoint_every_episodes: u64,
    /// Checkpoint at the first episode end this many wall-clock seconds after the last
    /// checkpoint (0: never by time), so that a kill -9 loses at most about that much work.
    #[serde(default = "default_checkpoint_seconds")]
    pub checkpoint_every_seconds: u64,
    /// Where the training episodes are saved as an episode set, if anywhere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub record_episodes: Option<PathBuf>,
    /// The demonstration set a bare run's agent stores in its replay buffer
    /// (`demos_in_replay`); `None`: the one shipped for the task. A DEFENDER run uses
    /// `[defender] demos`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demos: Option<PathBuf>,
    /// SHA-256 of that file, pinned when the run starts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demos_sha256: Option<String>,
    /// DEFENDER's settings; absent for a bare run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub defender: Option<DefenderSection>,
    /// SAC hyperparameters (used when `algo = "sac"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sac: Option<defender_rl::SacConfig>,
    /// TD3 hyperparameters (used when `algo = "td3"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub td3: Option<defender_rl::Td3Config>,
    /// A baseline that learns from the steps' costs (`[safety]`: `method = "penalty"`,
    /// `"lagrangian"`, `"pid"` or `"recovery"`; defender_rl::safety); absent: the agent ignores costs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub safety: Option<defender_rl::SafetyConfig>,
    /// What the run writes besides its CSV files (`[log]`); left out of `config.toml` when it is
    /// the default, so runs started before it resume unchanged.
    #[serde(default, skip_serializing_if = "LogSection::is_default")]
    pub log: LogSection,
    /// `[counterfactual]`: every `every`-th intervention of a DEFENDER run checked against the
    /// unfiltered continuation (docs/SPEC.md, section 15); absent: none is checked. The run
    /// sets `cost_limit` from the task (a cost task's episode limit).
    #[serde(default, skip_serializing_if = "defender_rl::CheckConfig::is_off")]
    pub counterfactual: defender_rl::CheckConfig,
}

/// The `[log]` section of a run configuration.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LogSection {
    /// TensorBoard event files in the run directory (`tensorboard --logdir`); on by default.
    #[serde(default = "yes")]
    pub tensorboard: bool,
}

fn yes() -> bool {
    true
}

impl Default for LogSection {
    fn default() -> Self {
        Self { tensorboard: true }
    }
}

impl LogSection {
    fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// The default `eval_episodes`.
pub fn five() -> usize {
    5
}

/// The default `checkpoint_every_seconds`. Checkpoints every 2 minutes by default: a checkpoint of a 100k-step run takes well under a
/// second, and a scheduler's kill -9 then loses at most about 2 minutes of training.
pub fn default_checkpoint_seconds() -> u64 {
    120
}

impl RunConfig {
    /// The training budget.
    ///
    /// # Errors
    /// None, or both, of `total_steps` and `total_episodes`.
    pub fn budget(&self) -> Result<Budget> {
        match (self.total_steps, self.total_episodes) {
            (0, 0) => bail!("no budget: give --steps N or --episodes N (or total_steps / total_episodes)"),
            (s, 0) => Ok(Budget::Steps(s)),
            (0, e) => Ok(Budget::Episodes(e)),
            _ => bail!("give a budget in steps or in episodes, not both"),
        }
    }

    /// This request as it applies to `saved`, a run already started: `strategy = "auto"` asks
    /// for the strategy the selection chose when that run began (its `config.toml` holds the
    /// choice and `[defender.selection]`), so it takes that choice rather than choosing again,
    /// and the scaling chosen with it when the request leaves the scaling to `auto`.
    /// The selection is part of the run; making it again on a resume (or comparing `auto` with
    /// the chosen name when a sweep checks a complete run) would change or refuse the run.
    #[must_use]
    pub fn keeping_automatic_choice_of(mut self, saved: &RunConfig) -> Self {
        if let (Some(requested), Some(saved)) = (self.defender.as_mut(), saved.defender.as_ref())
            && requested.strategy == StrategyChoice::Auto
            && saved.selection.is_some()
        {
            requested.strategy = saved.strategy;
            requested.selection.clone_from(&saved.selection);
            if requested.cost.scaling.is_none() {
                requested.cost.scaling = saved.cost.scaling;
            }
        }
        self
    }
}

impl RunConfig {
    /// Checks every value's range, section by section (one function per struct: a new key is
    /// checked in its struct's function), so that a bad value is refused where the
    /// configuration is read (`defender train`, and `defender sweep` for every run before any
    /// starts), never after a run has begun. Whether `num_demos` fits the demonstration file is
    /// [`RunConfig::check_demonstrations`]'s (it reads the file).
    ///
    /// # Errors
    /// The first bad value, naming its section, key and value.
    pub fn validate(&self) -> Result<()> {
        self.budget()?;
        if self.eval_episodes == 0 {
            bail!("eval_episodes = 0: give at least 1 episode per evaluation");
        }
        if let Some(d) = &self.defender {
            d.validate().context("[defender]")?;
        }
        if let Some(sac) = &self.sac {
            sac.validate().context("[sac]")?;
        }
        if let Some(td3) = &self.td3 {
            td3.validate().context("[td3]")?;
        }
        if let Some(d) = &self.defender
            && !d.filtered_cost.is_none()
            && self.safety.is_none()
        {
            bail!(
                "[defender] filtered_cost = \"{}\" charges the learner a cost, and this run's \
                 learner ignores costs: add a [safety] section (e.g. --lagrangian or --pid)",
                if d.filtered_cost == defender::FilteredCost::Violation {
                    "violation"
                } else {
                    "continuation"
                }
            );
        }
        if let Some(safety) = &self.safety {
            // The limit's range depends on the task: RunConfig::check_for_task.
            safety.validate().context("[safety]")?;
            if let (defender_rl::SafetyConfig::Lagrangian(_) | defender_rl::SafetyConfig::Pid(_), Algo::Td3) =
                (safety, self.algo)
            {
                bail!(
                    "[safety] method = \"{}\" is a Lagrangian SAC: it needs algo = \"sac\", not \"td3\"",
                    safety.method()
                );
            }
        }
        Ok(())
    }

    /// Checks the settings whose meaning depends on the task's safety signal, given the task's
    /// episode cost limit (`None`: a crash task, whose episode cost is 1 if it crashed, else 0):
    /// a Lagrangian `cost_limit` is a crash probability in [0, 1] on a crash task and a cost
    /// `> 0` per episode on a cost task; `[defender] episode_cost_limit` exists only on a cost task.
    ///
    /// # Errors
    /// The first setting that does not fit the task, naming its section, key and the task.
    pub fn check_for_task(&self, task_limit: Option<f64>) -> Result<()> {
        let env = &self.env;
        if let Some(safety) = &self.safety {
            match (safety, task_limit) {
                (_, None) => safety
                    .validate_for_crash_cost()
                    .with_context(|| format!("[safety] on {env}, whose episode cost is a crash (1 or 0)"))?,
                (
                    defender_rl::SafetyConfig::Lagrangian(defender_rl::safety::LagrangianConfig {
                        cost_limit,
                        ..
                    })
                    | defender_rl::SafetyConfig::Pid(defender_rl::safety::PidConfig { cost_limit, .. }),
                    Some(limit),
                ) if *cost_limit <= 0.0 => {
                    bail!(
                        "[safety] cost_limit = {cost_limit}: on {env}, a task with a per-step cost, it must be > 0                          (the mean episode cost to keep under; Safety-Gymnasium's is {limit})"
                    )
                }
                _ => {}
            }
        }
        if let Some(d) = &self.defender {
            let trigger = d.filter.trigger;
            let recovery = matches!(self.safety, Some(defender_rl::SafetyConfig::Recovery(_)));
            if trigger == defender::TriggerKind::RiskCritic && !recovery {
                bail!(
                    "[defender.filter] trigger = \"risk-critic\" with [safety] {}: the risk-critic trigger is \
                     Recovery RL's safety critic ending episodes; it needs [safety] method = \"recovery\" \
                     (gamma_risk, eps_risk, pretrain_steps, pos_fraction are its settings)",
                    self.safety.as_ref().map_or("absent", |s| s.method())
                );
            }
            if d.filtered_cost == defender::FilteredCost::Continuation && self.counterfactual.every != 1 {
                bail!(
                    "[defender] filtered_cost = \"continuation\" charges the learner the checked continuation's \
                     cost at every filtered step: it needs [counterfactual] every = 1 (--check-every 1), not {}",
                    self.counterfactual.every
                );
            }
            if trigger == defender::TriggerKind::Violation && task_limit.or(d.episode_cost_limit).is_none() {
                bail!(
                    "[defender.filter] trigger = \"violation\" ends an episode once its cost passes the limit: \
                     {env} is a crash task, where the violation itself ends the episode"
                );
            }
        }
        if let (Some(d), Some(safety)) = (&self.defender, &self.safety)
            && !d.filtered_cost.is_none()
        {
            // A filtered step is charged up to the episode limit plus one (1 on a crash task); the
            // continuation's cost is capped at cost_max, which must reach at least as far.
            let charged = d.episode_cost_limit.or(task_limit).unwrap_or(0.0) + 1.0;
            let cost_max = match safety {
                defender_rl::SafetyConfig::Lagrangian(l) => Some(l.cost_max),
                defender_rl::SafetyConfig::Pid(p) => Some(p.cost_max),
                _ => None,
            };
            if let Some(cost_max) = cost_max
                && cost_max < charged
            {
                bail!(
                    "[safety] cost_max = {cost_max}: with [defender] filtered_cost = \"{}\" on {env} a \
                     filtered step can cost the learner the episode limit plus one, {charged} (the \
                     continuation's cost is capped at cost_max); set cost_max to at least {charged} \
                     (--cost-max {charged})",
                    if d.filtered_cost == defender::FilteredCost::Violation {
                        "violation"
                    } else {
                        "continuation"
                    }
                );
            }
        }
        if let Some(d) = &self.defender
            && let (Some(given), None) = (d.episode_cost_limit, task_limit)
        {
            bail!(
                "[defender] episode_cost_limit = {given}: {env}'s safety is a crash (any crash is                  unsafe), not a per-step cost; leave the key out"
            );
        }
        Ok(())
    }

    /// Checks `num_demos` against the demonstration file the run will read (`demos`, else the
    /// one shipped for the task): at most the smaller of its two groups. `sizes` reads a file's
    /// `(safe, unsafe)` group sizes (a sweep reads each file once for all its runs).
    ///
    /// # Errors
    /// A file that cannot be read, or `num_demos` above what it holds.
    pub fn check_demonstrations(
        &self,
        sizes: &mut impl FnMut(&Path) -> Result<(usize, usize)>,
    ) -> Result<()> {
        let Some(d) = &self.defender else { return Ok(()) };
        // With no file known (an installed binary, no --demos), the run itself says so when built.
        let Some(path) = d.demos.clone().or_else(|| crate::shipped_demos(&self.env)) else {
            return Ok(());
        };
        let (safe, unsafe_) = sizes(&path)?;
        if let Some(n) = d.num_demos
            && n > safe.min(unsafe_)
        {
            bail!(
                "[defender] num_demos = {n}: {} holds {safe} safe and {unsafe_} unsafe demonstrations; \
                 give at most {}",
                path.display(),
                safe.min(unsafe_)
            );
        }
        Ok(())
    }
}

/// Reads a TOML run configuration, refusing unknown keys; its profile fills what it leaves out.
pub fn read_config(path: &Path) -> Result<RunConfig> {
    let text =
        defender_io::read_input_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    read_config_str(&text).with_context(|| format!("{}: not a valid run configuration", path.display()))
}

/// Parses a run configuration from TOML text, refusing unknown keys; its profile fills what it
/// leaves out.
pub fn read_config_str(text: &str) -> Result<RunConfig> {
    let given: toml::Table = toml::from_str(text)?;
    with_profile(&given, &given)
}

/// `table` (a configuration as written) with its profile's settings filled in where `given`
/// (what the user wrote) leaves them out, as a configuration.
pub fn with_profile(table: &toml::Table, given: &toml::Table) -> Result<RunConfig> {
    let mut table = table.clone();
    if let Some(profile) = given.get("profile") {
        table.insert("profile".into(), profile.clone());
    }
    crate::profile::expand(&mut table, given)?;
    Ok(RunConfig::deserialize(toml::Value::Table(table))?)
}

impl RunConfig {
    /// The agent's configuration.
    pub fn algo_config(&self) -> AlgoConfig {
        match self.algo {
            Algo::Sac => AlgoConfig::Sac(self.sac.clone().unwrap_or_default()),
            Algo::Td3 => AlgoConfig::Td3(self.td3.clone().unwrap_or_default()),
        }
    }
}

/// The `[defender]` section of a run configuration.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DefenderSection {
    /// `SAFE/UNSAFE` (SPEC section 3), or `auto` in a configuration given to `defender train`
    /// (chosen before training; `config.toml` then holds the choice and `selection`).
    pub strategy: StrategyChoice,
    /// `state` or `state-action`.
    #[serde(default)]
    pub mode: defender::Mode,
    /// The reward of a filtered step; resolved (from the demonstrations if not given) and saved.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_task: Option<f64>,
    /// Demonstrations per group (`None`: all of the file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub num_demos: Option<usize>,
    /// The demonstration set; `None`: the one shipped for the task.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demos: Option<PathBuf>,
    /// SHA-256 of the demonstration file's bytes, pinned when the run starts: a resumed run (or a
    /// configuration given with it) refuses a file whose content differs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demos_sha256: Option<String>,
    /// Options of the alignment cost (SPEC section 2).
    #[serde(default)]
    pub cost: CostSection,
    /// The filter's precision options (`[defender.filter]`: margin, budget, own episodes); absent
    /// or empty: SPEC section 4's filter.
    #[serde(default, skip_serializing_if = "defender::FilterOptions::is_spec")]
    pub filter: defender::FilterOptions,
    /// On a task whose safety is a cost, the episode cost past which an episode is unsafe
    /// (docs/SPEC.md, section 13); the run resolves it to the task's limit (25 on the velocity
    /// tasks) when left out, and `config.toml` records it. Absent on a crash task.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub episode_cost_limit: Option<f64>,
    /// What a filtered step costs the learner (docs/SPEC.md, section 14): `none` (absent) or
    /// `violation`, which needs a `[safety]` learner of costs.
    #[serde(default, skip_serializing_if = "defender::FilteredCost::is_none")]
    pub filtered_cost: defender::FilteredCost,
    /// The dynamics model (SPEC section 5).
    #[serde(default)]
    pub dynamics: defender::DynamicsConfig,
    /// How `strategy = "auto"` chose the strategy (`[defender.selection]`); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub selection: Option<defender_report::StrategySelection>,
}

/// `[defender.cost]` as a configuration gives it. `scaling` left out is SPEC section 2's plain
/// DTW for a given strategy, and for `strategy = "auto"` under SPEC's cost a choice between plain
/// and z-scored DTW made with the strategy's (docs/decisions.md, "z-scored DTW"); a started run's
/// `config.toml` always holds the scaling used, and every other option, default or not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostSection {
    /// `none` (plain DTW) or `zscore`; absent: see above.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scaling: Option<defender::Scaling>,
    /// `exact` (SPEC section 2) or `fastdtw` (the authors' code).
    #[serde(default)]
    pub dtw: defender::DtwKind,
    /// FastDTW's radius.
    #[serde(default = "default_radius")]
    pub radius: usize,
    /// `l2` (SPEC section 2) or `l1` (the `fastdtw` package's default).
    #[serde(default)]
    pub metric: defender::Metric,
    /// Align only the last N trajectory elements; absent: the whole trajectory (SPEC).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory_cap: Option<usize>,
    /// `spec` (state mode: the final observation included) or `per-transition`.
    #[serde(default)]
    pub elements: defender::Elements,
    /// `filter` (SPEC section 4) or `execute` (the authors' code).
    #[serde(default)]
    pub ties: defender::Ties,
}

fn default_radius() -> usize {
    defender::CostOptions::default().radius
}

impl Default for CostSection {
    fn default() -> Self {
        Self::from_options(defender::CostOptions::default(), None)
    }
}

impl CostSection {
    /// The section of `options`, with the scaling given or left to `auto`.
    pub fn from_options(options: defender::CostOptions, scaling: Option<defender::Scaling>) -> Self {
        let defender::CostOptions { scaling: _, dtw, radius, metric, trajectory_cap, elements, ties } =
            options;
        Self { scaling, dtw, radius, metric, trajectory_cap, elements, ties }
    }

    /// Checks every value's range (`trajectory_cap` at least 1, the radius bounded).
    ///
    /// # Errors
    /// The first bad value, naming its key.
    pub fn validate(&self) -> Result<()> {
        Ok(self.options().validate()?)
    }

    /// The method's cost options: an absent scaling is plain DTW.
    pub fn options(self) -> defender::CostOptions {
        let Self { scaling, dtw, radius, metric, trajectory_cap, elements, ties } = self;
        defender::CostOptions {
            scaling: scaling.unwrap_or_default(),
            dtw,
            radius,
            metric,
            trajectory_cap,
            elements,
            ties,
        }
    }

    /// The cost the configuration fixes, if it fixes one: `None` only for SPEC's cost with the
    /// scaling left out, where `strategy = "auto"` compares plain and z-scored DTW. Under any
    /// other option an absent scaling is plain DTW.
    pub fn given(self) -> Option<defender::CostOptions> {
        let spec = Self { scaling: self.scaling, ..Self::default() };
        (self.scaling.is_some() || self != spec).then(|| self.options())
    }
}

impl DefenderSection {
    /// A section with defaults for `strategy`.
    pub fn new(strategy: StrategyChoice) -> Self {
        Self {
            strategy,
            mode: defender::Mode::default(),
            r_task: None,
            num_demos: None,
            demos: None,
            demos_sha256: None,
            cost: Default::default(),
            filter: Default::default(),
            episode_cost_limit: None,
            filtered_cost: Default::default(),
            dynamics: Default::default(),
            selection: None,
        }
    }

    /// Checks every value's range (`num_demos` against the file: see
    /// [`RunConfig::check_demonstrations`]).
    ///
    /// # Errors
    /// The first bad value, naming its key and value.
    pub fn validate(&self) -> Result<()> {
        if self.num_demos == Some(0) {
            bail!("num_demos = 0: give at least 1 demonstration per group (or leave it out for all)");
        }
        if let Some(r) = self.r_task
            && !(r.is_finite() && r.abs() <= defender::MAX_ABS_R_TASK)
        {
            bail!(
                "r_task = {r:e} is out of range: it must be finite and at most {:e} in absolute \
                 value (it becomes a learning target; a huge value makes the critics diverge)",
                defender::MAX_ABS_R_TASK
            );
        }
        self.cost.validate().context("[defender.cost]")?;
        defender::UnsafeRule::from_limit(self.episode_cost_limit)?;
        self.filter.validate()?;
        self.dynamics.validate()?;
        Ok(())
    }

    /// The method crate's configuration.
    pub fn to_config(&self) -> Result<DefenderConfig> {
        Ok(DefenderConfig {
            strategy: self.strategy.fixed().context("strategy \"auto\" is chosen before the run is built")?,
            mode: self.mode,
            num_demos: self.num_demos,
            r_task: self.r_task,
            cost: self.cost.options(),
            filter: self.filter,
            episode_cost_limit: self.episode_cost_limit,
            filtered_cost: self.filtered_cost,
            dynamics: self.dynamics.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `config.toml` written by an earlier version (results/table1, before `demos_sha256`,
    /// `checkpoint_every_seconds` and the pinned copy existed).
    const TABLE1_IDP: &str = include_str!("../../defender-cli/tests/fixtures/idp-run/config.toml");

    /// Every key of `value` as `dotted.key = value` pairs.
    fn pairs(prefix: &str, value: &toml::Value, out: &mut Vec<(String, toml::Value)>) {
        match value {
            toml::Value::Table(t) => {
                for (k, v) in t {
                    pairs(&if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") }, v, out);
                }
            }
            other => out.push((prefix.to_string(), other.clone())),
        }
    }

    #[test]
    fn a_saved_config_parses_to_the_same_settings() {
        let config = read_config_str(TABLE1_IDP).unwrap();
        assert_eq!(config.env, "InvertedDoublePendulum-v5");
        assert_eq!(config.algo, Algo::Sac);
        assert_eq!(config.budget().unwrap(), Budget::Steps(30_000));
        assert_eq!(config.checkpoint_every_seconds, 120);
        let section = config.defender.as_ref().unwrap();
        assert_eq!(section.strategy.to_string(), "MeanDemoW5/MeanDemoW10");
        assert_eq!(section.mode, defender::Mode::State);
        assert_eq!(section.r_task, Some(-1.4209696054458618));
        assert_eq!(section.num_demos, Some(50));
        assert!(section.demos_sha256.is_none() && section.selection.is_none());
        let method = section.to_config().unwrap();
        assert_eq!(method.strategy.to_string(), "MeanDemoW5/MeanDemoW10");
        assert_eq!(method.dynamics.batch_size, 256);

        // Written back, every key of the file keeps its value; the only additions are defaults
        // of keys the file predates.
        let file: toml::Value = toml::from_str(TABLE1_IDP).unwrap();
        // As config.toml holds it: through the text (f32 settings are written in their shortest form).
        let text = toml::to_string_pretty(&config).unwrap();
        let written: toml::Value = toml::from_str(&text).unwrap();
        let (mut before, mut after) = (Vec::new(), Vec::new());
        pairs("", &file, &mut before);
        pairs("", &written, &mut after);
        for (key, value) in &before {
            assert_eq!(after.iter().find(|(k, _)| k == key).map(|(_, v)| v), Some(value), "{key}");
        }
        let added: Vec<&str> = after
            .iter()
            .filter(|(k, _)| !before.iter().any(|(b, _)| b == k))
            .map(|(k, _)| k.as_str())
            .collect();
        assert_eq!(
            added,
            [
                "checkpoint_every_seconds",
                "defender.cost.dtw",
                "defender.cost.elements",
                "defender.cost.metric",
                "defender.cost.radius",
                "defender.cost.ties",
                "profile",
                "sac.bc_form",
                "sac.bc_weight",
                "sac.demos_in_replay",
                "sac.terminal_on_truncation",
                "sac.warmup"
            ]
        );
        // And it reads back as itself (the pinned copy in a checkpoint is this text).
        let again = read_config_str(&text).unwrap();
        assert_eq!(toml::to_string_pretty(&again).unwrap(), text);
    }

    #[test]
    fn auto_and_unknown_keys() {
        let auto = TABLE1_IDP.replace("\"MeanDemoW5/MeanDemoW10\"", "\"auto\"");
        let config = read_config_str(&auto).unwrap();
        assert_eq!(config.defender.as_ref().unwrap().strategy, StrategyChoice::Auto);
        assert!(config.defender.unwrap().to_config().is_err());
        let unknown = TABLE1_IDP.replace("mode = \"state\"", "mode = \"state\"\nwindow = 5");
        let err = format!("{:#}", read_config_str(&unknown).unwrap_err());
        assert!(err.contains("window"), "{err}");
    }

    #[test]
    fn auto_keeps_the_strategy_and_the_scaling_it_chose() {
        let record = |scalings: &[&str]| defender_report::StrategySelection {
            chosen_by: "auto".into(),
            candidates: 441,
            equal: false,
            min_lead: 1,
            max_false_alarm: 0.1,
            safe_demos: 50,
            unsafe_demos: 50,
            false_alarm_rate: 0.0,
            crash_prevention_rate: 1.0,
            safe_allowed: 1.0,
            mean_lead: 5.0,
            score: 1.0,
            seconds: 1.0,
            scalings: scalings.iter().map(ToString::to_string).collect(),
        };
        // Started as `auto` with no scaling: the selection chose MinBothW5/MinBothW5, z-scored.
        let mut saved = read_config_str(TABLE1_IDP).unwrap();
        let d = saved.defender.as_mut().unwrap();
        d.strategy = StrategyChoice::Fixed("MinBothW5/MinBothW5".parse().unwrap());
        d.cost.scaling = Some(defender::Scaling::Zscore);
        d.selection = Some(record(&["none", "zscore"]));
        let unset = TABLE1_IDP
            .replace("\"MeanDemoW5/MeanDemoW10\"", "\"auto\"")
            .replace("[defender.cost]\nscaling = \"none\"\n", "");
        let request = read_config_str(&unset).unwrap();
        assert_eq!(request.defender.as_ref().unwrap().cost.scaling, None);
        let kept = request.clone().keeping_automatic_choice_of(&saved);
        let k = kept.defender.as_ref().unwrap();
        assert_eq!(k.strategy, saved.defender.as_ref().unwrap().strategy);
        assert_eq!(k.cost.scaling, Some(defender::Scaling::Zscore));
        assert!(crate::resume::differences(&saved, &kept, true).unwrap().is_empty());
        // A request that fixes another scaling is another run: the difference shows.
        let plain = read_config_str(&TABLE1_IDP.replace("\"MeanDemoW5/MeanDemoW10\"", "\"auto\"")).unwrap();
        let kept = plain.keeping_automatic_choice_of(&saved);
        let diffs = crate::resume::differences(&saved, &kept, true).unwrap();
        assert_eq!(diffs, ["defender.cost.scaling: \"zscore\" -> \"none\""]);
        // A given strategy with no scaling is plain DTW, and config.toml says so once resolved.
        let given =
            read_config_str(&unset.replace("strategy = \"auto\"", "strategy = \"MinBoth/MinBoth\"")).unwrap();
        assert_eq!(given.defender.as_ref().unwrap().cost.options(), defender::CostOptions::default());
    }
}
