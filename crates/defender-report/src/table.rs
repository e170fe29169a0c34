//! The paper's tables (Tables 1 and 2) as data: one row per task x algorithm x budget x strategy,
//! aggregated over seeds (SPEC section 6).

use std::collections::{BTreeMap, BTreeSet};

use defender::Mode;
use defender_rl::Budget;

use crate::costs::{CostColumns, CostLimits};
use crate::intervention_columns::{InterventionColumns, filtered_episodes};
use crate::run::{DefenderSettings, Run};
use crate::shield::ShieldColumns;
use crate::stats::{Estimate, Stat};

/// One row of the table: a task, an algorithm, a budget and a strategy (or none: the bare
/// algorithm), over the seeds run.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Gymnasium id, e.g. `Hopper-v5`.
    pub env: String,
    /// `sac` or `td3`.
    pub algo: String,
    /// The training budget.
    pub budget: Budget,
    /// `None` for the bare algorithm.
    pub filter: Option<DefenderSettings>,
    /// The seeds, ascending.
    pub seeds: Vec<u64>,
    /// Acc Reward (final eval), SPEC section 6: the mean return of the final evaluation.
    pub acc_reward: Estimate,
    /// Best episode (the paper's Acc Reward, as its authors' code computes it): the best single
    /// training-episode return of each run ([`Run::best_episode`]); `None` when no run of the row
    /// has a training episode, otherwise over the seeds that have one.
    pub best_episode: Option<Estimate>,
    /// Last-10 eval: the mean return of each run's last 10 evaluations
    /// ([`Run::last_evaluations`]).
    pub last_evaluations: Estimate,
    /// % Crash: crashed / all training episodes x 100 (the paper's measure).
    pub crash_pct: Estimate,
    /// Crashes: crashed training episodes over the run (the field's count).
    pub crashes: Estimate,
    /// Filtered (interventions): training episodes DEFENDER ended over the run (`metrics.csv`'s
    /// outcome `filtered`), whether or not the runs wrote `interventions.csv`; `None` for a row
    /// without a filter.
    pub filtered: Option<Estimate>,
    /// Crashes after the warm-up: crashed training episodes ending after the learner's random
    /// warm-up ([`Run::crashed_after_warmup`]), over the seeds whose configuration gives it;
    /// `None` when none does.
    pub crashes_after_warmup: Option<Estimate>,
    /// Crashes per 1,000 environment steps of training (filtered steps are not environment
    /// steps: crate::violations).
    pub crashes_per_1k: Estimate,
    /// Standing %: the share of each run's evaluations in which the agent stood still
    /// ([`Run::standing_pct`]); `None` for a task whose horizon the report does not know.
    pub standing_pct: Option<Estimate>,
    /// Filtered / all training episodes x 100 (0 for the bare algorithm).
    pub filtered_pct: Stat,
    /// Wall-clock seconds of the runs.
    pub wall_seconds: Stat,
    /// % Time: per seed, this run's wall-clock time / that of the bare run with the same task,
    /// algorithm, budget and seed x 100; over the seeds that have such a bare run. `None` when
    /// no seed has one.
    pub time_pct: Option<Stat>,
    /// The field's cost measures, for a task with an episode cost limit ([`TableOptions`]);
    /// `None` for the others (the crash tasks).
    pub costs: Option<CostColumns>,
    /// The evaluations with the filter kept, over the seeds that have them (DEFENDER runs);
    /// `None` for a row without (a bare row, or runs from before they existed).
    pub shield: Option<ShieldColumns>,
    /// The interventions checked against their unfiltered continuation, over the seeds with
    /// `interventions.csv`; `None` for a row without it (a bare row, or runs from before it
    /// existed).
    pub interventions: Option<InterventionColumns>,
}

impl Row {
    /// `Hopper-v5 SAC (400 steps)`, or `Hopper-v5 SAC MeanDemoW5/MeanDemoW10 (state, 400 steps)`:
    /// for notes and warnings.
    pub fn label(&self) -> String {
        let algo = crate::run::algo_display(&self.algo);
        match &self.filter {
            None => format!("{} {algo} ({})", self.env, self.budget),
            Some(f) => format!("{} {algo} {} ({}, {})", self.env, f.name(), f.mode, self.budget),
        }
    }

    /// The trajectory mode, `None` for the bare algorithm.
    pub fn mode(&self) -> Option<Mode> {
        self.filter.as_ref().map(|f| f.mode)
    }
}

/// The table: rows ordered by task, algorithm, budget, then the bare algorithm first and its
/// DEFENDER strategies after it (state mode before state-action, strategies by name), with notes
/// about what could not be computed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// The rows.
    pub rows: Vec<Row>,
    /// Notes for the reader (missing bare runs for % Time).
    pub notes: Vec<String>,
}

/// The labels of the agent under a row's filter, nearest first: the row's own label, then with
/// its last tag dropped, one at a time, down to the bare algorithm (`sac (keeps-learning,
/// margin-trigger0.5)`, `sac (keeps-learning)`, `sac`). `crate::label::algo_label` writes the
/// profile's and the demonstrations' tags before the filter's options, so the filter's go first;
/// the % Time column keeps its own, older rule (the own label, else the bare algorithm).
fn agent_labels(label: &str) -> Vec<String> {
    let (algo, tags) = crate::run::label_parts(label);
    let tags: Vec<&str> = tags.map_or_else(Vec::new, |t| t.split(", ").collect());
    (0..=tags.len())
        .rev()
        .map(|k| if k == 0 { algo.to_string() } else { format!("{algo} ({})", tags[..k].join(", ")) })
        .collect()
}

/// What a table is built with besides the runs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TableOptions {
    /// The episode cost limit of each per-step cost task: its rows get the cost columns.
    pub cost_limits: CostLimits,
}

type GroupKey = (String, String, Budget, Option<(Mode, String, Option<u64>, bool, bool)>);

impl Table {
    /// Aggregates `runs` over seeds, with no cost limit but the ones the runs' summaries record.
    pub fn from_runs(runs: &[Run]) -> Table {
        Table::from_runs_with(runs, &TableOptions::default())
    }

    /// Aggregates `runs` over seeds; a row of a task with a cost limit in `options` (or recorded
    /// by its runs) gets the cost columns.
    pub fn from_runs_with(runs: &[Run], options: &TableOptions) -> Table {
        let mut groups: BTreeMap<GroupKey, Vec<&Run>> = BTreeMap::new();
        for run in runs {
            let c = &run.config;
            let filter =
                c.filter.as_ref().map(|f| (f.mode, f.strategy.clone(), f.num_demos, f.auto, f.zscore));
            groups.entry((c.env.clone(), c.algo.clone(), c.budget, filter)).or_default().push(run);
        }
        // Wall-clock time of each bare run, by (task, algorithm, budget, seed).
        let bare: BTreeMap<(&str, &str, Budget, u64), f64> = runs
            .iter()
            .filter(|r| r.config.filter.is_none())
            .map(|r| {
                let c = &r.config;
                ((c.env.as_str(), c.algo.as_str(), c.budget, c.seed), r.summary.wall_seconds)
            })
            .collect();

        let mut table = Table::default();
        // BTreeMap order is the table's order: `None` (bare) sorts before `Some(..)`.
        for ((env, algo, budget, _), mut group) in groups {
            group.sort_by_key(|r| r.config.seed);
            let values = |f: &dyn Fn(&Run) -> f64| -> Vec<f64> { group.iter().map(|r| f(r)).collect() };
            let seeds: Vec<u64> = group.iter().map(|r| r.config.seed).collect();
            let mut missing = BTreeSet::new();
            let mut ratios = Vec::new();
            // A filtered row: the bare run of the same agent (`sac (authors)` for the authors'
            // profile), else plain bare SAC or TD3 (an arm whose label names its filter options
            // has no bare run of its own: its agent is the algorithm's). An unfiltered row that
            // changes the agent (a baseline: penalty, Lagrangian, Recovery RL, the demonstrations
            // alone; a peer's SAC; the authors' SAC): plain bare SAC or TD3, else itself, so that
            // what the change costs shows rather than a row timed against itself.
            let base = crate::run::label_parts(&algo).0;
            let unfiltered = group[0].config.filter.is_none();
            for run in &group {
                let seed = run.config.seed;
                let own = bare.get(&(env.as_str(), algo.as_str(), budget, seed));
                let plain = bare.get(&(env.as_str(), base, budget, seed));
                let reference = if unfiltered { plain.or(own) } else { own.or(plain) };
                match reference {
                    Some(bare_wall) => ratios.push(run.summary.wall_seconds / bare_wall * 100.0),
                    None => {
                        missing.insert(run.config.seed);
                    }
                }
            }
            let some =
                |f: &dyn Fn(&Run) -> Option<f64>| -> Vec<f64> { group.iter().filter_map(|r| f(r)).collect() };
            let (
                Some(acc_reward),
                Some(last_evaluations),
                Some(crash_pct),
                Some(crashes),
                Some(crashes_per_1k),
                Some(filtered_pct),
                Some(wall_seconds),
            ) = (
                Estimate::of(&values(&|r| r.acc_reward())),
                Estimate::of(&values(&|r| r.last_evaluations())),
                Estimate::of(&values(&|r| r.summary.crash_pct)),
                Estimate::of(&values(&|r| r.violations().crashes as f64)),
                Estimate::of(&values(&|r| r.violations().crashes_per_1k_env_steps)),
                Stat::of(&values(&|r| r.summary.filtered_pct)),
                Stat::of(&values(&|r| r.summary.wall_seconds)),
            )
            else {
                continue; // unreachable: a group has at least one run
            };
            let limit = options.cost_limits.of_runs(&env, group.iter().copied());
            let costs = limit.and_then(|limit| CostColumns::of(limit, &group));
            let row = Row {
                env,
                algo,
                budget,
                filter: group[0].config.filter.clone(),
                seeds,
                acc_reward,
                best_episode: Estimate::of(&some(&|r| r.best_episode())),
                last_evaluations,
                crash_pct,
                crashes,
                filtered: filtered_episodes(&group),
                crashes_after_warmup: Estimate::of(&some(&|r| r.crashed_after_warmup().map(|n| n as f64))),
                crashes_per_1k,
                standing_pct: Estimate::of(&some(&|r| r.standing_pct())),
                filtered_pct,
                wall_seconds,
                time_pct: Stat::of(&ratios),
                costs,
                shield: ShieldColumns::of(&group),
                interventions: InterventionColumns::of(&group),
            };
            table.notes.extend(crate::intervention_columns::notes(&row.label(), &group));
            if let Some(limit) = limit {
                table.notes.extend(crate::eval_episodes::notes(&row.label(), &group, limit));
            }
            if !missing.is_empty() {
                let list: Vec<String> = missing.iter().map(u64::to_string).collect();
                let consequence = if ratios.is_empty() {
                    "shown as -".to_string()
                } else {
                    format!("averaged over the other {} seed(s)", ratios.len())
                };
                table.notes.push(format!(
                    "% Time of {}: no bare run for seed(s) {}; {consequence}.",
                    row.label(),
                    list.join(", ")
                ));
            }
            // Runs whose strategy `--strategy auto` chose say so, with the choice's scores.
            for run in &group {
                if let Some(s) = &run.summary.selection {
                    // With the scalings it compared, when it chose the scaling too.
                    let scalings = if s.scalings.is_empty() {
                        String::new()
                    } else {
                        format!(", scaling chosen among {}", s.scalings.join(", "))
                    };
                    table.notes.push(format!(
                        "{} seed {}: strategy chosen by --strategy {}{scalings} (held-out demonstrations: \
                         {:.0}% false alarms, {:.0}% of crashes prevented).",
                        row.label(),
                        run.config.seed,
                        s.chosen_by,
                        100.0 * s.false_alarm_rate,
                        100.0 * s.crash_prevention_rate
                    ));
                }
            }
            table.rows.push(row);
        }
        table.set_per_crash_avoided();
        table
    }

    /// Interventions per crash avoided of every row with `interventions.csv`, against the bare
    /// row of the same task, budget and agent: the nearest of [`agent_labels`] that has one.
    /// Done once every row exists, since a bare row need not come first.
    fn set_per_crash_avoided(&mut self) {
        let bare_crashes = |row: &Row| -> Option<f64> {
            agent_labels(&row.algo).iter().find_map(|algo| {
                self.rows
                    .iter()
                    .find(|b| {
                        b.filter.is_none() && b.env == row.env && b.budget == row.budget && b.algo == *algo
                    })
                    .map(|b| b.crashes.stat.mean)
            })
        };
        let against: Vec<Option<f64>> = self.rows.iter().map(bare_crashes).collect();
        for (row, bare) in self.rows.iter_mut().zip(against) {
            if let Some(columns) = row.interventions.as_mut() {
                columns.per_crash_avoided = columns.per_crash_avoided_against(bare);
            }
        }
    }

    /// The trajectory modes of the DEFENDER rows, in order (empty when all rows are bare).
    pub fn modes(&self) -> Vec<Mode> {
        let set: BTreeSet<Mode> = self.rows.iter().filter_map(Row::mode).collect();
        set.into_iter().collect()
    }

    /// The rows for one of the paper's tables: every bare row, and the DEFENDER rows in `mode`
    /// (`None`: bare rows only), in table order.
    pub fn rows_for(&self, mode: Option<Mode>) -> impl Iterator<Item = &Row> {
        self.rows.iter().filter(move |r| r.filter.is_none() || (mode.is_some() && r.mode() == mode))
    }

    /// Whether the DEFENDER rows use more than one number of demonstrations (then the renderers
    /// show it, as in the paper's Table 3).
    pub fn varies_num_demos(&self) -> bool {
        let set: BTreeSet<Option<u64>> =
            self.rows.iter().filter_map(|r| r.filter.as_ref().map(|f| f.num_demos)).collect();
        set.len() > 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_arm_looks_for_its_agent_from_the_nearest_label_down() {
        assert_eq!(
            agent_labels("sac (keeps-learning, margin0.02+own50+margin-trigger0.5)"),
            ["sac (keeps-learning, margin0.02+own50+margin-trigger0.5)", "sac (keeps-learning)", "sac"]
        );
        assert_eq!(agent_labels("td3"), ["td3"]);
    }
}
