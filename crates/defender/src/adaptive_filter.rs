//! The filter with its precision options (`[defender.filter]`, crate::filter_options): the
//! decision margin, the filtered-rate budget that adapts it, and the agent's own episodes joining
//! the demonstrations. Everything that changes does so between episodes, so a step costs what the
//! plain [`Filter`]'s does; `DefenderEnv` and the offline screen drive it the same way:
//! [`AdaptiveFilter::begin`], then per step [`AdaptiveFilter::push`] and (when executed)
//! [`AdaptiveFilter::executed`] and [`AdaptiveFilter::real_step`], then [`AdaptiveFilter::end`].

use std::collections::VecDeque;
use std::path::Path;

use serde::{Deserialize, Serialize};

use defender_rl::Outcome;

use crate::demonstrations::Demonstrations;
use crate::episode_set::{EpisodeSet, Meta};
use crate::error::{DefenderError, Result};
use crate::filter::{Decision, Filter};
use crate::filter_options::{FilterOptions, MAX_ADAPTIVE_MARGIN};
use crate::recorder::EpisodeRecorder;
use crate::strategy::Strategy;
use crate::violation::{UnsafeRule, ViolationTracker};

/// File names inside a checkpoint's environment directory.
const STATE_FILE: &str = "filter_state.json";
const OWN_FILE: &str = "own_episodes.npz";

/// What changes between episodes, for checkpoints.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
struct AdaptiveState {
    margin: f64,
}

/// A [`Filter`] whose margin and demonstration groups may change between episodes.
#[derive(Debug, Clone)]
pub struct AdaptiveFilter {
    base: Demonstrations,
    filter: Filter,
    options: FilterOptions,
    /// The agent's own episodes per group (`[0]` safe, `[1]` unsafe), oldest first; each a
    /// one-episode set. Empty unless `own_episodes` is on.
    own: [VecDeque<EpisodeSet>; 2],
    recorder: EpisodeRecorder,
    recording: bool,
    /// What makes an own episode unsafe, and the current episode against it.
    violation: ViolationTracker,
}

impl AdaptiveFilter {
    /// A filter for `strategy` over `demos` with `options` (validated here).
    ///
    /// # Errors
    /// Invalid options ([`DefenderError::Config`]) or as [`Filter::new`].
    pub fn new(demos: &Demonstrations, strategy: Strategy, options: FilterOptions) -> Result<Self> {
        options.validate()?;
        let mut filter = Filter::new(demos, strategy)?;
        filter.set_margin(options.margin);
        Ok(Self {
            base: demos.clone(),
            filter,
            options,
            own: [VecDeque::new(), VecDeque::new()],
            recorder: EpisodeRecorder::new(),
            recording: false,
            violation: ViolationTracker::new(UnsafeRule::Crash),
        })
    }

    /// The filter whose own episodes are labelled by `rule` (the crash rule unless set).
    pub fn with_rule(mut self, rule: UnsafeRule) -> Self {
        self.violation = ViolationTracker::new(rule);
        self
    }

    /// The filter as it stands (its demonstrations include the own episodes that joined).
    pub fn filter(&self) -> &Filter {
        &self.filter
    }

    /// The options.
    pub fn options(&self) -> FilterOptions {
        self.options
    }

    /// The decision margin in use.
    pub fn margin(&self) -> f64 {
        self.filter.margin()
    }

    /// Own episodes in the safe and unsafe groups.
    pub fn own_counts(&self) -> (usize, usize) {
        (self.own[0].len(), self.own[1].len())
    }

    /// Starts an episode whose first observation is `obs`.
    pub fn begin(&mut self, obs: &[f64]) {
        self.filter.reset();
        self.violation.reset();
        self.recording = self.options.own_episodes.is_some();
        if self.recording {
            self.recorder.start(obs);
        }
    }

    /// Step `t`: appends `s_t` (and `a_t`) to the trajectory and decides (as [`Filter::push`]).
    ///
    /// # Errors
    /// As [`Filter::push`].
    pub fn push(&mut self, obs: &[f64], action: &[f64]) -> Result<Decision> {
        self.filter.push(obs, action)
    }

    /// The step's action was executed: the environment gave `reward` and `next_obs`.
    ///
    /// # Errors
    /// Only with own episodes on: a recorder error (cannot happen after [`AdaptiveFilter::begin`]).
    pub fn executed(&mut self, action: &[f64], reward: f64, next_obs: &[f64]) -> Result<()> {
        // An unsafe episode is kept up to the step that made it so (crate::violation).
        if self.recording && !self.violation.violated() {
            self.recorder.step(action, reward, next_obs)?;
        }
        Ok(())
    }

    /// A step reached the environment (after [`AdaptiveFilter::executed`], if its transition was
    /// usable): it cost `cost` and ended the episode if `terminated`. Under a cost rule, the step
    /// whose cost passes the limit is the last one an own unsafe episode keeps.
    pub fn real_step(&mut self, cost: f64, terminated: bool) {
        self.violation.step(cost, terminated);
    }

    /// The episode ended with `outcome`: the budget moves the margin, and an episode that is
    /// unsafe (crate::violation) or reached the horizon joins its group (own episodes on). A
    /// filtered episode joins no group, unless its cost had already passed the limit: nobody knows
    /// how it would have ended. Nor does one truncated before the horizon the demonstrations were
    /// made with (their longest safe one), by a time limit shorter than the task's: it did not
    /// crash, but it is not safe by the rule the demonstrations follow; nor, under a cost rule,
    /// one the environment ended without passing the limit (a fall).
    ///
    /// # Errors
    /// Rebuilding the groups failed (a DTW error for an unusable episode, e.g. non-finite).
    pub fn end(&mut self, outcome: Outcome) -> Result<()> {
        if let Some(budget) = self.options.budget {
            let filtered = if outcome == Outcome::Filtered { 1.0 } else { 0.0 };
            let m = self.filter.margin() + (filtered - budget.share) / budget.episodes as f64;
            self.filter.set_margin(m.clamp(0.0, MAX_ADAPTIVE_MARGIN));
        }
        let recorded = std::mem::take(&mut self.recording);
        let (Some(own), true) = (self.options.own_episodes, recorded) else {
            return Ok(());
        };
        let cost_rule = matches!(self.violation_rule(), UnsafeRule::CostAbove(_));
        let crashed = match outcome {
            _ if cost_rule && self.violation.violated() => true,
            Outcome::Filtered => return Ok(()),
            Outcome::Crashed if cost_rule => return Ok(()),
            Outcome::Crashed => true,
            Outcome::Truncated if self.recorder.len() < self.base.safe_horizon() => return Ok(()),
            Outcome::Truncated => false,
        };
        if self.recorder.is_empty() {
            return Ok(());
        }
        let mut set = EpisodeSet::new(self.base.obs_dim(), self.base.act_dim(), Meta::default())?;
        self.recorder.finish(&mut set, crashed)?;
        let group = &mut self.own[usize::from(crashed)];
        if group.len() == own.keep {
            group.pop_front();
        }
        group.push_back(set);
        self.rebuild()
    }

    /// The step just executed made the episode unsafe: for a replay of labelled episodes
    /// (crate::screen), which knows where each unsafe one was cut but not its per-step costs.
    pub fn violated(&mut self) {
        self.violation.force();
    }

    fn violation_rule(&self) -> UnsafeRule {
        self.violation.rule()
    }

    /// The filter over the base demonstrations joined by the own episodes, keeping the margin.
    fn rebuild(&mut self) -> Result<()> {
        let [safe, unsafe_] = &self.own;
        let demos =
            self.base.joined(safe.iter().map(|s| s.episode(0)), unsafe_.iter().map(|s| s.episode(0)))?;
        let margin = self.filter.margin();
        self.filter = Filter::new(&demos, self.filter.strategy())?;
        self.filter.set_margin(margin);
        Ok(())
    }

    /// Writes what changed since construction into `dir` (at an episode boundary; nothing without
    /// precision options): the margin,
    /// and the own episodes as an episode set (`own_episodes.npz`, safe ones first, each group
    /// oldest first; no file before the first one joins, as an episode set is never empty).
    ///
    /// # Errors
    /// An I/O error naming the file.
    pub fn save(&self, dir: &Path) -> Result<()> {
        if self.options.is_spec() {
            return Ok(());
        }
        let state = AdaptiveState { margin: self.filter.margin() };
        let path = dir.join(STATE_FILE);
        let text = serde_json::to_vec_pretty(&state).map_err(|e| DefenderError::Config(e.to_string()))?;
        crate::atomic::write_atomic(&path, |w| {
            std::io::Write::write_all(w, &text).map_err(|e| DefenderError::io(&path, e))
        })?;
        if self.options.own_episodes.is_some() && self.own.iter().any(|g| !g.is_empty()) {
            let mut all = EpisodeSet::new(self.base.obs_dim(), self.base.act_dim(), Meta::default())?;
            for set in self.own.iter().flatten() {
                let e = set.episode(0);
                all.push_episode(e.obs, e.act, e.rew, e.crashed)?;
            }
            all.save(dir.join(OWN_FILE))?;
        }
        Ok(())
    }

    /// Restores what [`AdaptiveFilter::save`] wrote. A directory without the state file (a
    /// checkpoint of a run without these options) leaves the filter as constructed.
    ///
    /// # Errors
    /// An unreadable or malformed file, or own episodes beyond `keep`.
    pub fn load(&mut self, dir: &Path) -> Result<()> {
        let path = dir.join(STATE_FILE);
        if !path.exists() {
            return Ok(());
        }
        let text = std::fs::read(&path).map_err(|e| DefenderError::io(&path, e))?;
        let state: AdaptiveState = serde_json::from_slice(&text)
            .map_err(|e| DefenderError::Config(format!("{}: {e}", path.display())))?;
        if !(state.margin.is_finite() && (0.0..1.0).contains(&state.margin)) {
            return Err(DefenderError::Config(format!(
                "{}: margin = {} is outside [0, 1)",
                path.display(),
                state.margin
            )));
        }
        self.own = [VecDeque::new(), VecDeque::new()];
        if let Some(own) = self.options.own_episodes
            && dir.join(OWN_FILE).exists()
        {
            let all = EpisodeSet::load(dir.join(OWN_FILE))?;
            for e in all.episodes() {
                let mut set = EpisodeSet::new(all.obs_dim(), all.act_dim(), Meta::default())?;
                set.push_episode(e.obs, e.act, e.rew, e.crashed)?;
                self.own[usize::from(e.crashed)].push_back(set);
            }
            if self.own.iter().any(|g| g.len() > own.keep) {
                return Err(DefenderError::Config(format!(
                    "{}: more own episodes per group than keep = {}",
                    dir.join(OWN_FILE).display(),
                    own.keep
                )));
            }
        }
        self.rebuild()?;
        self.filter.set_margin(state.margin);
        Ok(())
    }
}
