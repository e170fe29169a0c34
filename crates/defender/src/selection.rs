//! Choosing the strategy automatically (docs/decisions.md, "Choosing the strategy
//! automatically"): rank strategies for one task from its demonstrations alone, by leave-one-out,
//! optionally combined with the ablation score (SPEC section 7) on recorded episodes of an agent.
//!
//! **Leave-one-out.** Every demonstration is replayed, step by step as the online filter sees a
//! trajectory, against a filter built from all the other demonstrations (its own group without it,
//! the other group whole). For each strategy:
//!
//! - a held-out *safe* demonstration that is filtered at any step is a **false alarm**: the filter
//!   would stop an agent that behaves like the demonstrator;
//! - a held-out *unsafe* demonstration of `T` transitions (it crashes after the last one) is a
//!   **prevented crash** when it is filtered at a step `k` with lead time `T - k >= min(L, T)`,
//!   `L` = [`SelectionConfig::min_lead`] (default 1: any step before the crash, as SPEC section 7
//!   counts a filtered crash as safe; an unsafe demonstration shorter than `L` must be filtered at
//!   its first step, as early as its ending allows).
//!
//! Per strategy: `false_alarm_rate` (held-out safe demonstrations filtered / safe ones),
//! `crash_prevention_rate` (prevented / unsafe ones), `safe_allowed` and `unsafe_allowed` (mean
//! fraction `(k + 1) / T` of each held-out demonstration executed before its first filtered step,
//! 1 when never filtered), `mean_lead` (mean `T - k` in steps over the prevented crashes, 0 when
//! none), and
//!
//! `demo_score = (1 - false_alarm_rate) x crash_prevention_rate`
//!
//! With recorded episodes, `ablation_score` is the SPEC-7 score of the strategy on them and
//! `score = demo_score x ablation_score`; without, `score = demo_score`.
//!
//! **Ranking.** A strategy is *eligible* when its false-alarm rate is at most
//! [`SelectionConfig::max_false_alarm`] (default 0.1) and below 1 (it never filters every
//! held-out safe demonstration, whatever the budget); eligible strategies rank first. Then: `score` highest first, ties by
//! `safe_allowed` (later false alarms cost less), then `unsafe_allowed` (of two strategies that
//! catch the same crashes, the one that waits longer is the less aggressive: it is less likely to
//! stop an agent whose early states resemble neither group), then the strategy's name. [`Selection::best`] is the first row if it is eligible.
//!
//! **Cost options.** [`SelectionConfig::costs`] lists the alignment costs compared (default SPEC
//! section 2's plain DTW alone). Each row is one strategy under one cost; the rows of every cost
//! are ranked together by the same order (the rates are measured on the same held-out
//! demonstrations, so they compare), a tie keeping the cost listed first. `strategy = "auto"`
//! with no scaling configured compares [`AUTO_COSTS`], plain and z-scored DTW (docs/decisions.md,
//! "z-scored DTW").
//!
//! The work is shared as in the ablation ([`crate::Ablation`]): one DTW stream per group computes
//! every window any strategy needs against all demonstrations at once, and leaving a
//! demonstration out only drops its column from the aggregations (bit for bit the filter built
//! without it). Demonstrations are replayed in parallel on rayon's pool.

use std::cmp::Ordering;
use std::io::Write;
use std::path::Path;

use crate::ablation::{Ablation, Progress};
use crate::atomic::{io_at, write_atomic};
use crate::demonstrations::{CostOptions, Demonstrations, Scaling};
use crate::episode_set::EpisodeSet;
use crate::error::{DefenderError, Result};
use crate::score::StrategyTally;
use crate::strategy::{Mode, Strategy};
use crate::window::Window;

/// The `strategy` of a run's configuration: a fixed `SAFE/UNSAFE` strategy, or `auto` (chosen by
/// [`select`] on the run's demonstrations before training). Written and parsed as that string.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StrategyChoice {
    /// `auto`: the best strategy of [`select`].
    Auto,
    /// A given strategy.
    Fixed(Strategy),
}

impl StrategyChoice {
    /// The fixed strategy; `None` for `auto`.
    pub fn fixed(self) -> Option<Strategy> {
        match self {
            StrategyChoice::Auto => None,
            StrategyChoice::Fixed(s) => Some(s),
        }
    }
}

impl From<Strategy> for StrategyChoice {
    fn from(s: Strategy) -> Self {
        StrategyChoice::Fixed(s)
    }
}

impl std::fmt::Display for StrategyChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StrategyChoice::Auto => f.write_str("auto"),
            StrategyChoice::Fixed(s) => s.fmt(f),
        }
    }
}

impl std::str::FromStr for StrategyChoice {
    type Err = DefenderError;
    fn from_str(s: &str) -> Result<Self> {
        if s == "auto" {
            return Ok(StrategyChoice::Auto);
        }
        s.parse().map(StrategyChoice::Fixed).map_err(|e| match e {
            DefenderError::UnknownName { kind, name, valid } => {
                DefenderError::UnknownName { kind, name, valid: format!("auto, or {valid}") }
            }
            other => other,
        })
    }
}

impl serde::Serialize for StrategyChoice {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl<'de> serde::Deserialize<'de> for StrategyChoice {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        let text = String::deserialize(deserializer)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

/// What [`select`] ranks and how.
#[derive(Debug, Clone, PartialEq)]
pub struct SelectionConfig {
    /// Trajectory elements: states or state-action pairs.
    pub mode: Mode,
    /// Use only the first N demonstrations of each group (as a run's `num_demos`); `None`: all.
    pub num_demos: Option<usize>,
    /// Include the strategies that use the `Equal` window (the only non-incremental one; it costs
    /// O(n^2) DTW cells per step and dominates the time).
    pub equal: bool,
    /// Rank only these strategies (`None`: all 576, or the 441 without `Equal`).
    pub strategies: Option<Vec<Strategy>>,
    /// `L`: the lead time, in steps before the crash, that a prevented crash needs (>= 1).
    pub min_lead: usize,
    /// The false-alarm budget: a strategy whose false-alarm rate exceeds it is not chosen
    /// (in [0, 1]; default 0.1).
    pub max_false_alarm: f64,
    /// The alignment costs compared (each strategy is ranked under each; default: plain DTW).
    pub costs: Vec<CostOptions>,
}

/// What `strategy = "auto"` compares when the run configures no scaling: SPEC section 2's plain
/// DTW first (it wins ties), then DTW on z-scored features.
pub const AUTO_COSTS: [CostOptions; 2] =
    [CostOptions::with_scaling(Scaling::None), CostOptions::with_scaling(Scaling::Zscore)];

impl Default for SelectionConfig {
    /// State mode, all demonstrations, all 576 strategies, `L = 1`, a 10% false-alarm budget,
    /// plain DTW alone.
    fn default() -> Self {
        Self {
            mode: Mode::State,
            num_demos: None,
            equal: true,
            strategies: None,
            min_lead: 1,
            max_false_alarm: 0.1,
            costs: vec![CostOptions::default()],
        }
    }
}

impl SelectionConfig {
    /// The selection `strategy = "auto"` makes before a run: the run's mode and `num_demos`,
    /// without the `Equal` window (minutes to hours before training starts), under the run's
    /// cost if it configures one, else comparing [`AUTO_COSTS`].
    pub fn for_run(mode: Mode, num_demos: Option<usize>, cost: Option<CostOptions>) -> Self {
        Self {
            mode,
            num_demos,
            equal: false,
            costs: cost.map_or_else(|| AUTO_COSTS.to_vec(), |c| vec![c]),
            ..Self::default()
        }
    }

    /// The strategies ranked, in the fixed order of [`Strategy::all`] (or the order given).
    pub fn candidates(&self) -> Vec<Strategy> {
        let mut list: Vec<Strategy> = match &self.strategies {
            Some(list) => list.clone(),
            None => Strategy::all().collect(),
        };
        if !self.equal {
            list.retain(|s| s.safe.window != Window::Equal && s.unsafe_.window != Window::Equal);
        }
        list
    }
}

/// One strategy's scores (a row of `selection.csv`, docs/run-directory.md).
#[derive(Debug, Clone, PartialEq)]
pub struct StrategyScore {
    /// 1-based rank.
    pub rank: usize,
    /// The strategy.
    pub strategy: Strategy,
    /// The trajectory mode.
    pub mode: Mode,
    /// The feature scaling of the alignment cost the strategy was scored under.
    pub scaling: Scaling,
    /// Held-out safe demonstrations filtered at some step / safe demonstrations.
    pub false_alarm_rate: f64,
    /// Held-out unsafe demonstrations filtered with the lead time required / unsafe ones.
    pub crash_prevention_rate: f64,
    /// Mean over held-out safe demonstrations of the fraction executed, `(k + 1) / T` or 1.
    pub safe_allowed: f64,
    /// Mean over held-out unsafe demonstrations of the fraction executed, `(k + 1) / T` or 1.
    pub unsafe_allowed: f64,
    /// Mean lead time `T - k` (steps) of the prevented crashes; 0 when none was prevented.
    pub mean_lead: f64,
    /// `(1 - false_alarm_rate) x crash_prevention_rate`.
    pub demo_score: f64,
    /// The SPEC-7 ablation score on the recorded episodes, when given.
    pub ablation_score: Option<f64>,
    /// `demo_score x ablation_score`, or `demo_score` without recorded episodes.
    pub score: f64,
    /// `false_alarm_rate <= max_false_alarm` and `< 1`. Only eligible strategies are chosen.
    pub eligible: bool,
}

/// The ranked strategies of one task.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// The trajectory mode.
    pub mode: Mode,
    /// Demonstrations per group used: (safe, unsafe).
    pub demos: (usize, usize),
    /// Recorded episodes scored by the ablation (0 when none were given).
    pub episodes: usize,
    /// `L`.
    pub min_lead: usize,
    /// The false-alarm budget.
    pub max_false_alarm: f64,
    /// Every strategy ranked, best first.
    pub rows: Vec<StrategyScore>,
}

impl Selection {
    /// The chosen strategy: the first row, unless no strategy is eligible (each one raises more
    /// false alarms than the budget allows, or filters every held-out safe demonstration).
    pub fn best(&self) -> Option<&StrategyScore> {
        self.rows.first().filter(|r| r.eligible)
    }

    /// The row of `strategy` under `scaling`, if it was ranked.
    pub fn get(&self, strategy: Strategy, scaling: Scaling) -> Option<&StrategyScore> {
        self.rows.iter().find(|r| r.strategy == strategy && r.scaling == scaling)
    }

    /// The best row under `scaling`, if one is eligible.
    pub fn best_under(&self, scaling: Scaling) -> Option<&StrategyScore> {
        self.rows.iter().find(|r| r.scaling == scaling).filter(|r| r.eligible)
    }

    /// Writes the rows as `selection.csv` (header [`SELECTION_CSV_HEADER`]), atomically; numbers in
    /// Rust's shortest round-trip form, an empty `ablation_score` without recorded episodes.
    ///
    /// # Errors
    /// An I/O error.
    pub fn write_csv(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        write_atomic(path, |w| {
            writeln!(w, "{SELECTION_CSV_HEADER}").map_err(io_at(path))?;
            for r in &self.rows {
                writeln!(
                    w,
                    "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                    r.rank,
                    r.strategy,
                    r.strategy.safe,
                    r.strategy.unsafe_,
                    r.mode,
                    r.scaling,
                    r.false_alarm_rate,
                    r.crash_prevention_rate,
                    r.safe_allowed,
                    r.unsafe_allowed,
                    r.mean_lead,
                    r.demo_score,
                    r.ablation_score.map_or(String::new(), |v| v.to_string()),
                    r.score,
                    r.eligible
                )
                .map_err(io_at(path))?;
            }
            Ok(())
        })
    }
}

/// The header of `selection.csv`.
pub const SELECTION_CSV_HEADER: &str = "rank,strategy,safe_method,unsafe_method,mode,scaling,false_alarm_rate,\
crash_prevention_rate,safe_allowed,unsafe_allowed,mean_lead,demo_score,ablation_score,score,eligible";

/// Per-strategy sums over held-out demonstrations.
#[derive(Debug, Clone, Copy, Default)]
struct Tally {
    safe: usize,
    unsafe_: usize,
    false_alarms: usize,
    prevented: usize,
    safe_allowed: f64,
    unsafe_allowed: f64,
    lead: f64,
}

impl Tally {
    fn add(&mut self, len: usize, crashed: bool, first_filtered: Option<usize>, min_lead: usize) {
        let allowed = first_filtered.map_or(1.0, |k| (k + 1) as f64 / len as f64);
        if crashed {
            self.unsafe_ += 1;
            self.unsafe_allowed += allowed;
            if let Some(k) = first_filtered
                && len - k >= min_lead.min(len)
            {
                self.prevented += 1;
                self.lead += (len - k) as f64;
            }
        } else {
            self.safe += 1;
            self.safe_allowed += allowed;
            self.false_alarms += usize::from(first_filtered.is_some());
        }
    }

    fn score(
        &self,
        strategy: Strategy,
        mode: Mode,
        scaling: Scaling,
        ablation_score: Option<f64>,
        max_fa: f64,
    ) -> StrategyScore {
        let rate = |k: usize, n: usize| k as f64 / n.max(1) as f64;
        let false_alarm_rate = rate(self.false_alarms, self.safe);
        let crash_prevention_rate = rate(self.prevented, self.unsafe_);
        let demo_score = (1.0 - false_alarm_rate) * crash_prevention_rate;
        StrategyScore {
            rank: 0,
            strategy,
            mode,
            scaling,
            false_alarm_rate,
            crash_prevention_rate,
            safe_allowed: self.safe_allowed / self.safe.max(1) as f64,
            unsafe_allowed: self.unsafe_allowed / self.unsafe_.max(1) as f64,
            mean_lead: if self.prevented == 0 { 0.0 } else { self.lead / self.prevented as f64 },
            demo_score,
            ablation_score,
            score: demo_score * ablation_score.unwrap_or(1.0),
            eligible: self.false_alarms < self.safe && false_alarm_rate <= max_fa,
        }
    }
}

/// The ranking order of the module documentation.
fn order(a: &StrategyScore, b: &StrategyScore) -> Ordering {
    b.eligible
        .cmp(&a.eligible)
        .then_with(|| b.score.total_cmp(&a.score))
        .then_with(|| b.safe_allowed.total_cmp(&a.safe_allowed))
        .then_with(|| b.unsafe_allowed.total_cmp(&a.unsafe_allowed))
        .then_with(|| a.strategy.to_string().cmp(&b.strategy.to_string()))
}

/// Sorts rows by the ranking order (stably: a tie keeps the given order) and numbers them 1, 2, ...
pub fn rank_selection(mut rows: Vec<StrategyScore>) -> Vec<StrategyScore> {
    rows.sort_by(order);
    for (i, r) in rows.iter_mut().enumerate() {
        r.rank = i + 1;
    }
    rows
}

/// Ranks the strategies of `config` for the task of `demos` by leave-one-out over its
/// demonstrations, combined with the SPEC-7 ablation score on `episodes` when given (module
/// documentation), under each of `config.costs`. `progress` is called after each replayed
/// demonstration and episode (from worker threads); `total` counts both, once per cost.
///
/// # Errors
/// A missing group; fewer than two demonstrations in a group (leave-one-out needs another one);
/// `num_demos` larger than a group; `min_lead = 0`; `max_false_alarm` outside [0, 1] or NaN; no
/// strategy to rank; no cost, or one listed twice; recorded episodes of another task (dimensions
/// or env id) or an empty episode set.
pub fn select(
    demos: &EpisodeSet,
    episodes: Option<&EpisodeSet>,
    config: &SelectionConfig,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<Selection> {
    demos.require_both_groups()?;
    let chosen;
    let demos = match config.num_demos {
        Some(n) => {
            chosen = demos.select_demos(n)?;
            &chosen
        }
        None => demos,
    };
    let (n_safe, n_unsafe) = demos.group_sizes();
    for (group, n) in [("safe", n_safe), ("unsafe", n_unsafe)] {
        if n < 2 {
            // With num_demos given, that is the setting to change; otherwise the file.
            let fix = match config.num_demos {
                Some(k) => format!("num_demos = {k}: give at least 2"),
                None => "add demonstrations to the file".to_string(),
            };
            return Err(DefenderError::Config(format!(
                "{}: the {group} group has {n} demonstration; choosing a strategy by leave-one-out \
                 needs at least 2 per group ({fix})",
                demos.source().display()
            )));
        }
    }
    if config.min_lead == 0 {
        return Err(DefenderError::Config("min_lead must be >= 1 (steps before the crash)".into()));
    }
    if !(0.0..=1.0).contains(&config.max_false_alarm) {
        return Err(DefenderError::Config(format!(
            "max_false_alarm must be a rate in [0, 1], got {}",
            config.max_false_alarm
        )));
    }
    let candidates = config.candidates();
    if candidates.is_empty() {
        return Err(DefenderError::Config("no strategy to rank".into()));
    }
    if config.costs.is_empty() {
        return Err(DefenderError::Config("no alignment cost to rank the strategies under".into()));
    }
    if let Some((i, c)) = config.costs.iter().enumerate().find(|(i, c)| config.costs[..*i].contains(c)) {
        return Err(DefenderError::Config(format!("alignment cost {} listed twice ({c:?})", i + 1)));
    }
    if let Some(episodes) = episodes {
        let env_id = demos
            .meta()
            .env_id
            .as_deref()
            .or(episodes.meta().env_id.as_deref())
            .unwrap_or("the demonstrations");
        episodes.check_env(env_id, demos.obs_dim(), demos.act_dim())?;
    }
    let per_cost = demos.len() + episodes.map_or(0, EpisodeSet::len);
    let total = per_cost * config.costs.len();
    let mut rows = Vec::with_capacity(candidates.len() * config.costs.len());
    for (i, &cost) in config.costs.iter().enumerate() {
        let offset = i * per_cost;
        let overall = |p: Progress| progress(Progress { done: offset + p.done, total, ..p });
        rows.extend(score_under(demos, episodes, config, cost, &candidates, &overall)?);
    }
    Ok(Selection {
        mode: config.mode,
        demos: (n_safe, n_unsafe),
        episodes: episodes.map_or(0, EpisodeSet::len),
        min_lead: config.min_lead,
        max_false_alarm: config.max_false_alarm,
        rows: rank_selection(rows),
    })
}

/// The rows of every candidate under one alignment cost (unranked); `progress` counts the
/// demonstrations, then the episodes.
fn score_under(
    demos: &EpisodeSet,
    episodes: Option<&EpisodeSet>,
    config: &SelectionConfig,
    cost: CostOptions,
    candidates: &[Strategy],
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<Vec<StrategyScore>> {
    let prepared = Demonstrations::new(demos, config.mode, cost)?;
    let ablation = Ablation::new(&prepared, candidates)?;
    let strategies = ablation.strategies();

    let replays = ablation.replay_held_out(demos, progress)?;
    let mut tallies = vec![Tally::default(); strategies.len()];
    for (_, r) in &replays {
        for (tally, k) in tallies.iter_mut().zip(&r.first_filtered) {
            tally.add(r.len, r.crashed, *k, config.min_lead);
        }
    }

    let ablation_scores: Option<Vec<f64>> = match episodes {
        None => None,
        Some(episodes) => {
            let offset = demos.len();
            let recorded =
                ablation.replay_all(episodes, &|p| progress(Progress { done: offset + p.done, ..p }))?;
            let mut t = vec![StrategyTally::default(); strategies.len()];
            for r in &recorded {
                for (tally, k) in t.iter_mut().zip(&r.first_filtered) {
                    tally.add(r.len, r.crashed, *k);
                }
            }
            Some(t.iter().zip(strategies).map(|(t, &s)| t.row(s, config.mode).score).collect())
        }
    };
    Ok(strategies
        .iter()
        .enumerate()
        .map(|(i, &s)| {
            let ablation_score = ablation_scores.as_ref().map(|a| a[i]);
            tallies[i].score(s, config.mode, cost.scaling, ablation_score, config.max_false_alarm)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tally(entries: &[(usize, bool, Option<usize>)], min_lead: usize) -> StrategyScore {
        let mut t = Tally::default();
        for &(len, crashed, k) in entries {
            t.add(len, crashed, k, min_lead);
        }
        t.score("MinBoth/MinBoth".parse().unwrap(), Mode::State, Scaling::None, None, 1.0)
    }

    #[test]
    fn strategy_choices_parse_and_print() {
        assert_eq!("auto".parse::<StrategyChoice>().unwrap(), StrategyChoice::Auto);
        let s: StrategyChoice = "MeanDemoW5/MeanDemoW10".parse().unwrap();
        assert_eq!(s.fixed(), Some("MeanDemoW5/MeanDemoW10".parse().unwrap()));
        assert_eq!(s.to_string(), "MeanDemoW5/MeanDemoW10");
        assert_eq!(StrategyChoice::Auto.to_string(), "auto");
        let err = "Auto".parse::<StrategyChoice>().unwrap_err().to_string();
        assert!(err.contains("auto, or SAFE/UNSAFE"), "{err}");
        assert_eq!(serde_json::to_string(&StrategyChoice::Auto).unwrap(), "\"auto\"");
        let parsed: StrategyChoice = serde_json::from_str("\"MinBoth/MinBoth\"").unwrap();
        assert_eq!(parsed, StrategyChoice::Fixed("MinBoth/MinBoth".parse().unwrap()));
    }

    #[test]
    fn rates_follow_the_definitions() {
        let r = tally(
            &[
                (10, false, None),    // safe, passes
                (10, false, Some(9)), // safe, filtered at its last step: a false alarm
                (10, true, Some(4)),  // crash prevented, lead 6
                (10, true, None),     // crash missed
                (10, true, Some(9)),  // lead 1
                (4, true, Some(0)),   // lead 4
            ],
            1,
        );
        assert_eq!(r.false_alarm_rate, 0.5);
        assert_eq!(r.crash_prevention_rate, 0.75);
        assert_eq!(r.safe_allowed, 1.0);
        assert_eq!(r.unsafe_allowed, (0.5 + 1.0 + 1.0 + 0.25) / 4.0);
        assert_eq!(r.mean_lead, (6.0 + 1.0 + 4.0) / 3.0);
        assert_eq!(r.demo_score, 0.5 * 0.75);
        assert!(r.eligible);
    }

    #[test]
    fn lead_time_is_required_as_far_as_the_ending_allows() {
        // L = 5: filtered at k = 6 of 10 has lead 4 (missed); k = 5 has lead 5 (prevented); a
        // 3-step demonstration needs its first step.
        let r = tally(&[(10, true, Some(6)), (10, true, Some(5)), (3, true, Some(0)), (3, true, Some(1))], 5);
        assert_eq!(r.crash_prevention_rate, 0.5);
        let all_alarms = tally(&[(10, false, Some(3)), (10, true, Some(0))], 1);
        assert!(!all_alarms.eligible);
        assert_eq!(all_alarms.demo_score, 0.0);
    }

    #[test]
    fn ineligible_strategies_rank_last_and_ties_go_by_name() {
        let mut a = tally(&[(10, false, None), (10, true, Some(2))], 1);
        a.strategy = "MaxBoth/MinBoth".parse().unwrap();
        let mut b = a.clone();
        b.strategy = "MeanBoth/MinBoth".parse().unwrap();
        let mut c = tally(&[(10, false, Some(0)), (10, true, Some(2))], 1);
        c.score = 2.0; // even with a higher score
        let rows = rank_selection(vec![c, b, a]);
        let names: Vec<String> = rows.iter().map(|r| format!("{} {}", r.rank, r.strategy)).collect();
        assert_eq!(names, ["1 MaxBoth/MinBoth", "2 MeanBoth/MinBoth", "3 MinBoth/MinBoth"]);
        // The same strategy scored alike under two costs: the cost listed first wins the tie.
        let plain = tally(&[(10, false, None), (10, true, Some(2))], 1);
        let z = StrategyScore { scaling: Scaling::Zscore, ..plain.clone() };
        assert_eq!(rank_selection(vec![plain.clone(), z.clone()])[0].scaling, Scaling::None);
        assert_eq!(rank_selection(vec![z, plain])[0].scaling, Scaling::Zscore);
    }
}
