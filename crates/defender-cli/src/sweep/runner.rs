//! Running an experiment on this machine: N runs at a time, each an ordinary `defender train`
//! process on one core (one network thread), complete runs skipped and stopped ones resumed.
//!
//! Each run is a child process in its own process group, so a Ctrl-C at the terminal reaches
//! only the sweep, which passes one SIGTERM to every running run: each stops at its next
//! episode end with a checkpoint. The children are also told by the kernel (PR_SET_PDEATHSIG)
//! to stop if the sweep itself dies, so a killed sweep leaves no orphan training.

use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use anyhow::{Context, Result};

use crate::signals::StopRequest;
use defender_config::experiment::PlannedRun;

/// Where a run of the sweep stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunState {
    /// `summary.json` says complete.
    Complete,
    /// Started before (its `config.toml` exists): resumed from its checkpoint.
    Stopped,
    /// Not started.
    New,
}

impl RunState {
    /// How `--list` shows it.
    pub fn as_str(self) -> &'static str {
        match self {
            RunState::Complete => "complete",
            RunState::Stopped => "stopped",
            RunState::New => "new",
        }
    }
}

/// The state of the run directory `dir`.
pub fn state_of(dir: &Path) -> RunState {
    let complete = std::fs::read_to_string(dir.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v.get("complete").and_then(serde_json::Value::as_bool))
        .unwrap_or(false);
    if complete {
        RunState::Complete
    } else if dir.join("config.toml").exists() {
        RunState::Stopped
    } else {
        RunState::New
    }
}

/// The sweep's own files (not run directories): the runs' configurations and logs.
pub const SWEEP_DIR: &str = ".sweep";

/// How the sweep ended.
#[derive(Debug, Default)]
pub struct SweepEnd {
    /// Runs completed in this invocation.
    pub completed: usize,
    /// Runs that were already complete.
    pub skipped: usize,
    /// Runs that failed, with the tail of their log.
    pub failed: Vec<(String, String)>,
    /// Whether a signal stopped the sweep.
    pub stopped: bool,
}

struct Running {
    name: String,
    child: Child,
    dir: PathBuf,
    signalled: bool,
}

fn flat(name: &str) -> String {
    name.replace('/', "__")
}

fn last_steps(dir: &Path) -> u64 {
    std::fs::read_to_string(dir.join("metrics.csv"))
        .ok()
        .and_then(|t| t.lines().last().and_then(|l| l.split(',').nth(1)).and_then(|s| s.parse().ok()))
        .unwrap_or(0)
}

fn log_tail(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    lines[lines.len().saturating_sub(5)..].join("\n")
}

/// The run's summary: its one-line summary (`... steps, ... episodes, Acc Reward ...`), the log's
/// last line that is not a progress line, the closing `run directory:` line or the evaluation
/// line, followed by that evaluation line (`evaluation (mean of the last 10 ...`) when the run
/// printed one after it, and by a DEFENDER run's `interventions:` line.
fn summary_line(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().map(str::trim).collect();
    let is_eval = |l: &str| l.starts_with("evaluation (");
    let is_interventions = |l: &str| l.starts_with("interventions:");
    let Some(at) = lines.iter().rposition(|l| {
        !l.is_empty()
            && !l.starts_with("run directory:")
            && !l.starts_with("progress:")
            && !is_eval(l)
            && !is_interventions(l)
    }) else {
        return String::new();
    };
    let mut line = match lines.get(at + 1).filter(|l| is_eval(l)) {
        Some(eval) => format!("{}; {eval}", lines[at]),
        None => lines[at].to_string(),
    };
    if let Some(interventions) = lines[at..].iter().find(|l| is_interventions(l)) {
        line.push_str("; ");
        line.push_str(interventions);
    }
    line
}

fn spawn(binary: &Path, root: &Path, run: &PlannedRun, state: RunState) -> Result<Running> {
    let sweep = root.join(SWEEP_DIR);
    let config_path = sweep.join("configs").join(format!("{}.toml", flat(&run.name)));
    let text =
        toml::to_string_pretty(&run.config_in(root)).context("cannot serialise a run configuration")?;
    defender_io::write_bytes(&config_path, text.as_bytes())
        .map_err(|(p, e)| anyhow::anyhow!("cannot write {}: {e}", p.display()))?;
    let log_path = sweep.join("logs").join(format!("{}.log", flat(&run.name)));
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .with_context(|| format!("cannot open {}", log_path.display()))?;
    let dir = root.join(&run.name);
    if let Some(parent) = dir.parent() {
        std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    }
    let mut cmd = Command::new(binary);
    cmd.arg("train").arg("--config").arg(&config_path).arg("--out").arg(&dir);
    if state == RunState::Stopped {
        // The experiment's configuration is given again: a run whose file changed is refused.
        cmd.arg("--resume");
    }
    cmd.env("DEFENDER_NN_THREADS", "1")
        .stdin(Stdio::null())
        .stdout(log.try_clone().context("cannot share the log file")?)
        .stderr(log)
        .process_group(0);
    // SAFETY: prctl is async-signal-safe; it only asks the kernel to send SIGTERM to the child
    // when this process dies.
    unsafe {
        cmd.pre_exec(|| {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let child = cmd.spawn().with_context(|| format!("cannot start {}", binary.display()))?;
    Ok(Running { name: run.name.clone(), child, dir, signalled: false })
}

/// Runs every run of `runs` that is not complete, `jobs` at a time, into `root`.
pub fn run_all(root: &Path, runs: &[PlannedRun], jobs: usize, stop: &StopRequest) -> Result<SweepEnd> {
    let binary = std::env::current_exe().context("cannot find the defender binary")?;
    for sub in ["configs", "logs"] {
        let d = root.join(SWEEP_DIR).join(sub);
        std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
    }
    let mut end = SweepEnd::default();
    let mut queue: Vec<(&PlannedRun, RunState)> = Vec::new();
    for run in runs {
        match state_of(&root.join(&run.name)) {
            RunState::Complete => end.skipped += 1,
            state => queue.push((run, state)),
        }
    }
    let total = runs.len();
    let budget_of = |r: &PlannedRun| r.config.total_steps.max(1);
    let steps_total: u64 = queue.iter().map(|(r, _)| budget_of(r)).sum();
    note!(
        "sweep: {total} runs, {} complete, {} to run ({} resumed), {jobs} at a time",
        end.skipped,
        queue.len(),
        queue.iter().filter(|(_, s)| *s == RunState::Stopped).count()
    );
    let bar = crate::progress::bar(steps_total, "steps");
    let mut pending = queue.into_iter();
    let mut running: Vec<Running> = Vec::new();
    let mut finished_steps = 0u64;
    loop {
        if stop.is_requested() {
            end.stopped = true;
            for r in running.iter_mut().filter(|r| !r.signalled) {
                // One SIGTERM each: the run stops at its next episode end with a checkpoint.
                // SAFETY: kill(2) with a pid this process spawned and still waits for.
                unsafe {
                    libc::kill(r.child.id() as libc::pid_t, libc::SIGTERM);
                }
                r.signalled = true;
            }
        }
        while !end.stopped && running.len() < jobs {
            let Some((run, state)) = pending.next() else { break };
            running.push(spawn(&binary, root, run, state)?);
        }
        if running.is_empty() {
            break;
        }
        let mut i = 0;
        while i < running.len() {
            match running[i].child.try_wait().context("cannot wait for a run")? {
                None => i += 1,
                Some(status) => {
                    let r = running.swap_remove(i);
                    let log = root.join(SWEEP_DIR).join("logs").join(format!("{}.log", flat(&r.name)));
                    let done = runs.iter().find(|p| p.name == r.name).map_or(0, budget_of);
                    match (status.success(), state_of(&r.dir)) {
                        (true, RunState::Complete) => {
                            end.completed += 1;
                            finished_steps += done;
                            bar.suspend(|| {
                                note!(
                                    "[{}/{total}] complete {}: {}",
                                    end.completed + end.skipped,
                                    r.name,
                                    summary_line(&log)
                                );
                            });
                        }
                        _ if r.signalled => {
                            bar.suspend(|| {
                                note!("stopped {} (resumes when the sweep is started again)", r.name)
                            });
                        }
                        _ => {
                            let tail = log_tail(&log);
                            bar.suspend(|| note!("FAILED {} ({status}):\n{tail}", r.name));
                            end.failed.push((r.name.clone(), tail));
                        }
                    }
                }
            }
        }
        let live: u64 = running.iter().map(|r| last_steps(&r.dir)).sum();
        bar.set_position((finished_steps + live).min(steps_total));
        let names: Vec<String> = running
            .iter()
            .map(|r| {
                let of = runs.iter().find(|p| p.name == r.name).map_or(1, budget_of);
                format!("{} {:.0}%", r.name, 100.0 * last_steps(&r.dir) as f64 / of as f64)
            })
            .collect();
        // Off a terminal, crate::progress prints this as a line every minute.
        bar.set_message(format!(
            "{}/{total} complete; running: {}",
            end.completed + end.skipped,
            names.join(", ")
        ));
        std::thread::sleep(Duration::from_millis(200));
    }
    bar.finish_and_clear();
    Ok(end)
}
