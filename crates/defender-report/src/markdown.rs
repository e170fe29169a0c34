//! The report as Markdown: per trajectory mode and task, one table padded to read well in a
//! terminal, then what each column means and the notes.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use defender_rl::Budget;

use crate::cells::{demos_text, mode_title, number, pm_ci, pm_ci_or_dash, pm_ci_to, sections, time};
use crate::intervention_columns::InterventionColumns;
use crate::run::DefenderSettings;
use crate::stats::Estimate;
use crate::table::Table;

/// What the columns mean, printed under the tables (docs/run-directory.md has the same
/// definitions).
const LEGEND: &str = "
Acc Reward (final eval): mean return of the final evaluation (SPEC section 6; deterministic \
policy, 10 episodes). Best episode (paper's Acc Reward): the best single training-episode return \
of the run, filtered episodes included (what the paper's code reports as Acc Reward). Last-10 \
eval: mean return of the run's last 10 evaluations (all of them if it has fewer). % Crash: \
crashed / all training episodes x 100 (the paper's measure: the episodes the filter ends join its \
denominator). Crashes: crashed training episodes over the run. Crashes after warm-up: those \
ending after the learner's random warm-up (`learning_starts` training steps, 5,000 by default), \
which no baseline's learner chooses (a filter acts from the first step); - for a run whose \
configuration does not give it. Crashes / 1k env steps: crashes / \
environment steps of training x 1000, a filtered step not counting (it never reaches the \
environment). Standing %: evaluations in which the agent stood still \
(every episode lasted the task's horizon, 1000 steps, and the mean return is within 10% of the \
mean length) / all evaluations x 100; - for a task of unknown horizon. Each is mean ± std over \
the row's seeds (population std, ddof = 0) [95% percentile bootstrap confidence interval of the \
mean: the seeds resampled with replacement 50,000 times, fixed seed; with 3 seeds it is coarse, \
and rows whose intervals overlap are not told apart]. Seeds: runs in the row. % Time: \
wall-clock time / that of the bare run with the same task, algorithm, budget and seed x 100, \
averaged over seeds; a row without the filter that changes the agent (a penalty, a Lagrangian, \
Recovery RL, the demonstrations alone, a peer's SAC) is timed against plain bare SAC or TD3.
";

/// What the cost columns mean, printed under the legend when a table has them.
const COST_LEGEND: &str = "
Cost columns (tasks with a per-step cost and an episode cost limit L: Safety-Gymnasium's velocity \
tasks, L = 25 as OmniSafe's benchmarks): Cost rate: total cost of the training episodes / \
environment steps of training, a filtered step not counting (it never reaches the environment and \
costs 0). Eval cost (last-10): the evaluation episodes' mean cost, averaged over the run's last 10 \
evaluations. Episodes cost > L: training episodes whose summed cost exceeds L, counted over the \
run. % episodes cost > L: the same / all training episodes x 100; like % Crash, the episodes a \
filter ends join its denominator, so it can fall while the count rises. Each over seeds as the \
columns above.
";

/// What the shares of evaluation episodes within the limit mean, printed under the cost legend
/// when a table has them.
const EVAL_EPISODES_LEGEND: &str = "
Eval episodes cost ≤ L (last-10) (tasks with a cost limit L, runs with eval_episodes.csv): of the \
evaluation episodes of the run's last 10 evaluations, the share whose cost is at most L (an \
episode at L kept the constraint), from eval_episodes.csv's per-episode costs: where Eval cost \
(last-10) averages the costs, this says how many episodes kept the limit. Shielded episodes cost \
≤ L (last-10): the same share of the shielded episodes (DEFENDER runs). Each over the seeds with \
eval_episodes.csv, as the columns above; - for a row without it (runs written before the file \
existed).
";

/// What the shielded columns mean, printed under the legend when a table has them.
const SHIELD_LEGEND: &str = "
Shielded columns (DEFENDER runs): each evaluation runs its episodes again, from the same reset \
seeds, with the run's filter as it stood kept as a shield (deployed with the policy): an episode \
stops at the first step the filter refuses, that action not executed, and its return, cost and \
length are those of the executed steps. Shielded eval (last-10): their mean return, averaged over \
the run's last 10 evaluations, as Last-10 eval is without the filter. % Shield-ended: the share \
of those episodes that the filter ended, x 100, averaged the same way. Shielded cost (last-10) \
(tasks with a cost limit): their mean cost, as Eval cost (last-10). - for a row without a filter.
";

/// What the filtered episodes' column means, printed under the legend when a table has it.
const FILTERED_LEGEND: &str = "
Filtered (interventions): training episodes DEFENDER ended before their action ran (metrics.csv's \
outcome filtered: every trigger's interventions), counted over the run as Crashes is, mean ± std \
over seeds; - for a row without a filter.
";

/// What the checked interventions' columns mean, printed when a table has them.
const CHECKED_LEGEND: &str = "
Checked interventions (runs with interventions.csv; docs/SPEC.md section 15), over the whole run: \
Checked: interventions whose unfiltered continuation ran in a copy of the simulator. Precision: \
the share of those whose continuation failed (a crash; on a cost task, the episode's cost passing \
its limit), per run. Lead (median steps): per run, the median steps from an intervention to that \
failure (the stopped action's step is 1). Interventions / crash avoided: the row's mean \
interventions / (the bare row's mean crashes - the row's mean crashes), against the bare row of \
the same task, budget and agent (the row's label less its filter's tags, else plain bare SAC or \
TD3); - without such a row or when the row does not crash less. Each but the last is mean ± std [interval] over the seeds with \
interventions.csv (Precision over those with a checked intervention, Lead over those with a \
failure).
";

/// The Markdown report of `table`.
pub(crate) fn markdown(table: &Table) -> String {
    let demos = table.varies_num_demos();
    let mut out = String::from("# DEFENDER report\n");
    for mode in sections(table) {
        let _ = write!(out, "\n## {}\n", capitalise(mode_title(mode)));
        let columns: BTreeSet<(&str, Budget)> =
            table.rows_for(mode).map(|r| (r.env.as_str(), r.budget)).collect();
        for (env, budget) in columns {
            let _ = write!(out, "\n### {env}, {budget}\n\n");
            let mut header = vec!["Algorithm", "Safe", "Unsafe"];
            if demos {
                header.push("Demos");
            }
            let labels = header.len();
            let rows = || table.rows_for(mode).filter(|r| r.env == env && r.budget == budget);
            // A task with a cost limit gets the cost columns after the crash counts; the tables
            // of the crash tasks keep theirs.
            let limit = rows().find_map(|r| r.costs.map(|c| c.limit));
            // The evaluations with the filter kept sit beside the unfiltered ones, when a row
            // (a DEFENDER run) has them.
            let shielded = rows().any(|r| r.shield.is_some());
            // Crashes after the learner's warm-up, when a row's runs say how long it was.
            let warmup = rows().any(|r| r.crashes_after_warmup.is_some());
            // The filter's episodes beside the crashes, when a row has a filter; and what its
            // interventions would have led to, when a row's runs checked them.
            let filtered = rows().any(|r| r.filtered.is_some());
            let checked = rows().any(|r| r.interventions.is_some());
            // The share of evaluation episodes within the limit, beside the evaluation cost, when
            // a row's runs have eval_episodes.csv.
            let within = rows().any(|r| r.costs.is_some_and(|c| c.has_eval_episodes()));
            let eval_within =
                limit.map(|l| format!("Eval episodes cost ≤ {l} (last-10)")).unwrap_or_default();
            let shield_within =
                limit.map(|l| format!("Shielded episodes cost ≤ {l} (last-10)")).unwrap_or_default();
            let over = limit.map(|l| format!("Episodes cost > {l}")).unwrap_or_default();
            let over_pct = limit.map(|l| format!("% episodes cost > {l}")).unwrap_or_default();
            header.extend(["Acc Reward (final eval)", "Best episode (paper's Acc Reward)", "Last-10 eval"]);
            if shielded {
                header.extend(["Shielded eval (last-10)", "% Shield-ended"]);
            }
            header.extend(["% Crash", "Crashes"]);
            if filtered {
                header.push("Filtered (interventions)");
            }
            if warmup {
                header.push("Crashes after warm-up");
            }
            header.push("Crashes / 1k env steps");
            if limit.is_some() {
                header.extend(["Cost rate", "Eval cost (last-10)"]);
                if within {
                    header.push(eval_within.as_str());
                }
                if shielded {
                    header.push("Shielded cost (last-10)");
                    if within {
                        header.push(shield_within.as_str());
                    }
                }
                header.extend([over.as_str(), over_pct.as_str()]);
            }
            if checked {
                header.extend([
                    "Checked",
                    "Precision",
                    "Lead (median steps)",
                    "Interventions / crash avoided",
                ]);
            }
            header.extend(["Standing %", "% Time", "Seeds"]);
            let mut cells = vec![header.iter().map(|s| s.to_string()).collect::<Vec<_>>()];
            for row in rows() {
                let (safe, unsafe_) = row
                    .filter
                    .as_ref()
                    .map_or(("-".to_string(), "-"), |f: &DefenderSettings| (f.safe_cell(), f.unsafe_()));
                let mut line = vec![crate::run::algo_display(&row.algo), safe, unsafe_.to_string()];
                if demos {
                    line.push(demos_text(row));
                }
                line.extend([
                    pm_ci(&row.acc_reward, 0),
                    pm_ci_or_dash(row.best_episode.as_ref(), 0),
                    pm_ci(&row.last_evaluations, 0),
                ]);
                let shield = row.shield.as_ref();
                if shielded {
                    line.extend([
                        pm_ci_or_dash(shield.map(|s| &s.eval), 0),
                        pm_ci_or_dash(shield.map(|s| &s.ended_pct), 1),
                    ]);
                }
                line.extend([pm_ci(&row.crash_pct, 1), pm_ci(&row.crashes, 0)]);
                if filtered {
                    line.push(pm_ci_or_dash(row.filtered.as_ref(), 0));
                }
                if warmup {
                    line.push(pm_ci_or_dash(row.crashes_after_warmup.as_ref(), 0));
                }
                line.push(pm_ci(&row.crashes_per_1k, 2));
                if limit.is_some() {
                    let costs = row.costs.as_ref();
                    line.extend([
                        costs.map_or_else(|| "-".into(), |c| pm_ci_to(&c.cost_rate, 3, 3)),
                        pm_ci_or_dash(costs.and_then(|c| c.eval_cost.as_ref()), 1),
                    ]);
                    if within {
                        line.push(share(costs.and_then(|c| c.eval_within_limit.as_ref())));
                    }
                    if shielded {
                        line.push(pm_ci_or_dash(shield.map(|s| &s.cost), 1));
                        if within {
                            line.push(share(costs.and_then(|c| c.shield_within_limit.as_ref())));
                        }
                    }
                    line.extend([
                        pm_ci_or_dash(costs.map(|c| &c.over_limit), 0),
                        pm_ci_or_dash(costs.map(|c| &c.over_limit_pct), 1),
                    ]);
                }
                if checked {
                    line.extend(checked_cells(row.interventions.as_ref()));
                }
                line.extend([
                    pm_ci_or_dash(row.standing_pct.as_ref(), 0),
                    time(row),
                    row.seeds.len().to_string(),
                ]);
                cells.push(line);
            }
            write_padded(&mut out, &cells, labels);
        }
    }
    out.push_str(LEGEND);
    if table.rows.iter().any(|r| r.filtered.is_some()) {
        out.push_str(FILTERED_LEGEND);
    }
    if table.rows.iter().any(|r| r.interventions.is_some()) {
        out.push_str(CHECKED_LEGEND);
    }
    if table.rows.iter().any(|r| r.shield.is_some()) {
        out.push_str(SHIELD_LEGEND);
    }
    if table.rows.iter().any(|r| r.costs.is_some()) {
        out.push_str(COST_LEGEND);
    }
    if table.rows.iter().any(|r| r.costs.is_some_and(|c| c.has_eval_episodes())) {
        out.push_str(EVAL_EPISODES_LEGEND);
    }
    if !table.notes.is_empty() {
        out.push_str("\nNotes:\n");
        for note in &table.notes {
            let _ = writeln!(out, "- {note}");
        }
    }
    out
}

/// A share (0 to 1) over seeds, two decimals as Precision; `-` for a row without it.
fn share(estimate: Option<&Estimate>) -> String {
    estimate.map_or_else(|| "-".into(), |e| pm_ci_to(e, 2, 2))
}

/// The checked interventions' four cells: Checked, Precision (a share: two decimals), Lead and
/// Interventions / crash avoided; `-` for what the row does not have.
fn checked_cells(columns: Option<&InterventionColumns>) -> [String; 4] {
    let Some(c) = columns else { return std::array::from_fn(|_| "-".to_string()) };
    [
        pm_ci(&c.checked, 0),
        c.precision.as_ref().map_or_else(|| "-".into(), |p| pm_ci_to(p, 2, 2)),
        pm_ci_or_dash(c.lead.as_ref(), 1),
        c.per_crash_avoided.map_or_else(|| "-".into(), |v| number(v, 1)),
    ]
}

fn capitalise(text: &str) -> String {
    let mut chars = text.chars();
    chars.next().map(|c| c.to_uppercase().chain(chars).collect()).unwrap_or_default()
}

/// Writes a Markdown table with columns padded to equal width; the first `left` columns are
/// left-aligned, the others right-aligned.
fn write_padded(out: &mut String, cells: &[Vec<String>], left: usize) {
    let columns = cells.first().map_or(0, Vec::len);
    let widths: Vec<usize> =
        (0..columns).map(|c| cells.iter().map(|r| r[c].chars().count()).max().unwrap_or(0).max(3)).collect();
    for (i, row) in cells.iter().enumerate() {
        out.push('|');
        for (c, cell) in row.iter().enumerate() {
            let w = widths[c];
            if c < left {
                let _ = write!(out, " {cell:<w$} |");
            } else {
                let _ = write!(out, " {cell:>w$} |");
            }
        }
        out.push('\n');
        if i == 0 {
            out.push('|');
            for (c, w) in widths.iter().enumerate() {
                let dashes = "-".repeat(*w);
                if c < left {
                    let _ = write!(out, " {dashes} |");
                } else {
                    let _ = write!(out, " {}: |", &dashes[1..]);
                }
            }
            out.push('\n');
        }
    }
}
