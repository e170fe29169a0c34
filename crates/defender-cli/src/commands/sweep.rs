//! `defender sweep`: run an experiment file's grid on this machine.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;

use crate::signals::{StopRequest, Stopped};
use crate::sweep::runner::{self, RunState, state_of};
use defender_config::experiment;

/// Arguments of `defender sweep`.
#[derive(Debug, Args)]
#[command(after_help = "Examples:
  defender sweep experiments/table1.toml --out results/table1 --jobs 2
  defender sweep experiments/table1.toml --out results/table1 --list      (the runs and where they stand)
  defender report results/table1 --plots results/table1/plots             (the tables, over seeds)

Every run is an ordinary run directory, <out>/<task>/<algo>-<strategy>-s<seed>. Started again,
the sweep skips complete runs (refusing any made with another configuration than the file asks
for) and resumes stopped ones from their checkpoint. Ctrl-C or SIGTERM
stops every run at its next episode end with a checkpoint (exit code 130/143); nothing is lost.
Each run uses one core (one network thread): --jobs N runs N at a time [default: the cores].
Each run's output goes to <out>/.sweep/logs/<task>__<run>.log (a `progress:` line a minute;
DEFENDER_PROGRESS_INTERVAL=SECONDS or off), the sweep's own to stderr.
The experiment format is in docs/experiments.md.")]
pub struct SweepArgs {
    /// The experiment file (TOML grid; see experiments/).
    pub experiment: PathBuf,
    /// The sweep directory (one run directory per grid point).
    #[arg(long)]
    pub out: PathBuf,
    /// Runs at a time [default: the number of cores].
    #[arg(long)]
    pub jobs: Option<usize>,
    /// List the runs and their state (complete, changed, running, stopped, new) without running
    /// anything; every run's configuration is checked first.
    #[arg(long)]
    pub list: bool,
    /// With --list: one JSON object per run (name, dir, state, config), for other schedulers.
    #[arg(long, requires = "list")]
    pub json: bool,
}

/// Runs `defender sweep`.
pub fn run(args: SweepArgs) -> Result<()> {
    if args.out.exists() && !args.out.is_dir() {
        bail!(
            "--out {}: exists and is not a directory; give a sweep directory (made if missing)",
            args.out.display()
        );
    }
    let experiment = experiment::load(&args.experiment, &crate::setup::task_ids())?;
    for run in &experiment.runs {
        run.config.check_for_task(crate::setup::task_cost_limit(&run.config.env)).with_context(|| {
            format!("{}: not a valid experiment: run '{}'", args.experiment.display(), run.name)
        })?;
    }
    if args.list {
        for run in &experiment.runs {
            for warning in defender_config::inert::warnings(&run.config) {
                note!("warning: {}: {warning}", run.name);
            }
            let dir = args.out.join(&run.name);
            let state = match state_of(&dir) {
                // A complete run made with another configuration is not this experiment's run.
                RunState::Complete
                    if !crate::sweep::complete::differences(&dir, &run.config_in(&args.out))?.is_empty() =>
                {
                    "changed"
                }
                // Its lock is held: a `defender train` is writing it right now.
                RunState::Stopped | RunState::New if defender_io::DirLock::is_held(&dir) => "running",
                state => state.as_str(),
            };
            if args.json {
                let line = serde_json::json!({
                    "name": run.name,
                    "dir": dir,
                    "state": state,
                    "config": toml::to_string(&run.config_in(&args.out))?,
                });
                say!("{line}");
            } else {
                say!("{state:8} {}", run.name);
            }
        }
        return Ok(());
    }
    let jobs = args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
    if jobs == 0 {
        bail!("--jobs must be at least 1");
    }
    let stop = StopRequest::install()?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let _lock = defender_io::DirLock::try_acquire(&args.out)?;
    crate::sweep::complete::check(&args.out, &experiment.runs)?;
    if !experiment.description.is_empty() {
        note!("{}", experiment.description);
    }
    if let Some(paper) = &experiment.paper {
        let per_run = match (paper.episodes, paper.steps) {
            (Some(e), _) => format!("{e} episodes"),
            (None, Some(s)) => format!("{s} steps"),
            (None, None) => "unstated".to_string(),
        };
        note!(
            "the paper's budget: {per_run} per run, {} seeds; this file's budget is in config.toml of each run",
            paper.seeds.map_or("?".to_string(), |s| s.to_string())
        );
    }
    let end = runner::run_all(&args.out, &experiment.runs, jobs, &stop)?;
    note!(
        "sweep: {} completed now, {} were complete, {} failed{}; tables: defender report {}",
        end.completed,
        end.skipped,
        end.failed.len(),
        if end.stopped { ", stopped (start it again to continue)" } else { "" },
        args.out.display()
    );
    if let (true, Some(code)) = (end.stopped, stop.exit_code()) {
        return Err(Stopped { code }.into());
    }
    if !end.failed.is_empty() {
        let names: Vec<&str> = end.failed.iter().map(|(n, _)| n.as_str()).collect();
        bail!(
            "{} run(s) failed: {} (their logs are in {}/.sweep/logs)",
            names.len(),
            names.join(", "),
            args.out.display()
        );
    }
    Ok(())
}
