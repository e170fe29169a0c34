//! `defender ablate`: the offline ablation of SPEC section 7, ranking filtering strategies by
//! replaying recorded episodes against the demonstrations.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use defender::{AblationRow, EpisodeSet, Mode, Strategy, Window};

use crate::progress;
use crate::text_table::{Column, TextTable};

/// Arguments of `defender ablate`.
#[derive(Debug, Args)]
#[command(after_help = "Examples:
  defender train --env Hopper-v5 --steps 100000 --out runs/bare --record-episodes hopper-episodes.npz
  defender ablate --demos data/demos/Hopper-v5.npz --episodes hopper-episodes.npz --out scores.csv
  defender ablate --demos a.npz --episodes a-ep.npz --demos b.npz --episodes b-ep.npz --out scores.csv
  defender ablate ... --strategies MeanDemoW5/MeanDemoW10,MinBoth/MinTrajW10
  defender ablate ... --strategies all --no-equal     (skip the Equal window: it costs O(n^2) per step)
  defender ablate --combine hopper.csv walker.csv --out both.csv   (rank tasks ablated apart)

Several --demos/--episodes pairs (one per task) rank the strategies by the mean score over tasks;
--combine ranks the same way from rankings already written (one CSV per task, the same strategies
and mode), so tasks can be ablated apart (one at a time, on other machines) and ranked together.
score = mean episode-length ratio x safe-episode rate (SPEC section 7); the CSV has one row per
strategy (SPEC section 9) and the top 10 are printed.")]
pub struct AblateArgs {
    /// Demonstration set of a task (repeat once per task, paired in order with --episodes).
    #[arg(long, required_unless_present = "combine")]
    pub demos: Vec<PathBuf>,
    /// Recorded episode set of the same task (e.g. from `defender train --record-episodes`).
    #[arg(long, required_unless_present = "combine")]
    pub episodes: Vec<PathBuf>,
    /// Rank by the mean over these per-task rankings (CSVs this command wrote) instead of
    /// replaying episodes.
    #[arg(long, num_args = 2.., conflicts_with_all = ["demos", "episodes", "strategies", "no_equal", "num_demos"])]
    pub combine: Vec<PathBuf>,
    /// Trajectory elements: states, or state-action pairs.
    #[arg(long, default_value = "state", value_parser = ["state", "state-action"])]
    pub mode: String,
    /// `all`, or a comma-separated list of SAFE/UNSAFE strategies.
    #[arg(long, default_value = "all")]
    pub strategies: String,
    /// Leave out the strategies that use the Equal window (the only non-incremental one).
    #[arg(long)]
    pub no_equal: bool,
    /// Use only the first N demonstrations of each group.
    #[arg(long)]
    pub num_demos: Option<usize>,
    /// Rows to print.
    #[arg(long, default_value_t = 10)]
    pub top: usize,
    /// Where to write the scores (CSV, SPEC section 9).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `defender ablate`.
pub fn run(args: AblateArgs) -> Result<()> {
    if args.demos.len() != args.episodes.len() {
        bail!(
            "give one --episodes per --demos (got {} --demos and {} --episodes); they pair up in order",
            args.demos.len(),
            args.episodes.len()
        );
    }
    // The ablation can take minutes to hours: refuse an unwritable --out before it starts.
    crate::run_dir::check_writable(&args.out).context("--out")?;
    if !args.combine.is_empty() {
        return combine(&args);
    }
    refuse_repeats("--episodes", &args.episodes)?;
    if args.num_demos == Some(0) {
        bail!("--num-demos 0: give at least 1 demonstration per group (or leave it out for all)");
    }
    let mode: Mode = args.mode.parse()?;
    let mut strategies: Vec<Strategy> = if args.strategies == "all" {
        Strategy::all().collect()
    } else {
        Strategy::parse_list(&args.strategies)?
    };
    if args.no_equal {
        strategies.retain(|s| s.safe.window != Window::Equal && s.unsafe_.window != Window::Equal);
    }
    if strategies.is_empty() {
        bail!("no strategy left to score");
    }
    let mut per_task = Vec::new();
    for (demos_path, episodes_path) in args.demos.iter().zip(&args.episodes) {
        let mut demos = EpisodeSet::load(demos_path)?;
        if let Some(n) = args.num_demos {
            demos = demos.select_demos(n)?;
        }
        let episodes = EpisodeSet::load(episodes_path)?;
        let task = demos.meta().env_id.clone().unwrap_or_else(|| demos_path.display().to_string());
        let bar = progress::bar(episodes.len() as u64, "episodes");
        bar.set_message(format!("{task}: {} strategies, {} mode", strategies.len(), mode));
        let rows = defender::ablate(&demos, &episodes, Some(&strategies), mode, Default::default(), &|p| {
            bar.set_position(p.done as u64);
        })
        .with_context(|| {
            format!("ablation of {} against {}", episodes_path.display(), demos_path.display())
        })?;
        bar.finish_and_clear();
        eprintln!("{task}: {} recorded episodes scored", episodes.len());
        per_task.push(rows);
    }
    let rows = if per_task.len() == 1 { per_task.remove(0) } else { defender::rank_tasks(&per_task)? };
    defender::write_csv(&args.out, &rows)?;
    print_top(&rows, args.top);
    println!("{} strategies ranked -> {}", rows.len(), args.out.display());
    Ok(())
}

/// `--combine`: the mean over per-task rankings, as the ablation of several tasks ranks them.
fn combine(args: &AblateArgs) -> Result<()> {
    refuse_repeats("--combine", &args.combine)?;
    let mut per_task = Vec::new();
    for path in &args.combine {
        let rows = defender::read_csv(path).with_context(|| format!("--combine {}", path.display()))?;
        if rows.is_empty() {
            bail!("--combine {}: no strategy rows", path.display());
        }
        per_task.push(rows);
    }
    let rows = defender::rank_tasks(&per_task).context(
        "--combine: the rankings must score the same strategies in the same mode (one CSV per task)",
    )?;
    defender::write_csv(&args.out, &rows)?;
    print_top(&rows, args.top);
    println!("{} strategies ranked over {} tasks -> {}", rows.len(), per_task.len(), args.out.display());
    Ok(())
}

/// Refuses the same input given twice (the same file by another path, or a copy with the same
/// bytes): its runs would count twice in the mean over tasks, without a word.
fn refuse_repeats(flag: &str, paths: &[PathBuf]) -> Result<()> {
    let mut seen: Vec<(&PathBuf, PathBuf, Vec<u8>)> = Vec::new();
    for path in paths {
        let canonical = std::fs::canonicalize(path).with_context(|| format!("{flag} {}", path.display()))?;
        let bytes =
            std::fs::read(path).with_context(|| format!("{flag} {}: cannot read it", path.display()))?;
        if let Some((first, _, _)) = seen.iter().find(|(_, c, b)| *c == canonical || *b == bytes) {
            bail!(
                "{flag} {} is given twice ({} holds the same {}): each task's input counts once; \
                 remove the repeat",
                path.display(),
                first.display(),
                if canonical == std::fs::canonicalize(first)? { "file" } else { "bytes" }
            );
        }
        seen.push((path, canonical, bytes));
    }
    Ok(())
}

fn print_top(rows: &[AblationRow], top: usize) {
    let mut table = TextTable::new(vec![
        Column::right("rank"),
        Column::left("strategy"),
        Column::right("mean_ratio"),
        Column::right("safe_rate"),
        Column::right("score").min_width(8),
    ]);
    for r in rows.iter().take(top) {
        table.row([
            r.rank.to_string(),
            r.strategy.to_string(),
            format!("{:.4}", r.mean_ratio),
            format!("{:.4}", r.safe_rate),
            format!("{:.4}", r.score),
        ]);
    }
    print!("{}", table.render());
}
