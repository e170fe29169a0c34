//! Writing the run directory of docs/run-directory.md as a run goes. The files' names, headers and
//! row formats are `defender_report::run`'s, beside their readers. Whole files are written atomically (temporary file, then rename); `metrics.csv` and
//! `eval.csv` grow by whole lines, flushed as they are written, and are rewritten atomically from
//! the checkpoint's records on resume, so an interrupted run keeps everything already written.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use defender_report::{
    CONFIG_FILE, DYNAMICS_FILE, DYNAMICS_HEADER, EVAL_EPISODES_FILE, EVAL_EPISODES_HEADER, EVAL_FILE,
    EVAL_HEADER, EpisodeRow, EvalRow, EvalShield, INTERVENTIONS_FILE, INTERVENTIONS_HEADER, METRICS_FILE,
    METRICS_HEADER, SUMMARY_FILE, Summary, UPDATES_FILE, UPDATES_HEADER, eval_episode_rows, intervention_row,
    write_atomic,
};
use defender_rl::{EpisodeRecord, EvalRecord, InterventionRecord};
use serde::Serialize;

/// One `metrics.csv` row.
fn metrics_row(r: &EpisodeRecord) -> String {
    EpisodeRow {
        episode: r.episode,
        total_steps: r.total_steps,
        ret: r.episode_return,
        length: r.length,
        outcome: r.outcome(),
        wall_seconds: r.wall_seconds,
        cost: r.cost(),
    }
    .to_csv()
}

/// An evaluation as `eval.csv` holds it (the shielded columns empty for a run without a filter);
/// the TensorBoard board writes its scalars from the same row, so the two cannot disagree.
pub fn eval_row(r: &EvalRecord) -> EvalRow {
    EvalRow {
        total_steps: r.total_steps,
        mean_return: r.mean_return,
        std_return: r.std_return,
        mean_length: r.mean_length,
        episodes: r.episodes as u64,
        mean_cost: r.mean_cost,
        shield: r.shield.as_ref().map(|s| EvalShield {
            mean_return: s.mean_return,
            mean_cost: s.mean_cost,
            filtered: s.filtered,
        }),
    }
}

/// An open run directory.
pub struct RunDir {
    root: PathBuf,
    metrics: File,
    eval: File,
    updates: File,
    /// `eval_episodes.csv`.
    eval_episodes: File,
    dynamics: Option<File>,
    /// `interventions.csv` (DEFENDER runs).
    interventions: Option<File>,
}

impl RunDir {
    /// Creates `root` (if needed) and starts `metrics.csv` and `eval.csv` with the rows already
    /// known (none for a new run; the checkpoint's for a resumed one); `updates.csv` (and
    /// `dynamics.csv` for a DEFENDER run, `dynamics`) keeps its rows up to the checkpoint's
    /// `total_steps` (those after it are trained again).
    pub fn create(
        root: &Path,
        episodes: &[EpisodeRecord],
        evals: &[EvalRecord],
        total_steps: u64,
        dynamics: bool,
    ) -> Result<Self> {
        std::fs::create_dir_all(root)
            .with_context(|| format!("cannot create run directory {}", root.display()))?;
        let metrics =
            Self::start_csv(&root.join(METRICS_FILE), METRICS_HEADER, episodes.iter().map(metrics_row))?;
        let eval =
            Self::start_csv(&root.join(EVAL_FILE), EVAL_HEADER, evals.iter().map(|r| eval_row(r).to_csv()))?;
        let updates = Self::restart_csv(&root.join(UPDATES_FILE), UPDATES_HEADER, total_steps)?;
        let restart = |name: &str, header: &str| Self::restart_csv(&root.join(name), header, total_steps);
        let (dynamics, interventions) = if dynamics {
            (
                Some(restart(DYNAMICS_FILE, DYNAMICS_HEADER)?),
                Some(restart(INTERVENTIONS_FILE, INTERVENTIONS_HEADER)?),
            )
        } else {
            (None, None)
        };
        let eval_episodes = restart(EVAL_EPISODES_FILE, EVAL_EPISODES_HEADER)?;
        Ok(Self { root: root.to_path_buf(), metrics, eval, updates, eval_episodes, dynamics, interventions })
    }

    /// Opens the files of a run being resumed as they are, so that nothing in them is lost
    /// before [`RunDir::create`] restarts them from the checkpoint's records (rewriting
    /// `updates.csv` here would drop the rows up to the checkpoint, which it cannot recompute).
    pub fn reopen(root: &Path, dynamics: bool) -> Result<Self> {
        let open = |name: &str| {
            let path = root.join(name);
            OpenOptions::new()
                .append(true)
                .create(true)
                .open(&path)
                .with_context(|| format!("cannot open {}", path.display()))
        };
        Ok(Self {
            root: root.to_path_buf(),
            metrics: open(METRICS_FILE)?,
            eval: open(EVAL_FILE)?,
            updates: open(UPDATES_FILE)?,
            eval_episodes: open(EVAL_EPISODES_FILE)?,
            dynamics: if dynamics { Some(open(DYNAMICS_FILE)?) } else { None },
            interventions: if dynamics { Some(open(INTERVENTIONS_FILE)?) } else { None },
        })
    }

    /// Starts a CSV whose first column is `total_steps` with its rows up to `total_steps` (a
    /// run started before the file existed starts it empty).
    fn restart_csv(path: &Path, header: &str, total_steps: u64) -> Result<File> {
        let kept: Vec<String> = std::fs::read_to_string(path)
            .unwrap_or_default()
            .lines()
            .skip(1)
            .filter(|l| {
                l.split(',').next().and_then(|s| s.parse::<u64>().ok()).is_some_and(|s| s <= total_steps)
            })
            .map(str::to_string)
            .collect();
        Self::start_csv(path, header, kept.into_iter())
    }

    fn start_csv(path: &Path, header: &str, rows: impl Iterator<Item = String>) -> Result<File> {
        let mut text = String::from(header);
        text.push('\n');
        for row in rows {
            text.push_str(&row);
            text.push('\n');
        }
        write_atomic(path, text.as_bytes())?;
        OpenOptions::new().append(true).open(path).with_context(|| format!("cannot open {}", path.display()))
    }

    /// The directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Appends a training episode to `metrics.csv`.
    pub fn append_episode(&mut self, record: &EpisodeRecord) -> Result<()> {
        writeln!(self.metrics, "{}", metrics_row(record))
            .and_then(|()| self.metrics.flush())
            .with_context(|| format!("cannot append to {}", self.root.join(METRICS_FILE).display()))
    }

    /// Appends a row to `dynamics.csv` (nothing for a bare run).
    pub fn append_dynamics(&mut self, row: &str) -> Result<()> {
        let Some(file) = &mut self.dynamics else { return Ok(()) };
        writeln!(file, "{row}")
            .and_then(|()| file.flush())
            .with_context(|| format!("cannot append to {}", self.root.join(DYNAMICS_FILE).display()))
    }

    /// Appends an intervention to `interventions.csv` (nothing for a bare run).
    pub fn append_intervention(&mut self, record: &InterventionRecord) -> Result<()> {
        let Some(file) = &mut self.interventions else { return Ok(()) };
        writeln!(file, "{}", intervention_row(record))
            .and_then(|()| file.flush())
            .with_context(|| format!("cannot append to {}", self.root.join(INTERVENTIONS_FILE).display()))
    }

    /// Appends a row to `updates.csv`.
    pub fn append_updates(&mut self, row: &str) -> Result<()> {
        writeln!(self.updates, "{row}")
            .and_then(|()| self.updates.flush())
            .with_context(|| format!("cannot append to {}", self.root.join(UPDATES_FILE).display()))
    }

    /// Appends an evaluation to `eval.csv`.
    pub fn append_eval(&mut self, record: &EvalRecord) -> Result<()> {
        writeln!(self.eval, "{}", eval_row(record).to_csv())
            .and_then(|()| self.eval.flush())
            .with_context(|| format!("cannot append to {}", self.root.join(EVAL_FILE).display()))?;
        let rows = eval_episode_rows(record);
        rows.iter()
            .try_for_each(|row| writeln!(self.eval_episodes, "{row}"))
            .and_then(|()| self.eval_episodes.flush())
            .with_context(|| format!("cannot append to {}", self.root.join(EVAL_EPISODES_FILE).display()))
    }

    /// Writes `config.toml`.
    pub fn write_config<T: Serialize>(&self, config: &T) -> Result<()> {
        let text = toml::to_string_pretty(config).context("cannot serialise the configuration")?;
        Ok(write_atomic(self.root.join(CONFIG_FILE), text.as_bytes())?)
    }

    /// Writes `summary.json`.
    pub fn write_summary(&self, summary: &Summary) -> Result<()> {
        let text = serde_json::to_vec_pretty(summary).context("cannot serialise the summary")?;
        Ok(write_atomic(self.root.join(SUMMARY_FILE), &text)?)
    }
}

/// A run directory taken by this process ([`claim`]): its lock, and on drop, if nothing but the
/// lock file is in it (a run that failed before writing anything), the lock file removed and the
/// directory too if [`claim`] created it, so that a failed `defender train` leaves nothing behind.
pub struct Claim {
    dir: PathBuf,
    created: bool,
    _lock: defender_io::DirLock,
}

impl Drop for Claim {
    fn drop(&mut self) {
        let Ok(entries) = std::fs::read_dir(&self.dir) else { return };
        let names: Vec<_> = entries.filter_map(|e| e.ok()).map(|e| e.file_name()).collect();
        if names.iter().all(|n| n == defender_io::DirLock::FILE_NAME) {
            let _ = std::fs::remove_file(self.dir.join(defender_io::DirLock::FILE_NAME));
            if self.created {
                let _ = std::fs::remove_dir(&self.dir);
            }
        }
    }
}

/// Takes the run directory `out` for this process: creates it if needed, refuses a directory
/// that holds something else than a run (it would be overwritten), and locks it exclusively, so
/// that two processes never write one run. The lock lasts as long as the returned guard.
pub fn claim(out: &Path) -> Result<Claim> {
    let created = !out.exists();
    if out.exists() {
        if !out.is_dir() {
            anyhow::bail!("--out {}: exists and is not a directory", out.display());
        }
        let config = out.join(CONFIG_FILE);
        // A config.toml that is there but unreadable (a link to itself or to nowhere) is a run
        // whose configuration is damaged, not a folder without one.
        if std::fs::symlink_metadata(&config).is_ok()
            && let Err(e) = std::fs::metadata(&config)
        {
            anyhow::bail!("{}: is there but cannot be read ({e}); repair or remove it", config.display());
        }
        let is_run = config.exists();
        let foreign: Vec<String> = std::fs::read_dir(out)
            .with_context(|| format!("cannot read {}", out.display()))?
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|name| name != defender_io::DirLock::FILE_NAME)
            .collect();
        if !is_run && !foreign.is_empty() {
            anyhow::bail!(
                "--out {} is not a run directory (no {CONFIG_FILE}) and is not empty ({}{}); \
                 refusing to write into it: give a new or empty directory",
                out.display(),
                foreign.iter().take(3).cloned().collect::<Vec<_>>().join(", "),
                if foreign.len() > 3 { ", ..." } else { "" }
            );
        }
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create run directory {}", out.display()))?;
    Ok(Claim { dir: out.to_path_buf(), created, _lock: defender_io::DirLock::try_acquire(out)? })
}

/// Checks, before any work, that a file can be written at `path` (its folder exists and is
/// writable), so that a long run does not lose its result at the very end.
pub fn check_writable(path: &Path) -> Result<()> {
    let probe = defender_io::tmp_sibling(path, ".probe");
    std::fs::File::create(&probe)
        .with_context(|| format!("cannot write {} (checked before starting)", path.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}
