//! `defender select`: rank the filtering strategies of one task from its demonstrations alone
//! (leave-one-out), optionally with the ablation score on recorded episodes; and the `auto`
//! strategy of `defender train`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use defender::selection::{AUTO_COSTS, Selection, SelectionConfig, StrategyScore, select};
use defender::{EpisodeSet, Mode};
use defender_report::StrategySelection;

use crate::progress;
use crate::text_table::{Column, TextTable};
use defender_config::profile::Profile;

/// Arguments of `defender select`.
#[derive(Debug, Args)]
#[command(after_help = "Criterion (docs/decisions.md, \"Choosing the strategy automatically\"):
  Leave-one-out over the demonstrations. Each demonstration is replayed step by step against a
  filter built from all the others (its own group without it, the other group whole).
  - false_alarm_rate: held-out SAFE demonstrations filtered at any step, as a fraction of them
    (a false alarm would stop an agent that behaves like the demonstrator);
  - crash_prevention_rate: held-out UNSAFE demonstrations of T transitions filtered at a step k
    with lead time T - k >= min(L, T), L = --min-lead (default 1: any step before the crash);
  - safe_allowed / unsafe_allowed: mean fraction (k + 1) / T of each held-out demonstration
    executed before its first filtered step (1 when never filtered); mean_lead: mean T - k of the
    prevented crashes;
  - demo_score = (1 - false_alarm_rate) x crash_prevention_rate;
  - with --episodes: score = demo_score x the ablation score on the recorded episodes
    (SPEC section 7: mean episode-length ratio x safe-episode rate); else score = demo_score.
  Ranking: a strategy is eligible when false_alarm_rate <= --max-false-alarm (default 0.1) and
  < 1 (it never filters every held-out safe demonstration); eligible strategies come first and
  only they are chosen. Then score, highest first; ties by safe_allowed, then unsafe_allowed (higher: the less
  aggressive of two equally good strategies), then the name. With --scaling auto every strategy is
  scored under plain and under z-scored DTW and the rows of both are ranked together (a tie keeps
  plain DTW): the first row is what `defender train --strategy auto` chooses when the run sets no
  scaling. The CSV columns are described in docs/run-directory.md (\"selection.csv\").

Examples:
  defender select --demos data/demos/Hopper-v5.npz --no-equal --out selection.csv
  defender select --demos data/demos/Hopper-v5.npz --no-equal --scaling auto --out selection.csv
  defender select --demos data/demos/Hopper-v5.npz --mode state-action --num-demos 20 --out sel.csv
  defender select --demos data/demos/Hopper-v5.npz --episodes hopper-episodes.npz --out sel.csv
  defender train --env Hopper-v5 --strategy auto --steps 300000 --out runs/hopper-auto")]
pub struct SelectArgs {
    /// Demonstration set of the task (.npz, SPEC section 8), with >= 2 demonstrations per group.
    #[arg(long)]
    pub demos: PathBuf,
    /// Recorded episodes of an agent on the same task (e.g. `defender train --record-episodes`):
    /// the ablation score on them multiplies the demonstrations' score.
    #[arg(long)]
    pub episodes: Option<PathBuf>,
    /// Trajectory elements: states, or state-action pairs.
    #[arg(long, default_value = "state", value_parser = ["state", "state-action"])]
    pub mode: String,
    /// Use only the first N demonstrations of each group (as `defender train --num-demos`).
    #[arg(long)]
    pub num_demos: Option<usize>,
    /// Leave out the strategies that use the Equal window (O(n^2) per step: most of the time).
    #[arg(long)]
    pub no_equal: bool,
    /// `all`, or a comma-separated list of SAFE/UNSAFE strategies to rank.
    #[arg(long, default_value = "all")]
    pub strategies: String,
    /// L: steps before the crash by which a held-out unsafe demonstration must be filtered.
    #[arg(long, default_value_t = 1)]
    pub min_lead: usize,
    /// The false-alarm budget: strategies that filter a larger fraction of the held-out safe
    /// demonstrations are not chosen.
    #[arg(long, default_value_t = 0.1)]
    pub max_false_alarm: f64,
    /// Feature scaling before DTW, as a run's `[defender.cost] scaling`: `none` (SPEC section 2's
    /// plain DTW), `zscore` (per feature, fitted on the demonstrations), or `auto` (both, ranked
    /// together, as `--strategy auto` compares them; twice the time).
    #[arg(long, default_value = "none", value_parser = ["none", "zscore", "auto"])]
    pub scaling: String,
    /// spec (SPEC section 2's exact DTW, the default) or authors: rank under the cost of the
    /// authors' code (FastDTW L1 over the last 20 steps, one element per transition, ties
    /// executed: docs/SPEC.md, section 10), as an authors-profile run would filter;
    /// keeps-learning ranks as spec (its runs compare with SPEC's cost).
    #[arg(long, value_enum, default_value = "spec")]
    pub profile: Profile,
    /// Rows to print.
    #[arg(long, default_value_t = 10)]
    pub top: usize,
    /// Where to write the ranking (CSV, docs/run-directory.md).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `defender select`.
pub fn run(args: SelectArgs) -> Result<()> {
    let mode: Mode = args.mode.parse()?;
    let config = SelectionConfig {
        mode,
        num_demos: args.num_demos,
        equal: !args.no_equal,
        strategies: if args.strategies == "all" {
            None
        } else {
            Some(defender::Strategy::parse_list(&args.strategies)?)
        },
        min_lead: args.min_lead,
        max_false_alarm: args.max_false_alarm,
        costs: {
            let scalings: Vec<defender::Scaling> = if args.scaling == "auto" {
                AUTO_COSTS.iter().map(|c| c.scaling).collect()
            } else {
                vec![args.scaling.parse()?]
            };
            let base = args.profile.cost_options();
            scalings.into_iter().map(|scaling| defender::CostOptions { scaling, ..base }).collect()
        },
    };
    let demos = EpisodeSet::load(&args.demos)?;
    let episodes = args.episodes.as_ref().map(EpisodeSet::load).transpose()?;
    let task = demos.meta().env_id.clone().unwrap_or_else(|| args.demos.display().to_string());
    let start = Instant::now();
    let selection = run_selection(&demos, episodes.as_ref(), &config, &task)
        .with_context(|| format!("choosing a strategy for {}", args.demos.display()))?;
    selection.write_csv(&args.out)?;
    print_top(&selection.rows, args.top);
    let (safe, unsafe_) = selection.demos;
    say!(
        "{} strategies ranked from {safe} + {unsafe_} demonstrations{} in {:.1}s -> {}",
        selection.rows.len(),
        if selection.episodes > 0 {
            format!(" and {} recorded episodes", selection.episodes)
        } else {
            String::new()
        },
        start.elapsed().as_secs_f64(),
        args.out.display()
    );
    match selection.best() {
        Some(best) => say!("chosen: {} ({mode}, scaling {})", best.strategy, best.scaling),
        None => say!(
            "no strategy chosen: each one raises false alarms on more than {}% of the held-out safe \
             demonstrations (--max-false-alarm)",
            100.0 * config.max_false_alarm
        ),
    }
    Ok(())
}

/// Runs the selection with a progress bar on a terminal.
fn run_selection(
    demos: &EpisodeSet,
    episodes: Option<&EpisodeSet>,
    config: &SelectionConfig,
    task: &str,
) -> Result<Selection> {
    let total = config.num_demos.map_or(demos.len(), |n| 2 * n) + episodes.map_or(0, EpisodeSet::len);
    let total = total * config.costs.len();
    let bar = progress::bar(total as u64, "replays");
    bar.set_message(format!(
        "{task}: {} strategies, {} mode, leave-one-out",
        config.candidates().len(),
        config.mode
    ));
    let selection = select(demos, episodes, config, &|p| bar.set_position(p.done as u64));
    bar.finish_and_clear();
    Ok(selection?)
}

fn print_top(rows: &[StrategyScore], top: usize) {
    let mut table = TextTable::new(vec![
        Column::right("rank"),
        Column::left("strategy"),
        Column::left("scaling"),
        Column::right("false_alarm"),
        Column::right("prevention"),
        Column::right("safe_allowed"),
        Column::right("mean_lead"),
        Column::right("ablation"),
        Column::right("score").min_width(8),
    ]);
    for r in rows.iter().take(top) {
        table.row([
            r.rank.to_string(),
            r.strategy.to_string(),
            r.scaling.to_string(),
            format!("{:.4}", r.false_alarm_rate),
            format!("{:.4}", r.crash_prevention_rate),
            format!("{:.4}", r.safe_allowed),
            format!("{:.1}", r.mean_lead),
            r.ablation_score.map_or("-".to_string(), |v| format!("{v:.4}")),
            format!("{:.4}", r.score),
        ]);
    }
    put!("{}", table.render());
}

/// `strategy = "auto"` in a run: chooses the strategy on the run's demonstrations (its
/// `num_demos`, `mode`, and its cost if it sets one, else comparing plain and z-scored DTW;
/// without the Equal window, which would cost minutes to hours before training starts) and
/// returns it, the scaling it was chosen under, and the record for `config.toml` and
/// `summary.json`.
pub fn choose_for_run(
    demos: &EpisodeSet,
    mode: Mode,
    num_demos: Option<usize>,
    cost: Option<defender::CostOptions>,
) -> Result<(defender::Strategy, defender::Scaling, StrategySelection)> {
    let config = SelectionConfig::for_run(mode, num_demos, cost);
    let task = demos.meta().env_id.clone().unwrap_or_else(|| demos.source().display().to_string());
    let start = Instant::now();
    let selection = run_selection(demos, None, &config, &task)
        .with_context(|| format!("strategy = \"auto\": choosing a strategy for {task}"))?;
    let scalings: Vec<defender::Scaling> = config.costs.iter().map(|c| c.scaling).collect();
    let Some(best) = selection.best() else {
        bail!(
            "strategy = \"auto\": every strategy filters more than {}% of the held-out safe \
             demonstrations of {} (false alarms that would stop the agent from learning); rank them \
             with `defender select` and give --strategy SAFE/UNSAFE",
            100.0 * config.max_false_alarm,
            demos.source().display()
        );
    };
    let record = StrategySelection {
        chosen_by: "auto".into(),
        candidates: selection.rows.len() / scalings.len(),
        equal: config.equal,
        min_lead: config.min_lead,
        max_false_alarm: config.max_false_alarm,
        safe_demos: selection.demos.0,
        unsafe_demos: selection.demos.1,
        false_alarm_rate: best.false_alarm_rate,
        crash_prevention_rate: best.crash_prevention_rate,
        safe_allowed: best.safe_allowed,
        mean_lead: best.mean_lead,
        score: best.score,
        seconds: start.elapsed().as_secs_f64(),
        scalings: if scalings.len() > 1 {
            scalings.iter().map(ToString::to_string).collect()
        } else {
            Vec::new()
        },
    };
    if scalings.len() > 1 {
        for &scaling in &scalings {
            match selection.best_under(scaling) {
                Some(r) => note!(
                    "strategy auto: best under scaling {scaling}: {} (false alarms {:.1}%, crashes prevented {:.1}%)",
                    r.strategy,
                    100.0 * r.false_alarm_rate,
                    100.0 * r.crash_prevention_rate
                ),
                None => {
                    note!("strategy auto: no strategy within the false-alarm budget under scaling {scaling}")
                }
            }
        }
    }
    note!(
        "strategy auto: chose {} ({mode}, scaling {}) of {} strategies in {:.1}s: false alarms {:.1}%, crashes prevented {:.1}%",
        best.strategy,
        best.scaling,
        record.candidates,
        record.seconds,
        100.0 * record.false_alarm_rate,
        100.0 * record.crash_prevention_rate
    );
    if record.crash_prevention_rate < 0.5 {
        note!(
            "warning: {} catches only {:.0}% of the held-out crashes within the false-alarm budget: \
             the demonstrations hardly tell safe from unsafe; recorded episodes of an agent \
             (`defender select --episodes`) may choose better",
            best.strategy,
            100.0 * record.crash_prevention_rate
        );
    }
    Ok((best.strategy, best.scaling, record))
}
