//! Finding run directories under the paths given, and loading them all.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use defender_io::DirLock;

use crate::error::{ReportError, Result, io_err};
use crate::run::{CONFIG_FILE, EVAL_FILE, METRICS_FILE, Run, SUMMARY_FILE};
use crate::status::{SkippedRun, has_checkpoint, lock_holder, not_complete, running};

/// The runs to report on.
#[derive(Debug, Clone, Default)]
pub struct RunSet {
    /// Complete runs, in the order found.
    pub runs: Vec<Run>,
    /// Run directories left out, in order: still running, stopped or broken.
    pub skipped: Vec<SkippedRun>,
}

/// Whether `path` is a run directory, complete or not: it holds a file of the run directory
/// (`summary.json`, `config.toml`, `metrics.csv`, `eval.csv`) or a checkpoint, or nothing but
/// `.lock` (a `defender train` in its first seconds, before it writes `config.toml`).
fn is_run_dir(path: &Path) -> bool {
    if [SUMMARY_FILE, CONFIG_FILE, METRICS_FILE, EVAL_FILE].iter().any(|f| path.join(f).is_file())
        || has_checkpoint(path)
    {
        return true;
    }
    // A sweep's directory also has a `.lock`, beside its `.sweep/` and the runs' folders.
    let mut entries = match std::fs::read_dir(path) {
        Ok(entries) => entries.filter_map(|e| e.ok()).map(|e| e.file_name()),
        Err(_) => return false,
    };
    entries.next().is_some_and(|name| name == DirLock::FILE_NAME) && entries.next().is_none()
}

/// Expands `paths` into run directories ([`is_run_dir`]: complete, running, stopped or broken);
/// a path that is not one has its subdirectories, and theirs, searched (one or two levels deep;
/// hidden ones such as a sweep's `.sweep/` are not), so `runs/` and `runs/hopper/` both work.
/// The result is sorted and free of duplicates.
///
/// # Errors
///
/// [`ReportError::NoSuchPath`] for a path that does not exist, [`ReportError::NoRuns`] for one
/// with no run directory in it or one or two levels below it, [`ReportError::Io`] when a directory
/// cannot be listed.
pub fn find_run_dirs<P: AsRef<Path>>(paths: &[P]) -> Result<Vec<PathBuf>> {
    let mut found = Vec::new();
    for path in paths {
        let path = path.as_ref();
        if !path.exists() {
            return Err(ReportError::NoSuchPath { path: path.to_path_buf() });
        }
        let before = found.len();
        search(path, 2, &mut found)?;
        if found.len() == before {
            return Err(ReportError::NoRuns { path: path.to_path_buf() });
        }
    }
    // The same directory reached through two arguments (`runs/` and `runs/a`) counts once.
    let mut unique = BTreeMap::new();
    for dir in found {
        let key = std::fs::canonicalize(&dir).map_err(io_err(&dir))?;
        unique.entry(key).or_insert(dir);
    }
    let mut dirs: Vec<PathBuf> = unique.into_values().collect();
    dirs.sort();
    Ok(dirs)
}

fn search(path: &Path, depth: usize, found: &mut Vec<PathBuf>) -> Result<()> {
    if is_run_dir(path) {
        found.push(path.to_path_buf());
        return Ok(());
    }
    if depth == 0 || !path.is_dir() {
        return Ok(());
    }
    let mut children = Vec::new();
    for entry in std::fs::read_dir(path).map_err(io_err(path))? {
        let entry = entry.map_err(io_err(path))?;
        let hidden = entry.file_name().to_string_lossy().starts_with('.');
        // A symbolic link to a directory counts as one: an experiment shares a run of another
        // whose configuration is identical by linking to it (docs/experiments.md).
        if !hidden && entry.path().is_dir() {
            children.push(entry.path());
        }
    }
    children.sort();
    for child in children {
        search(&child, depth - 1, found)?;
    }
    Ok(())
}

/// Finds the run directories under `paths` ([`find_run_dirs`]) and loads the complete ones
/// ([`Run::load`]). The others are not an error: they are returned in [`RunSet::skipped`], with
/// their state, for the caller to list: still running (a process holds the directory's lock, even
/// when its `summary.json` says complete: its files are being rewritten), stopped (no complete
/// `summary.json`, a checkpoint present) or broken (neither).
///
/// # Errors
///
/// The errors of [`find_run_dirs`] and [`Run::load`] (a complete run whose files are unreadable or
/// contradict each other stops the report: a table silently missing a run would be wrong);
/// [`ReportError::Duplicate`] when two
/// directories hold the same experiment (task, algorithm, budget, strategy, mode, number of
/// demonstrations, seed).
pub fn load_runs<P: AsRef<Path>>(paths: &[P]) -> Result<RunSet> {
    let mut set = RunSet::default();
    for dir in find_run_dirs(paths)? {
        if let Some(holder) = lock_holder(&dir) {
            set.skipped.push(running(&dir, holder));
            continue;
        }
        if !dir.join(SUMMARY_FILE).is_file() {
            set.skipped.push(not_complete(&dir));
            continue;
        }
        match Run::load(&dir) {
            Ok(run) => set.runs.push(run),
            Err(ReportError::Incomplete { dir }) => set.skipped.push(not_complete(&dir)),
            Err(err) => return Err(err),
        }
    }
    let mut seen: BTreeMap<String, &Path> = BTreeMap::new();
    for run in &set.runs {
        let c = &run.config;
        let what = match &c.filter {
            None => format!("{} {} {} bare seed {}", c.env, c.algo, c.budget, c.seed),
            Some(f) => format!(
                "{} {} {} {} {} demos {:?} seed {}",
                // The name, not the bare strategy: an automatic choice or z-scored DTW of the
                // same strategy is another configuration, not a second copy of this run.
                c.env,
                c.algo,
                c.budget,
                f.name(),
                f.mode,
                f.num_demos,
                c.seed
            ),
        };
        if let Some(first) = seen.get(&what) {
            return Err(ReportError::Duplicate { first: first.to_path_buf(), second: run.dir.clone(), what });
        }
        seen.insert(what, &run.dir);
    }
    Ok(set)
}
