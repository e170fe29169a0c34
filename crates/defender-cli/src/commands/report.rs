//! `defender report RUN_DIR...`: the paper's tables (and optionally the learning-curve plots)
//! from run directories; a thin layer over the `defender-report` crate.

use std::io::Write as _;
use std::path::PathBuf;

use clap::{Args, ValueEnum};
use defender_report::{
    CostLimits, Format, PlotOptions, ReportError, Table, TableOptions, draw_plots, load_runs, render,
    write_atomic,
};

use anyhow::bail;

const AFTER_HELP: &str = "\
Examples:
  defender report runs/                              Markdown tables of every run under runs/
  defender report runs/ --format latex --out tables.tex
  defender report runs/hopper runs/walker --format csv --plots plots/
  defender report results/keeps-learning --plots plots/ --crash-window 30000 --strict

Per task x algorithm x strategy, over seeds: Acc Reward (final eval) as SPEC 6; Best episode
(the paper's Acc Reward: the best training-episode return); Last-10 eval (mean of the last 10
evaluations); % Crash; Standing % (evaluations that stood still); each as mean ± std
(population std, ddof = 0) [95% percentile bootstrap interval over seeds, 50,000 resamples,
fixed seed], with the number of seeds. % Time: wall-clock time / that of the bare run with the
same task, algorithm, budget and seed x 100 (\"-\" without a bare run); a row without the filter
that changes the agent (penalty, Lagrangian, Recovery RL, demos alone, a peer's SAC) is timed
against plain bare SAC or TD3.

A task with a per-step cost and an episode cost limit (the Safety*Velocity-v1 tasks: 25, OmniSafe's
benchmark setting on Safety-Gymnasium) adds: Cost rate (training cost / environment steps,
filtered steps not counted), Eval cost (last-10: the evaluations' mean cost over the last 10),
Episodes cost > 25 (training episodes over the limit, counted) and % episodes cost > 25 (the
same / all training episodes: like % Crash, a filter's own episodes join its denominator);
--plots adds *_cost (cumulative training cost) and *_eval_cost (evaluation cost, the limit drawn
across). Where DEFENDER runs have evaluations with the filter kept (eval.csv's shield_* columns),
--plots adds *_shield_eval (their return) and, on a cost task, *_shield_eval_cost, for the
configurations with a filter.

A row with a filter adds Filtered (interventions): the training episodes DEFENDER ended over the
run (metrics.csv's filtered episodes), beside Crashes. Where its runs have interventions.csv
(defender train --check-every K checks every K-th one against its unfiltered continuation), it
adds, over the whole run: Checked; Precision, the share of the checked interventions whose
continuation failed; Lead (median steps) from an intervention to that failure; and
Interventions / crash avoided, its interventions / (the bare row's crashes - its crashes), the
bare row of the same task, budget and agent (\"-\" without one, or when it does not crash less).

A run directory that is not complete is left out and listed, with its state: still running
(its lock is held), stopped (a checkpoint to resume from) or broken; --strict makes that an
error. Any other bad run directory is an error. Definitions and the run-directory format:
docs/run-directory.md.";

/// Output format of the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    /// Markdown, readable in a terminal.
    Md,
    /// LaTeX (booktabs), laid out like the paper's Tables 1 and 2.
    Latex,
    /// CSV, one row per task x algorithm x strategy with mean and std columns.
    Csv,
}

impl From<FormatArg> for Format {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Md => Format::Markdown,
            FormatArg::Latex => Format::Latex,
            FormatArg::Csv => Format::Csv,
        }
    }
}

/// `defender report` arguments.
#[derive(Debug, Args)]
#[command(after_help = AFTER_HELP)]
pub struct ReportArgs {
    /// Run directories, or folders holding them (searched one or two levels deep).
    #[arg(required = true, value_name = "RUN_DIR")]
    pub runs: Vec<PathBuf>,
    /// Output format of the table.
    #[arg(long, value_enum, default_value_t = FormatArg::Md)]
    pub format: FormatArg,
    /// Also draw the plots into DIR, created if needed (PNG and SVG): per task, the learning
    /// curves (training return, cumulative crash rate, evaluation return), the trade-off of the
    /// final results, and `*_windows`, the crash rate over a rolling window of steps beside the
    /// evaluation return, for reading long budgets; for a task with a cost limit, `*_cost` and
    /// `*_eval_cost`.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// The window of the rolling crash rate in `--plots` (`*_windows`), in environment steps
    /// [default: a tenth of the steps the runs reach, to two significant digits].
    #[arg(long, value_name = "STEPS", requires = "plots", value_parser = clap::value_parser!(u64).range(1..))]
    pub crash_window: Option<u64>,
    /// Fail (exit code 1, nothing written) when a run directory found is not complete (still
    /// running, stopped or broken) instead of leaving it out with a warning.
    #[arg(long)]
    pub strict: bool,
    /// Write the table to FILE (atomically) instead of standard output.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Also write TensorBoard event files from the runs' CSV files into DIR, one per run at its
    /// path below the folder given (for runs that predate the event files `defender train`
    /// writes): `tensorboard --logdir DIR`.
    #[arg(long, value_name = "DIR")]
    pub tensorboard: Option<PathBuf>,
}

/// Runs `defender report`.
pub fn run(args: ReportArgs) -> anyhow::Result<()> {
    let set = load_runs(&args.runs)?;
    if args.strict && !set.skipped.is_empty() {
        let list: Vec<String> =
            set.skipped.iter().map(|s| format!("  {}: {}", s.dir.display(), s.reason)).collect();
        bail!(
            "--strict: {} run director{} not complete; nothing written:\n{}",
            set.skipped.len(),
            if set.skipped.len() == 1 { "y is" } else { "ies are" },
            list.join("\n")
        );
    }
    for skipped in &set.skipped {
        note!("warning: skipping {}: {}", skipped.dir.display(), skipped.reason);
    }
    if set.runs.is_empty() {
        return Err(ReportError::Empty.into());
    }
    // The episode cost limits are the task registry's (defender-mujoco), which the report crate
    // does not depend on: a per-step cost task's rows and plots get the cost measures.
    let cost_limits: CostLimits = defender_mujoco::registry()
        .iter()
        .filter_map(|spec| spec.cost.episode_limit().map(|limit| (spec.id, limit)))
        .collect();
    let options = TableOptions { cost_limits: cost_limits.clone() };
    let mut table = Table::from_runs_with(&set.runs, &options);
    let format = Format::from(args.format);
    if format == Format::Csv {
        // Markdown and LaTeX carry the notes in the output; CSV has no place for them.
        for note in &table.notes {
            note!("note: {note}");
        }
    } else if !set.skipped.is_empty() {
        // The written report says that it is short of these runs, not only this terminal.
        table
            .notes
            .extend(set.skipped.iter().map(|s| format!("Left out: {}: {}.", s.dir.display(), s.reason)));
    }
    let text = render(&table, format);
    match &args.out {
        Some(path) => {
            if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
                std::fs::create_dir_all(parent)
                    .map_err(|source| ReportError::Io { path: parent.to_path_buf(), source })?;
            }
            write_atomic(path, text.as_bytes())?;
            note!("wrote {} ({} rows from {} runs)", path.display(), table.rows.len(), set.runs.len());
        }
        None => {
            let mut stdout = std::io::stdout().lock();
            match stdout.write_all(text.as_bytes()).and_then(|()| stdout.flush()) {
                // `defender report runs/ | head` is not an error.
                Err(err) if err.kind() == std::io::ErrorKind::BrokenPipe => {}
                other => other?,
            }
        }
    }
    if let Some(dir) = &args.plots {
        let options = PlotOptions { crash_window: args.crash_window, cost_limits, ..PlotOptions::default() };
        let plots = draw_plots(&set.runs, dir, &options)?;
        for note in &plots.notes {
            note!("note: {note}");
        }
        note!("wrote {} plot files to {}", plots.files.len(), dir.display());
    }
    if let Some(dir) = &args.tensorboard {
        let n = crate::tensorboard::convert::write_runs(&set.runs, &args.runs, dir)?;
        note!("wrote the TensorBoard event files of {n} runs to {}", dir.display());
    }
    Ok(())
}
