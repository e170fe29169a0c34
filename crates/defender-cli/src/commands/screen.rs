//! `defender screen`: replays a bare run's recorded episodes, in order, through the filter with
//! each precision variant (`[defender.filter]`), and tabulates caught crashes, false alarms and
//! the experience kept, before any training is spent on a variant (defender::screen).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use defender::{
    CostOptions, Demonstrations, EpisodeSet, FilterOptions, Mode, Scaling, ScreenTally, Strategy,
};
use rayon::prelude::*;

use crate::text_table::{Column, TextTable};

/// The variants screened when none is given: SPEC's filter, margins, budgets, own episodes, and
/// the budget with own episodes.
const DEFAULT_VARIANTS: &[&str] = &[
    "",
    "margin = 0.1",
    "margin = 0.2",
    "margin = 0.4",
    "budget = { share = 0.1 }",
    "budget = { share = 0.2 }",
    "budget = { share = 0.3 }",
    "own_episodes = { keep = 20 }",
    "own_episodes = { keep = 50 }",
    "margin = 0.2\nown_episodes = { keep = 50 }",
    "budget = { share = 0.2 }\nown_episodes = { keep = 50 }",
];

/// Arguments of `defender screen`.
#[derive(Debug, Args)]
#[command(after_help = "Examples:
  defender train --env Hopper-v5 --steps 100000 --out runs/bare --record-episodes episodes.npz
  defender screen --demos data/demos/Hopper-v5.npz --episodes runs/bare/episodes.npz \\
      --strategy MeanBothW5/MeanBothW5 --out screen.csv
  defender screen ... --variant 'margin = 0.3' --variant 'budget = { share = 0.2, episodes = 50 }'
  defender screen ... --scaling none --scaling zscore     (each variant with plain and z-scored DTW)

Each --variant is the body of a [defender.filter] section (TOML); without one, a default list is
screened (SPEC's filter, margins 0.1-0.4, budgets 0.1-0.3, own episodes 20 and 50, combinations).
Episodes are replayed in the order recorded: the budget's margin and the own episodes that join
the groups evolve as they would in training, except that a filtered episode is not cut short in
the recording (the agent would have gone on differently).

Columns: caught% (crashed episodes the filter ended first), false% (episodes that reached the
horizon but were filtered), filtered% and crash% (of all episodes, as training would count them),
kept% (recorded transitions before the first filtered step: the experience left to the agent),
lead (mean steps between the filtered step and the crash it caught; small is precise), late%
(caught crashes within 10 steps of the crash), margin (at the end).")]
pub struct ScreenArgs {
    /// Demonstration set of the task.
    #[arg(long)]
    pub demos: PathBuf,
    /// Recorded episodes of a bare run of the same task (`defender train --record-episodes`).
    #[arg(long)]
    pub episodes: PathBuf,
    /// SAFE/UNSAFE strategies to screen (repeat, or comma-separated).
    #[arg(long, required = true, value_delimiter = ',')]
    pub strategy: Vec<String>,
    /// A variant: the body of a `[defender.filter]` section, e.g. 'margin = 0.2' (repeat).
    #[arg(long)]
    pub variant: Vec<String>,
    /// Feature scaling of the alignment cost (repeat to cross): none or zscore.
    #[arg(long, default_value = "none")]
    pub scaling: Vec<String>,
    /// Trajectory elements: states, or state-action pairs.
    #[arg(long, default_value = "state", value_parser = ["state", "state-action"])]
    pub mode: String,
    /// Use only the first N demonstrations of each group.
    #[arg(long)]
    pub num_demos: Option<usize>,
    /// Replay only the first N recorded episodes.
    #[arg(long)]
    pub first: Option<usize>,
    /// Where to write the table (CSV).
    #[arg(long)]
    pub out: PathBuf,
}

/// One line of the screen.
struct Line {
    strategy: Strategy,
    scaling: Scaling,
    variant: FilterOptions,
    tally: ScreenTally,
}

/// Runs `defender screen`.
pub fn run(args: ScreenArgs) -> Result<()> {
    crate::run_dir::check_writable(&args.out).context("--out")?;
    let mode: Mode = args.mode.parse()?;
    let strategies = args
        .strategy
        .iter()
        .map(|s| s.parse::<Strategy>().with_context(|| format!("--strategy {s}")))
        .collect::<Result<Vec<_>>>()?;
    let scalings = args
        .scaling
        .iter()
        .map(|s| s.parse::<Scaling>().with_context(|| format!("--scaling {s}")))
        .collect::<Result<Vec<_>>>()?;
    let bodies: Vec<&str> = if args.variant.is_empty() {
        DEFAULT_VARIANTS.to_vec()
    } else {
        args.variant.iter().map(String::as_str).collect()
    };
    let variants = bodies
        .iter()
        .map(|body| {
            let v: FilterOptions = toml::from_str(body)
                .with_context(|| format!("--variant '{body}': not a [defender.filter] body"))?;
            v.validate().with_context(|| format!("--variant '{body}'"))?;
            Ok(v)
        })
        .collect::<Result<Vec<_>>>()?;
    if args.num_demos == Some(0) {
        bail!("--num-demos 0: give at least 1 demonstration per group (or leave it out for all)");
    }
    let mut set = EpisodeSet::load(&args.demos)?;
    if let Some(n) = args.num_demos {
        set = set.select_demos(n)?;
    }
    let episodes = EpisodeSet::load(&args.episodes)?;
    // Both files must call the same episodes unsafe (docs/SPEC.md, section 13).
    defender::UnsafeRule::of_set(&episodes)?
        .check_demos(&set)
        .with_context(|| format!("--demos against the rule of --episodes {}", args.episodes.display()))?;
    if (episodes.obs_dim(), episodes.act_dim()) != (set.obs_dim(), set.act_dim()) {
        bail!(
            "--episodes {} has (obs, act) dimensions ({}, {}); the demonstrations have ({}, {}): \
             give episodes of the same task",
            args.episodes.display(),
            episodes.obs_dim(),
            episodes.act_dim(),
            set.obs_dim(),
            set.act_dim()
        );
    }
    let prepared = scalings
        .iter()
        .map(|&scaling| Ok((scaling, Demonstrations::new(&set, mode, CostOptions::with_scaling(scaling))?)))
        .collect::<Result<Vec<_>>>()?;
    let mut jobs = Vec::new();
    for &strategy in &strategies {
        for (scaling, demos) in &prepared {
            for &variant in &variants {
                jobs.push((strategy, *scaling, demos, variant));
            }
        }
    }
    let n = episodes.len().min(args.first.unwrap_or(usize::MAX));
    note!("screening {} variants over {n} recorded episodes ...", jobs.len());
    let lines = jobs
        .into_par_iter()
        .map(|(strategy, scaling, demos, variant)| {
            let tally = defender::screen(demos, strategy, variant, &episodes, args.first, |_, _| {})?;
            Ok(Line { strategy, scaling, variant, tally })
        })
        .collect::<Result<Vec<_>>>()?;
    write(&args.out, &lines)?;
    print(&lines);
    say!("{} lines -> {}", lines.len(), args.out.display());
    Ok(())
}

const HEADER: &str = "strategy,scaling,variant,episodes,crashed,caught_pct,false_alarm_pct,filtered_pct,\
crash_pct,kept_pct,mean_lead,late_pct,final_margin,own_safe,own_unsafe";

fn write(path: &std::path::Path, lines: &[Line]) -> Result<()> {
    let mut text = String::from(HEADER);
    text.push('\n');
    for l in lines {
        let t = &l.tally;
        text.push_str(&format!(
            "{},{},{},{},{},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.4},{},{}\n",
            l.strategy,
            l.scaling,
            l.variant.label(),
            t.episodes,
            t.crashed,
            t.caught_pct(),
            t.false_alarm_pct(),
            t.filtered_pct(),
            t.crash_pct(),
            t.kept_pct(),
            t.mean_lead(),
            late_pct(t),
            t.final_margin,
            t.own_safe,
            t.own_unsafe
        ));
    }
    defender_io::write_file(path, |w| std::io::Write::write_all(w, text.as_bytes()))
        .map_err(|(at, e)| anyhow::anyhow!("{}: {e}", at.display()))
}

fn late_pct(t: &ScreenTally) -> f64 {
    if t.caught == 0 { f64::NAN } else { 100.0 * t.caught_late as f64 / t.caught as f64 }
}

fn print(lines: &[Line]) {
    let mut table = TextTable::new(vec![
        Column::left("strategy"),
        Column::left("scaling"),
        Column::left("variant"),
        Column::right("caught%"),
        Column::right("false%"),
        Column::right("filtered%"),
        Column::right("crash%"),
        Column::right("kept%"),
        Column::right("lead"),
        Column::right("late%"),
        Column::right("margin"),
    ])
    .with_rule();
    for l in lines {
        let t = &l.tally;
        table.row([
            l.strategy.to_string(),
            l.scaling.to_string(),
            l.variant.label(),
            format!("{:.1}", t.caught_pct()),
            format!("{:.1}", t.false_alarm_pct()),
            format!("{:.1}", t.filtered_pct()),
            format!("{:.1}", t.crash_pct()),
            format!("{:.1}", t.kept_pct()),
            format!("{:.1}", t.mean_lead()),
            format!("{:.1}", late_pct(t)),
            format!("{:.3}", t.final_margin),
        ]);
    }
    put!("{}", table.render());
}
