//! Learning curves as PNG and SVG, drawn with `plotters` and an embedded font (no system font
//! library): per task, algorithm and budget, the bare algorithm against each DEFENDER strategy,
//! mean over seeds with a shaded min-max band; beside them, the trade-off of the final results
//! (`crate::tradeoff`). This module chooses what is drawn and names the files; the drawing is
//! `crate::curves` and `crate::tradeoff`, written by `crate::figure::write_figure`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use defender_rl::{Budget, Outcome};

use crate::costs::CostLimits;
use crate::curves::{Band, Chart, Grid, band};
use crate::error::{Result, io_err};
use crate::figure::{file_safe, register_font, steps_label, write_figure};
use crate::run::{DefenderSettings, Run};
use crate::stats::rolling_mean;
use crate::{crashes_vs_eval, tradeoff, windows};

/// One seed's curve: steps and values.
type Curve = (Vec<f64>, Vec<f64>);

/// Options of [`draw_plots`].
#[derive(Debug, Clone, PartialEq)]
pub struct PlotOptions {
    /// Image width in pixels (PNG) or user units (SVG).
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Points of the common step grid onto which each seed's training curve is interpolated.
    pub grid_points: usize,
    /// The training-return curve is the rolling mean of this many episodes (1: raw returns).
    pub smoothing_episodes: usize,
    /// The window, in environment steps, of the rolling crash rate (`*_windows`); `None`: a
    /// tenth of the steps the runs of the plot reach, to two significant digits.
    pub crash_window: Option<u64>,
    /// The episode cost limit of each per-step cost task: its plots add the cost curves
    /// ([`PlotKind::Cost`], [`PlotKind::EvalCost`]).
    pub cost_limits: CostLimits,
}

impl Default for PlotOptions {
    fn default() -> Self {
        Self {
            width: 960,
            height: 600,
            grid_points: 200,
            smoothing_episodes: 10,
            crash_window: None,
            cost_limits: CostLimits::default(),
        }
    }
}

/// Which curve a plot shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PlotKind {
    /// (a) Training episode return vs environment steps (`*_return`).
    Return,
    /// (b) Cumulative crash rate, % of the episodes so far that crashed, vs steps (`*_crash`).
    CrashRate,
    /// (c) Evaluation return (`eval.csv`) vs steps (`*_eval`).
    Evaluation,
    /// (d) Crashes so far vs environment steps (filtered steps not counted) (`*_crashes`): the
    /// field's cumulative count of violations.
    Crashes,
    /// (e) Training cost so far vs environment steps (filtered steps not counted) (`*_cost`):
    /// the cumulative cost, for a task with a cost limit only.
    Cost,
    /// (f) Evaluation mean cost (`eval.csv`'s `mean_cost`) vs steps, the episode cost limit
    /// drawn across (`*_eval_cost`), for a task with a cost limit only.
    EvalCost,
    /// (g) The evaluation return with the filter kept (`eval.csv`'s `shield_mean_return`; a
    /// filtered step ends the episode) vs steps (`*_shield_eval`), for the configurations with a
    /// filter only.
    ShieldEval,
    /// (h) Its mean cost (`shield_mean_cost`), the limit drawn across (`*_shield_eval_cost`), for a
    /// task with a cost limit only.
    ShieldEvalCost,
}

impl PlotKind {
    /// All kinds, in file order.
    pub const ALL: [PlotKind; 8] = [
        PlotKind::Return,
        PlotKind::CrashRate,
        PlotKind::Evaluation,
        PlotKind::Crashes,
        PlotKind::Cost,
        PlotKind::EvalCost,
        PlotKind::ShieldEval,
        PlotKind::ShieldEvalCost,
    ];

    /// The file-name suffix.
    pub fn suffix(self) -> &'static str {
        match self {
            PlotKind::Return => "return",
            PlotKind::CrashRate => "crash",
            PlotKind::Evaluation => "eval",
            PlotKind::Crashes => "crashes",
            PlotKind::Cost => "cost",
            PlotKind::EvalCost => "eval_cost",
            PlotKind::ShieldEval => "shield_eval",
            PlotKind::ShieldEvalCost => "shield_eval_cost",
        }
    }

    /// Whether the plot is drawn only for a task with an episode cost limit: a crash task's
    /// cost is its crashes, which `*_crashes` already shows.
    pub fn needs_cost_limit(self) -> bool {
        matches!(self, PlotKind::Cost | PlotKind::EvalCost | PlotKind::ShieldEvalCost)
    }

    /// Whether the plot shows the evaluations with the filter kept: drawn for the configurations
    /// with a filter, and only when one of them has such evaluations.
    pub fn is_shielded(self) -> bool {
        matches!(self, PlotKind::ShieldEval | PlotKind::ShieldEvalCost)
    }

    /// Whether the curve is the evaluations' (one point per evaluation, markers drawn).
    fn is_evaluation(self) -> bool {
        matches!(
            self,
            PlotKind::Evaluation | PlotKind::EvalCost | PlotKind::ShieldEval | PlotKind::ShieldEvalCost
        )
    }

    /// Whether the episode cost limit is drawn across.
    fn draws_limit(self) -> bool {
        matches!(self, PlotKind::EvalCost | PlotKind::ShieldEvalCost)
    }
}

/// What [`draw_plots`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plots {
    /// The files written (a PNG and an SVG per plot).
    pub files: Vec<PathBuf>,
    /// Curves that could not be drawn, and why.
    pub notes: Vec<String>,
}

/// Draws the learning curves of `runs` into `dir` (created if needed): for each task x algorithm
/// (x budget, when a task and algorithm were run with several), `{env}_{algo}_return`,
/// `{env}_{algo}_crash` and `{env}_{algo}_eval`, and the final results' trade-off
/// `{env}_{algo}_tradeoff` (% Crash against Acc Reward, one point per configuration), and
/// `{env}_{algo}_windows` for reading long budgets (`crate::windows`: the crash rate over a
/// rolling window of [`PlotOptions::crash_window`] steps beside the evaluation return, twice as
/// wide), each as `.png` and `.svg`. A task with an episode cost limit
/// ([`PlotOptions::cost_limits`], or recorded in its runs' `summary.json`) also gets
/// `{env}_{algo}_cost` (the training cost so far against environment steps) and
/// `{env}_{algo}_eval_cost` (the evaluations' mean cost, the limit drawn across).
///
/// Each seed's curve is interpolated linearly onto a grid over the steps all seeds reached
/// (from the latest first point to the earliest last point), so the mean never mixes a
/// different number of seeds; the band is the min and max over seeds.
///
/// # Errors
///
/// [`ReportError::Io`] when `dir` cannot be created or a file written, [`ReportError::Plot`] when
/// drawing fails.
pub fn draw_plots(runs: &[Run], dir: impl AsRef<Path>, options: &PlotOptions) -> Result<Plots> {
    let dir = dir.as_ref();
    register_font();
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    // One plot per task x algorithm (x budget); in it one curve per configuration: the row's
    // label (what sets its agent and filter apart: `sac (demos+BC, margin0.02+own50)`) and its
    // DEFENDER settings, bare runs first, so that the arms of an experiment are side by side.
    type Key<'a> = (&'a str, &'a str, Budget);
    type Curves<'a> = BTreeMap<(bool, &'a str, Option<&'a DefenderSettings>), Vec<&'a Run>>;
    let mut groups: BTreeMap<Key<'_>, Curves<'_>> = BTreeMap::new();
    for run in runs {
        let c = &run.config;
        groups
            .entry((c.env.as_str(), crate::run::label_parts(&c.algo).0, c.budget))
            .or_default()
            .entry((c.filter.is_some(), c.algo.as_str(), c.filter.as_ref()))
            .or_default()
            .push(run);
    }
    let budgets: BTreeMap<(&str, &str), usize> = groups.keys().fold(BTreeMap::new(), |mut m, (e, a, _)| {
        *m.entry((*e, *a)).or_default() += 1;
        m
    });
    let mut plots = Plots::default();
    for ((env, algo, budget), by_filter) in &groups {
        let mut stem = format!("{}_{}", file_safe(env), file_safe(algo));
        if budgets.get(&(*env, *algo)).copied().unwrap_or(0) > 1 {
            stem.push_str(&format!("_{}", file_safe(&budget.to_string())));
        }
        let modes: BTreeSet<_> = by_filter.keys().filter_map(|k| k.2).map(|f| f.mode).collect();
        let demos: BTreeSet<_> = by_filter.keys().filter_map(|k| k.2).map(|f| f.num_demos).collect();
        let label = |(_, row, filter): (bool, &str, Option<&DefenderSettings>), seeds: usize| {
            let mut text = match (filter, crate::run::label_parts(row).1) {
                // An unfiltered arm with its own tags (a baseline, a peer) is named by them.
                (None, None) => format!("{} (bare)", crate::run::algo_display(row)),
                (None, Some(_)) => crate::run::algo_display(row),
                (Some(f), None) => f.name(),
                (Some(f), Some(tags)) => format!("{}, {tags}", f.name()),
            };
            if let Some(f) = filter {
                if modes.len() > 1 {
                    text.push_str(&format!(", {}", f.mode));
                }
                if demos.len() > 1 {
                    text.push_str(&format!(", {} demos", f.num_demos.map_or("?".into(), |n| n.to_string())));
                }
            }
            text.push_str(&format!(" [{seeds} seed{}]", if seeds == 1 { "" } else { "s" }));
            text
        };
        // Colour i of the curves is the same configuration's colour in the trade-off; the first
        // bare curve is black (colour 0), and without one the palette starts at 1.
        let bare_first = by_filter.keys().next().is_some_and(|k| !k.0);
        let color_of = |i: usize| i + usize::from(!bare_first);
        // One band per configuration (with a filter only, if `filtered_only`: a shielded curve
        // exists only where there is a filter to keep) of the curve `curve` gives each seed, on
        // `grid`.
        let bands_of = |curve: &dyn Fn(&Run) -> Curve,
                        grid: Grid,
                        name: &str,
                        why: &str,
                        filtered_only: bool,
                        notes: &mut Vec<String>| {
            let mut bands = Vec::new();
            for (i, (key, seeds)) in by_filter.iter().enumerate() {
                if filtered_only && !key.0 {
                    continue;
                }
                let curves: Vec<(Vec<f64>, Vec<f64>)> = seeds.iter().map(|r| curve(r)).collect();
                let label = label(*key, seeds.len());
                match band(&curves, grid) {
                    Some((xs, mean, lo, hi)) => {
                        bands.push(Band { label, color: color_of(i), xs, mean, lo, hi });
                    }
                    None => notes.push(format!("{stem}_{name}: {label}: {why}; not drawn")),
                }
            }
            bands
        };
        let mut eval_chart = None;
        let limit = options.cost_limits.of_runs(env, by_filter.values().flatten().copied());
        for kind in PlotKind::ALL {
            if kind.needs_cost_limit() && limit.is_none() {
                continue;
            }
            let shielded =
                || by_filter.values().flatten().any(|r| r.evaluations.iter().any(|e| e.shield.is_some()));
            if kind.is_shielded() && !shielded() {
                continue;
            }
            let grid = if kind.is_evaluation() { Grid::Union } else { Grid::Linear(options.grid_points) };
            let name = kind.suffix();
            let why = match kind {
                PlotKind::EvalCost => {
                    "a seed has no evaluation with a cost (eval.csv's mean_cost) or the seeds share no \
                     step range"
                        .to_string()
                }
                PlotKind::ShieldEval | PlotKind::ShieldEvalCost => {
                    "a seed has no evaluation with the filter kept (eval.csv's shield columns) or the \
                     seeds share no step range"
                        .to_string()
                }
                _ => format!("the seeds' {name} share no step range"),
            };
            let bands = bands_of(
                &|r| curve(r, kind, options),
                grid,
                name,
                &why,
                kind.is_shielded(),
                &mut plots.notes,
            );
            if bands.is_empty() {
                continue;
            }
            let chart = Chart {
                title: title(env, algo, *budget, kind),
                y_label: y_label(kind, options),
                y_from: matches!(
                    kind,
                    PlotKind::CrashRate
                        | PlotKind::Crashes
                        | PlotKind::Cost
                        | PlotKind::EvalCost
                        | PlotKind::ShieldEvalCost
                )
                .then_some(0.0),
                x_from: None,
                markers: kind.is_evaluation(),
                bands,
                limit: limit.filter(|_| kind.draws_limit()).map(|l| (l, format!("episode cost limit ({l})"))),
            };
            let base = dir.join(format!("{stem}_{}", kind.suffix()));
            plots.files.extend(write_figure(&chart, &base, (options.width, options.height))?);
            if kind == PlotKind::Evaluation {
                eval_chart = Some(chart);
            }
        }
        // The long-budget view: the crash rate over a rolling window beside the evaluations.
        let all: Vec<&Run> = by_filter.values().flatten().copied().collect();
        let window = options.crash_window.unwrap_or_else(|| windows::default_window(&all));
        let name = "windows";
        let bands = bands_of(
            &|r| windows::crash_rate(&r.episodes, window),
            Grid::Linear(options.grid_points),
            name,
            &format!("a seed ends before its first window of {window} steps"),
            false,
            &mut plots.notes,
        );
        if let (false, Some(mut eval)) = (bands.is_empty(), eval_chart) {
            eval.title = "evaluation return".into();
            eval.x_from = Some(0.0);
            let crash = Chart {
                title: format!("crash rate over the last {} steps", steps_label(window as f64)),
                y_label: "crashed / episodes ending in the window (%)".into(),
                y_from: Some(0.0),
                x_from: Some(0.0),
                markers: false,
                bands,
                limit: None,
            };
            let figure = windows::Windows {
                title: format!(
                    "{env}, {}, {budget}: crash rate and evaluation return",
                    crate::run::algo_display(algo)
                ),
                crash,
                eval,
            };
            let base = dir.join(format!("{stem}_{name}"));
            plots.files.extend(write_figure(&figure, &base, (2 * options.width, options.height))?);
        }
        let points = by_filter
            .iter()
            .enumerate()
            .map(|(i, (key, seeds))| tradeoff::Point::of(label(*key, seeds.len()), color_of(i), seeds))
            .collect();
        let figure = tradeoff::Tradeoff::new(
            format!("{env}, {}, {budget}: final results", crate::run::algo_display(algo)),
            points,
        );
        plots.files.extend(write_figure(
            &figure,
            &dir.join(format!("{stem}_tradeoff")),
            (options.width, options.height),
        )?);
        let arms = by_filter
            .iter()
            .enumerate()
            .map(|(i, (key, seeds))| crashes_vs_eval::Arm::of(label(*key, seeds.len()), color_of(i), seeds))
            .collect();
        let figure = crashes_vs_eval::CrashesVsEval {
            title: format!(
                "{env}, {}, {budget}: crashes and last-10 evaluation",
                crate::run::algo_display(algo)
            ),
            arms,
        };
        plots.files.extend(write_figure(
            &figure,
            &dir.join(format!("{stem}_crashes_vs_eval")),
            (options.width, options.height),
        )?);
    }
    Ok(plots)
}

fn title(env: &str, algo: &str, budget: Budget, kind: PlotKind) -> String {
    let what = match kind {
        PlotKind::Return => "training episode return",
        PlotKind::CrashRate => "cumulative crash rate",
        PlotKind::Evaluation => "evaluation return",
        PlotKind::Crashes => "crashes against environment steps",
        PlotKind::Cost => "cumulative cost against environment steps",
        PlotKind::EvalCost => "evaluation cost",
        PlotKind::ShieldEval => "evaluation return with the filter kept",
        PlotKind::ShieldEvalCost => "evaluation cost with the filter kept",
    };
    format!("{env}, {}, {budget}: {what}", crate::run::algo_display(algo))
}

fn y_label(kind: PlotKind, options: &PlotOptions) -> String {
    match kind {
        PlotKind::Return if options.smoothing_episodes > 1 => {
            format!("episode return (mean of last {} episodes)", options.smoothing_episodes)
        }
        PlotKind::Return => "episode return".into(),
        PlotKind::CrashRate => "crashed episodes so far (%)".into(),
        PlotKind::Evaluation => "mean evaluation return".into(),
        PlotKind::Crashes => "crashes so far (x: steps that reached the environment)".into(),
        PlotKind::Cost => "training cost so far (x: steps that reached the environment)".into(),
        PlotKind::EvalCost => "mean evaluation episode cost".into(),
        PlotKind::ShieldEval => "mean evaluation return (a filtered step ends the episode)".into(),
        PlotKind::ShieldEvalCost => "mean evaluation episode cost (a filtered step ends the episode)".into(),
    }
}

/// One seed's curve: x = environment steps.
fn curve(run: &Run, kind: PlotKind, options: &PlotOptions) -> (Vec<f64>, Vec<f64>) {
    let steps = || run.episodes.iter().map(|e| e.total_steps as f64).collect::<Vec<_>>();
    match kind {
        PlotKind::Return => {
            let returns: Vec<f64> = run.episodes.iter().map(|e| e.ret).collect();
            (steps(), rolling_mean(&returns, options.smoothing_episodes))
        }
        PlotKind::CrashRate => {
            let mut crashed = 0usize;
            let rate = run
                .episodes
                .iter()
                .enumerate()
                .map(|(i, e)| {
                    crashed += usize::from(e.outcome == Outcome::Crashed);
                    crashed as f64 * 100.0 / (i + 1) as f64
                })
                .collect();
            (steps(), rate)
        }
        PlotKind::Evaluation => (
            run.evaluations.iter().map(|e| e.total_steps as f64).collect(),
            run.evaluations.iter().map(|e| e.mean_return).collect(),
        ),
        // The crashes and the cost are counted alike (`Run::cumulative`): over the steps that
        // reached the environment.
        PlotKind::Crashes => run.cumulative_crashes().into_iter().map(|(s, c)| (s as f64, c as f64)).unzip(),
        PlotKind::Cost => run.cumulative_cost().into_iter().map(|(s, c)| (s as f64, c)).unzip(),
        // Rows of a file from before costs existed have no cost: left out.
        PlotKind::EvalCost => {
            run.evaluations.iter().filter_map(|e| Some((e.total_steps as f64, e.mean_cost?))).unzip()
        }
        PlotKind::ShieldEval => {
            run.evaluations.iter().filter_map(|e| Some((e.total_steps as f64, e.shield?.mean_return))).unzip()
        }
        PlotKind::ShieldEvalCost => {
            run.evaluations.iter().filter_map(|e| Some((e.total_steps as f64, e.shield?.mean_cost))).unzip()
        }
    }
}
