//! The safe-RL field's cost measures, for a task whose every step may cost (Safety-Gymnasium's
//! velocity tasks) and whose runs are held to an episode cost limit (25 there, OmniSafe's
//! benchmark setting): the cost rate of training, the evaluation cost (and, from
//! `eval_episodes.csv`, the share of evaluation episodes within the limit: `crate::eval_episodes`),
//! and the training episodes over the limit, counted and as a share. A crash task costs at most 1
//! an episode; it is read through its crashes instead (`crate::violations`) and has no limit here.
//!
//! The limits are not this crate's to know: they belong to the task registry of
//! defender-mujoco, which needs the MuJoCo runtime. Whoever builds a report passes them in
//! ([`CostLimits`], e.g. `defender report` from the registry); a run whose `summary.json` records
//! its task's limit brings it along too.

use std::collections::BTreeMap;

use crate::measures::LAST_EVALUATIONS;
use crate::run::Run;
use crate::stats::Estimate;

/// The episode cost limit of each task that has one, by Gymnasium id. A task not in it (every
/// crash task) has no cost columns and no cost plots.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CostLimits {
    limits: BTreeMap<String, f64>,
}

impl CostLimits {
    /// No task has a limit (but a run whose `summary.json` records one: [`CostLimits::of_runs`]).
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets the limit of the task `env`.
    pub fn insert(&mut self, env: impl Into<String>, limit: f64) {
        self.limits.insert(env.into(), limit);
    }

    /// The limit of the task `env`, if it has one.
    pub fn get(&self, env: &str) -> Option<f64> {
        self.limits.get(env).copied()
    }

    /// The limit of the task `env` whose runs are `runs`: the one given for the task, else the
    /// one the first of its runs recorded in `summary.json`.
    pub fn of_runs<'r>(&self, env: &str, runs: impl IntoIterator<Item = &'r Run>) -> Option<f64> {
        self.get(env).or_else(|| runs.into_iter().find_map(|r| r.summary.episode_cost_limit))
    }
}

impl<S: Into<String>> FromIterator<(S, f64)> for CostLimits {
    fn from_iter<I: IntoIterator<Item = (S, f64)>>(iter: I) -> Self {
        let mut limits = Self::new();
        iter.into_iter().for_each(|(env, limit)| limits.insert(env, limit));
        limits
    }
}

/// The cost columns of a row of a task with an episode cost limit, over the row's seeds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostColumns {
    /// The task's episode cost limit.
    pub limit: f64,
    /// Cost rate: total training cost / environment steps of training, filtered steps not
    /// counted ([`crate::Violations::cost_rate`]).
    pub cost_rate: Estimate,
    /// Evaluation cost (last-10): [`Run::eval_cost`]; `None` when no run of the row has an
    /// evaluation with a cost.
    pub eval_cost: Option<Estimate>,
    /// Eval episodes cost <= L (last-10): [`Run::eval_within_limit`], over the seeds whose runs
    /// have `eval_episodes.csv`; `None` when none has.
    pub eval_within_limit: Option<Estimate>,
    /// Shielded episodes cost <= L (last-10): [`Run::shield_within_limit`], over the seeds whose
    /// runs have shielded episodes in `eval_episodes.csv`; `None` when none has.
    pub shield_within_limit: Option<Estimate>,
    /// Episodes over the limit, counted: [`Run::over_limit`].
    pub over_limit: Estimate,
    /// % episodes over the limit: [`Run::over_limit_pct`].
    pub over_limit_pct: Estimate,
}

impl CostColumns {
    /// The columns of `runs` (one row's seeds) under `limit`; `None` without runs.
    pub fn of(limit: f64, runs: &[&Run]) -> Option<Self> {
        let values = |f: &dyn Fn(&Run) -> f64| -> Vec<f64> { runs.iter().map(|r| f(r)).collect() };
        let some =
            |f: &dyn Fn(&Run) -> Option<f64>| -> Vec<f64> { runs.iter().filter_map(|r| f(r)).collect() };
        Some(Self {
            limit,
            cost_rate: Estimate::of(&values(&|r| r.violations().cost_rate))?,
            eval_cost: Estimate::of(&some(&|r| r.eval_cost())),
            eval_within_limit: Estimate::of(&some(&|r| r.eval_within_limit(limit))),
            shield_within_limit: Estimate::of(&some(&|r| r.shield_within_limit(limit))),
            over_limit: Estimate::of(&values(&|r| r.over_limit(limit) as f64))?,
            over_limit_pct: Estimate::of(&values(&|r| r.over_limit_pct(limit)))?,
        })
    }

    /// Whether the row has a share of evaluation episodes within the limit (its runs, or some of
    /// them, have `eval_episodes.csv`).
    pub fn has_eval_episodes(&self) -> bool {
        self.eval_within_limit.is_some() || self.shield_within_limit.is_some()
    }
}

impl Run {
    /// Evaluation cost (last-10): the mean `mean_cost` of the run's last [`LAST_EVALUATIONS`]
    /// evaluations that have one (rows of files written before costs existed have none; all of
    /// them when there are fewer), as "Last-10 eval" averages the return; `None` when no
    /// evaluation has a cost.
    pub fn eval_cost(&self) -> Option<f64> {
        let costs: Vec<f64> = self.evaluations.iter().filter_map(|e| e.mean_cost).collect();
        let last = &costs[costs.len().saturating_sub(LAST_EVALUATIONS)..];
        (!last.is_empty()).then(|| last.iter().sum::<f64>() / last.len() as f64)
    }

    /// Episodes over the limit: the training episodes whose cost exceeds `limit` (strictly: an
    /// episode at the limit kept the constraint).
    pub fn over_limit(&self, limit: f64) -> usize {
        self.episodes.iter().filter(|e| e.cost > limit).count()
    }

    /// % episodes over the limit: [`Run::over_limit`] / all training episodes x 100; 0 for a run
    /// without episodes. Like the paper's % Crash, the episodes a filter ends join the
    /// denominator, so a filter that cuts episodes short lowers it without fewer violations;
    /// [`Run::over_limit`] counts them.
    pub fn over_limit_pct(&self, limit: f64) -> f64 {
        let over = self.over_limit(limit);
        if self.episodes.is_empty() { 0.0 } else { 100.0 * over as f64 / self.episodes.len() as f64 }
    }
}
