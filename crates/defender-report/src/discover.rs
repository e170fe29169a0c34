//! Finding run directories under the paths given, and loading them all.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{ReportError, Result, io_err};
use crate::run::{Run, SUMMARY_FILE};

/// A run directory that was found but left out of the report.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedRun {
    /// The run directory.
    pub dir: PathBuf,
    /// Why, for a warning.
    pub reason: String,
}

/// The runs to report on.
#[derive(Debug, Clone, Default)]
pub struct RunSet {
    /// Complete runs, in the order found.
    pub runs: Vec<Run>,
    /// Incomplete runs (`"complete": false`), left out.
    pub skipped: Vec<SkippedRun>,
}

/// Expands `paths` into run directories: a path holding `summary.json` is a run directory;
/// otherwise its subdirectories, and theirs, are searched (one or two levels deep), so
/// `runs/` and `runs/hopper/` both work. The result is sorted and free of duplicates.
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
    if path.join(SUMMARY_FILE).is_file() {
        found.push(path.to_path_buf());
        return Ok(());
    }
    if depth == 0 || !path.is_dir() {
        return Ok(());
    }
    let mut children = Vec::new();
    for entry in std::fs::read_dir(path).map_err(io_err(path))? {
        let entry = entry.map_err(io_err(path))?;
        if entry.file_type().map_err(io_err(entry.path()))?.is_dir() {
            children.push(entry.path());
        }
    }
    children.sort();
    for child in children {
        search(&child, depth - 1, found)?;
    }
    Ok(())
}

/// Finds the run directories under `paths` ([`find_run_dirs`]) and loads them ([`Run::load`]).
/// Incomplete runs are not an error: they are returned in [`RunSet::skipped`] for the caller to
/// warn about.
///
/// # Errors
///
/// The errors of [`find_run_dirs`] and [`Run::load`] (the first bad run directory stops the
/// report: a table silently missing a run would be wrong); [`ReportError::Duplicate`] when two
/// directories hold the same experiment (task, algorithm, budget, strategy, mode, number of
/// demonstrations, seed).
pub fn load_runs<P: AsRef<Path>>(paths: &[P]) -> Result<RunSet> {
    let mut set = RunSet::default();
    for dir in find_run_dirs(paths)? {
        match Run::load(&dir) {
            Ok(run) => set.runs.push(run),
            Err(ReportError::Incomplete { dir }) => set
                .skipped
                .push(SkippedRun { dir, reason: "incomplete (summary.json has \"complete\": false)".into() }),
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
