//! `defender report RUN_DIR...`: the paper's tables (and optionally the learning-curve plots)
//! from run directories; a thin layer over the `defender-report` crate.

use std::io::Write as _;
use std::path::PathBuf;

use clap::{Args, ValueEnum};
use defender_report::{Format, PlotOptions, ReportError, Table, draw_plots, load_runs, render, write_atomic};

const AFTER_HELP: &str = "\
Examples:
  defender report runs/                              Markdown tables of every run under runs/
  defender report runs/ --format latex --out tables.tex
  defender report runs/hopper runs/walker --format csv --plots plots/

Per task x algorithm x strategy, over seeds: Acc Reward (final evaluation return) and % Crash
as mean ± std (population std, ddof = 0), and % Time: wall-clock time / that of the bare run
with the same task, algorithm, budget and seed x 100 (\"-\" without a bare run). Incomplete runs
(\"complete\": false) are skipped with a warning; any other bad run directory is an error.
The run-directory format is docs/run-directory.md.";

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
    /// Also draw the learning curves (training return, cumulative crash rate, evaluation return;
    /// PNG and SVG) into DIR, created if needed.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
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
    for skipped in &set.skipped {
        eprintln!("warning: skipping {}: {}", skipped.dir.display(), skipped.reason);
    }
    if set.runs.is_empty() {
        return Err(ReportError::Empty.into());
    }
    let table = Table::from_runs(&set.runs);
    let format = Format::from(args.format);
    let text = render(&table, format);
    if format == Format::Csv {
        // Markdown and LaTeX carry the notes in the output; CSV has no place for them.
        for note in &table.notes {
            eprintln!("note: {note}");
        }
    }
    match &args.out {
        Some(path) => {
            if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
                std::fs::create_dir_all(parent)
                    .map_err(|source| ReportError::Io { path: parent.to_path_buf(), source })?;
            }
            write_atomic(path, text.as_bytes())?;
            eprintln!("wrote {} ({} rows from {} runs)", path.display(), table.rows.len(), set.runs.len());
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
        let plots = draw_plots(&set.runs, dir, &PlotOptions::default())?;
        for note in &plots.notes {
            eprintln!("note: {note}");
        }
        eprintln!("wrote {} plot files to {}", plots.files.len(), dir.display());
    }
    if let Some(dir) = &args.tensorboard {
        let n = crate::tensorboard::convert::write_runs(&set.runs, &args.runs, dir)?;
        eprintln!("wrote the TensorBoard event files of {n} runs to {}", dir.display());
    }
    Ok(())
}
