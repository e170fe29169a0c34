//! The report as LaTeX (booktabs): one table per trajectory mode, tasks side by side, laid out
//! like the paper's Tables 1 and 2.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use defender_rl::Budget;

use crate::cells::{mode_title, number, pm, pm_to, sections, time};
use crate::run::DefenderSettings;
use crate::stats::Estimate;
use crate::table::{Row, Table};

fn tex_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '%' | '&' | '_' | '#' | '$' | '{' | '}' => {
                out.push('\\');
                out.push(c);
            }
            '~' => out.push_str("\\textasciitilde{}"),
            '^' => out.push_str("\\textasciicircum{}"),
            '\\' => out.push_str("\\textbackslash{}"),
            _ => out.push(c),
        }
    }
    out
}

/// Columns per task: Acc Reward (final eval), Best episode (the paper's Acc Reward), % Crash,
/// Crashes (over the run), % Time.
const PER_TASK: usize = 5;

/// Columns a task with an episode cost limit adds: Cost rate, Eval cost (last-10), episodes over
/// the limit (counted, and in %).
const PER_COST_TASK: usize = 4;

/// Columns a task with an episode cost limit whose rows have `eval_episodes.csv` adds: the share
/// of evaluation episodes within the limit (and of the shielded ones, with shielded evaluations).
const PER_EVAL_EPISODES_TASK: usize = 1;

/// Columns a task whose rows have shielded evaluations adds: Shielded eval (last-10) and
/// % Shield-ended, and with a cost limit Shielded cost (last-10).
const PER_SHIELD_TASK: usize = 2;

/// Columns a task whose rows have checked interventions adds: Precision, Lead and
/// Interventions / crash avoided (a task with a filter adds Filtered, beside Crashes).
const PER_CHECKED_TASK: usize = 3;

/// The optional column groups of one task's columns, by what its rows have.
#[derive(Clone, Copy)]
struct Extras {
    limit: Option<f64>,
    shield: bool,
    /// The share of evaluation episodes within the limit (a task with a limit only).
    within: bool,
    filtered: bool,
    checked: bool,
}

impl Extras {
    fn of(rows: &[&Row], env: &str, budget: Budget) -> Self {
        let task = || rows.iter().filter(|r| r.env == env && r.budget == budget);
        Self {
            limit: limit_of(rows, env, budget),
            shield: shielded(rows, env, budget),
            within: task().any(|r| r.costs.is_some_and(|c| c.has_eval_episodes())),
            filtered: task().any(|r| r.filtered.is_some()),
            checked: task().any(|r| r.interventions.is_some()),
        }
    }

    /// The task's columns.
    fn width(&self) -> usize {
        let within = if self.within { PER_EVAL_EPISODES_TASK * (1 + usize::from(self.shield)) } else { 0 };
        let cost = if self.limit.is_some() { PER_COST_TASK + usize::from(self.shield) + within } else { 0 };
        PER_TASK
            + if self.shield { PER_SHIELD_TASK } else { 0 }
            + usize::from(self.filtered)
            + cost
            + if self.checked { PER_CHECKED_TASK } else { 0 }
    }
}

/// The episode cost limit of the rows of task `env` at `budget`, `None` for a crash task.
fn limit_of(rows: &[&Row], env: &str, budget: Budget) -> Option<f64> {
    rows.iter().filter(|r| r.env == env && r.budget == budget).find_map(|r| r.costs.map(|c| c.limit))
}

/// Whether a row of task `env` at `budget` has shielded evaluations (a DEFENDER run).
fn shielded(rows: &[&Row], env: &str, budget: Budget) -> bool {
    rows.iter().any(|r| r.env == env && r.budget == budget && r.shield.is_some())
}

/// The LaTeX report of `table`.
pub(crate) fn latex(table: &Table) -> String {
    let demos = table.varies_num_demos();
    let labels = if demos { 3 } else { 2 };
    let mut out =
        String::from("% defender report: needs \\usepackage{booktabs} and \\usepackage{graphicx}\n");
    for mode in sections(table) {
        let rows: Vec<&Row> = table.rows_for(mode).collect();
        // Columns: one group of PER_TASK per (task, budget); the budget is named only when a task
        // has several.
        let columns: Vec<(&str, Budget)> =
            rows.iter().map(|r| (r.env.as_str(), r.budget)).collect::<BTreeSet<_>>().into_iter().collect();
        let column_title = |env: &str, budget: Budget| {
            if columns.iter().filter(|(e, _)| *e == env).count() > 1 {
                format!("{} ({budget})", tex_escape(env))
            } else {
                tex_escape(env)
            }
        };
        // A task with a cost limit has the cost columns too (before % Time), and so on for the
        // shielded evaluations, the filter's episodes and the checked interventions.
        let extras: Vec<Extras> = columns.iter().map(|(e, b)| Extras::of(&rows, e, *b)).collect();
        let widths: Vec<usize> = extras.iter().map(Extras::width).collect();
        let cost_caption = if extras.iter().any(|x| x.limit.is_some()) {
            " Cost rate: total training cost / environment steps of training (filtered steps not \
             counted); Eval cost (last-10): mean evaluation cost over the last 10 evaluations; \
             Cost $>$ L: training episodes whose cost exceeds the episode cost limit L, over the run; \
             \\% cost $>$ L: the same / all training episodes (the filter's episodes join the denominator)."
        } else {
            ""
        };
        let within_caption = if extras.iter().any(|x| x.within) {
            " Eval ep. cost $\\leq$ L: the share of the evaluation episodes of the last 10 evaluations \
             whose cost is at most L (Shielded ep.: of the shielded episodes), from eval\\_episodes.csv."
        } else {
            ""
        };
        let filtered_caption = if extras.iter().any(|x| x.filtered) {
            " Filtered: training episodes the filter ended (interventions), over the run."
        } else {
            ""
        };
        let checked_caption = if extras.iter().any(|x| x.checked) {
            " Precision: the share of the checked interventions whose unfiltered continuation failed; \
             Lead: the median steps from an intervention to that failure; Int./crash avoided: \
             interventions / (the bare row's crashes $-$ the row's crashes), - unless it crashes less; \
             over the run."
        } else {
            ""
        };
        let shield_caption = if extras.iter().any(|x| x.shield) {
            " Shielded: each evaluation's episodes again (the same reset seeds) with the run's filter kept, \
             an episode stopping at the first step the filter refuses (its return and cost those of the \
             executed steps), over the last 10 evaluations; \\% Shield-ended: the share of those \
             episodes the filter ended."
        } else {
            ""
        };
        let _ = write!(
            out,
            "\n\\begin{{table}}[tb]\n\\caption{{Performance, safety and computation time, {}. Acc Reward \
             (final eval): mean return of the final evaluation; Best episode: the best training-episode \
             return of a run (the paper's Acc Reward); \\% Crash: crashed / all training episodes; Crashes: crashed training \
             episodes over the run; mean $\\pm$ std over seeds.{filtered_caption}{cost_caption}{within_caption}{checked_caption}{shield_caption}}}\n\
             \\centering\n\\resizebox{{\\textwidth}}{{!}}{{%\n\\begin{{tabular}}{{{}{}}}\n\\toprule\n",
            tex_escape(mode_title(mode)),
            "l".repeat(labels),
            "r".repeat(widths.iter().sum())
        );
        out.push_str(&" & ".repeat(labels - 1));
        for ((env, budget), width) in columns.iter().zip(&widths) {
            let _ = write!(out, " & \\multicolumn{{{width}}}{{c}}{{{}}}", column_title(env, *budget));
        }
        out.push_str(" \\\\\n");
        let mut first = labels + 1;
        for width in &widths {
            let _ = write!(out, "\\cmidrule(lr){{{first}-{}}} ", first + width - 1);
            first += width;
        }
        out.push_str(if demos { "\nSafe & Unsafe & Demos" } else { "\nSafe & Unsafe" });
        for x in &extras {
            out.push_str(" & Acc Reward (final eval) & Best episode");
            if x.shield {
                out.push_str(" & Shielded eval (last-10) & \\% Shield-ended");
            }
            out.push_str(" & \\% Crash & Crashes");
            if x.filtered {
                out.push_str(" & Filtered");
            }
            if let Some(limit) = x.limit {
                let eval_within =
                    if x.within { format!(" & Eval ep. cost $\\leq$ {limit}") } else { String::new() };
                let shielded_cost = match (x.shield, x.within) {
                    (false, _) => String::new(),
                    (true, false) => " & Shielded cost (last-10)".to_string(),
                    (true, true) => format!(" & Shielded cost (last-10) & Shielded ep. cost $\\leq$ {limit}"),
                };
                let _ = write!(
                    out,
                    " & Cost rate & Eval cost (last-10){eval_within}{shielded_cost} & Cost $>$ {limit} & \\% cost $>$ {limit}"
                );
            }
            if x.checked {
                out.push_str(" & Precision & Lead & Int./crash avoided");
            }
            out.push_str(" & \\% Time");
        }
        out.push_str(" \\\\\n");
        let algos: Vec<&str> =
            rows.iter().map(|r| r.algo.as_str()).collect::<BTreeSet<_>>().into_iter().collect();
        for algo in algos {
            out.push_str("\\midrule\n");
            let filters: Vec<Option<&DefenderSettings>> = rows
                .iter()
                .filter(|r| r.algo == algo)
                .map(|r| r.filter.as_ref())
                .collect::<BTreeSet<_>>()
                .into_iter()
                .collect();
            for filter in filters {
                match filter {
                    None => {
                        let _ = write!(
                            out,
                            "\\multicolumn{{{labels}}}{{l}}{{{}}}",
                            tex_escape(&crate::run::algo_display(algo))
                        );
                    }
                    Some(f) => {
                        let _ = write!(out, "{} & {}", tex_escape(&f.safe_cell()), tex_escape(f.unsafe_()));
                        if demos {
                            let _ = write!(out, " & {}", f.num_demos.map_or("?".into(), |n| n.to_string()));
                        }
                    }
                }
                for (((env, budget), x), width) in columns.iter().zip(&extras).zip(&widths) {
                    let cell = rows.iter().find(|r| {
                        r.algo == algo && r.env == *env && r.budget == *budget && r.filter.as_ref() == filter
                    });
                    match cell {
                        Some(r) => {
                            let _ = write!(
                                out,
                                " & {} & {}",
                                pm(&r.acc_reward.stat, 0, "$\\pm$"),
                                r.best_episode.map_or_else(|| "-".into(), |b| pm(&b.stat, 0, "$\\pm$")),
                            );
                            if x.shield {
                                let s = r.shield.as_ref();
                                let _ = write!(
                                    out,
                                    " & {} & {}",
                                    estimate_cell(s.map(|s| &s.eval), 0, 1),
                                    estimate_cell(s.map(|s| &s.ended_pct), 1, 1)
                                );
                            }
                            let _ = write!(
                                out,
                                " & {} & {}",
                                pm(&r.crash_pct.stat, 0, "$\\pm$"),
                                pm(&r.crashes.stat, 0, "$\\pm$"),
                            );
                            if x.filtered {
                                let _ = write!(out, " & {}", estimate_cell(r.filtered.as_ref(), 0, 1));
                            }
                            if x.limit.is_some() {
                                out.push_str(&cost_cells(r, x));
                            }
                            if x.checked {
                                out.push_str(&checked_cells(r));
                            }
                            let _ = write!(out, " & {}", time(r));
                        }
                        None => out.push_str(&" & -".repeat(*width)),
                    }
                }
                out.push_str(" \\\\\n");
                if filter.is_none() {
                    out.push_str("\\cmidrule(lr){1-");
                    let _ = writeln!(out, "{}}}", labels + widths.iter().sum::<usize>());
                }
            }
        }
        out.push_str("\\bottomrule\n\\end{tabular}}\n\\end{table}\n");
    }
    for note in &table.notes {
        let _ = writeln!(out, "% Note: {note}");
    }
    out
}

/// A cell: mean $\pm$ std, the mean to `decimals` and the std to `std_decimals`; `-` for a value
/// the row does not have.
fn estimate_cell(e: Option<&Estimate>, decimals: usize, std_decimals: usize) -> String {
    e.map_or_else(|| "-".to_string(), |e| pm_to(&e.stat, decimals, std_decimals, "$\\pm$"))
}

/// The checked interventions' cells of a row (Precision, Lead, Int./crash avoided), each starting
/// with ` & `.
fn checked_cells(row: &Row) -> String {
    let c = row.interventions.as_ref();
    format!(
        " & {} & {} & {}",
        estimate_cell(c.and_then(|c| c.precision.as_ref()), 2, 2),
        estimate_cell(c.and_then(|c| c.lead.as_ref()), 1, 1),
        c.and_then(|c| c.per_crash_avoided).map_or_else(|| "-".into(), |v| number(v, 1))
    )
}

/// The cost cells of a row of a task with a cost limit, each starting with ` & ` (with the
/// share of evaluation episodes within the limit after the evaluation cost, and the shielded
/// evaluation's cost and share after them, when the task's table has them).
fn cost_cells(row: &Row, x: &Extras) -> String {
    // The cost rate (~0.05) keeps its std to the mean's three decimals ([`pm_to`]); a share (0
    // to 1) has two decimals.
    let costs = row.costs.as_ref();
    let within = |e: Option<&Estimate>| {
        if x.within { format!(" & {}", estimate_cell(e, 2, 2)) } else { String::new() }
    };
    let shield = if x.shield {
        format!(
            " & {}{}",
            estimate_cell(row.shield.as_ref().map(|s| &s.cost), 1, 1),
            within(costs.and_then(|c| c.shield_within_limit.as_ref()))
        )
    } else {
        String::new()
    };
    format!(
        " & {} & {}{}{shield} & {} & {}",
        estimate_cell(costs.map(|c| &c.cost_rate), 3, 3),
        estimate_cell(costs.and_then(|c| c.eval_cost.as_ref()), 1, 1),
        within(costs.and_then(|c| c.eval_within_limit.as_ref())),
        estimate_cell(costs.map(|c| &c.over_limit), 0, 1),
        estimate_cell(costs.map(|c| &c.over_limit_pct), 1, 1)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes() {
        assert_eq!(tex_escape("a_b 50% & c"), "a\\_b 50\\% \\& c");
    }
}
