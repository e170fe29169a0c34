//! `defender report RUN_DIR... --tensorboard DIR`: TensorBoard event files written from the CSV
//! files of complete runs (those that predate the event files `defender train` writes, such as
//! the committed results), one per run under `DIR`, at the run directory's path relative to the
//! folder it was found in, so that `tensorboard --logdir DIR` names each curve as a run written
//! today would be named. The scalars are a training run's (see [`super::board`]) less the ones
//! its CSV files do not hold (speed, costs); `wall_time` is the run's own clock (its seconds since
//! it started, from the Unix epoch), as the CSV files record no date. Converting again replaces
//! the file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use defender_report::{DYNAMICS_FILE, Run, UPDATES_FILE};

use super::board::{Rates, dynamics_scalars, eval_scalars, update_scalars};
use super::event_file::EventFile;
use crate::update_log::{DynamicsRow, UpdateRow};

/// The name of a converted run's event file (fixed, so a second conversion replaces it).
const FILE_NAME: &str = "events.out.tfevents.0.defender-report";

/// Where the events of the run in `dir` go under `out`: its path relative to the first of
/// `roots` that holds it (or its own name when none does).
fn target(dir: &Path, roots: &[PathBuf], out: &Path) -> PathBuf {
    let rel = roots
        .iter()
        .find_map(|root| dir.strip_prefix(root).ok().filter(|r| !r.as_os_str().is_empty()))
        .map_or_else(|| PathBuf::from(dir.file_name().unwrap_or(dir.as_os_str())), Path::to_path_buf);
    out.join(rel)
}

/// Reads an optional `updates.csv` / `dynamics.csv` (a run that predates it has none).
fn rows<T>(path: &Path, parse: impl Fn(&str) -> Result<T, String>) -> Result<Vec<T>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
    };
    text.lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.is_empty())
        .map(|(i, l)| parse(l).map_err(|e| anyhow::anyhow!("{} line {}: {e}", path.display(), i + 1)))
        .collect()
}

/// Writes the event file of `run` into `dir`; returns its path.
///
/// # Errors
/// A file that cannot be read or written, or a malformed `updates.csv` / `dynamics.csv`.
pub fn write_run(run: &Run, dir: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let path = dir.join(FILE_NAME);
    let updates = rows(&run.dir.join(UPDATES_FILE), UpdateRow::parse)?;
    let dynamics = rows(&run.dir.join(DYNAMICS_FILE), DynamicsRow::parse)?;
    // The run's clock at a step: that of the episode that ended there or after it.
    let clock = |step: u64| {
        let i = run.episodes.partition_point(|e| e.total_steps < step);
        run.episodes.get(i).or(run.episodes.last()).map_or(0.0, |e| e.wall_seconds)
    };
    let mut file = EventFile::create(&path, 0.0)?;
    let mut rates = Rates::default();
    for e in &run.episodes {
        file.scalars(e.total_steps, e.wall_seconds, &rates.add(e.outcome, e.ret, e.length, e.cost))?;
    }
    for u in &updates {
        file.scalars(u.total_steps, clock(u.total_steps), &update_scalars(u))?;
    }
    for d in &dynamics {
        file.scalars(d.total_steps, clock(d.total_steps), &dynamics_scalars(d))?;
    }
    for v in &run.evaluations {
        file.scalars(v.total_steps, clock(v.total_steps), &eval_scalars(v))?;
    }
    file.flush()?;
    Ok(path)
}

/// Writes the event files of `runs` (found under `roots`) under `out`; returns how many.
///
/// # Errors
/// As [`write_run`].
pub fn write_runs(runs: &[Run], roots: &[PathBuf], out: &Path) -> Result<usize> {
    for run in runs {
        write_run(run, &target(&run.dir, roots, out))?;
    }
    Ok(runs.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_keeps_its_path_below_the_folder_it_was_found_in() {
        let roots = [PathBuf::from("results/table1"), PathBuf::from("runs/x")];
        let out = Path::new("tb");
        assert_eq!(
            target(Path::new("results/table1/Hopper-v5/sac/bare/seed0"), &roots, out),
            Path::new("tb/Hopper-v5/sac/bare/seed0")
        );
        // A run given itself is named by its folder.
        assert_eq!(target(Path::new("runs/x"), &roots, out), Path::new("tb/x"));
    }
}
