//! The run directory of docs/run-directory.md: what `defender train` writes and `defender report`
//! reads. Whole files are written atomically (temporary file, then rename); `metrics.csv` and
//! `eval.csv` grow by whole lines, flushed as they are written, and are rewritten atomically from
//! the checkpoint's records on resume, so an interrupted run keeps everything already written.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use defender_rl::{EpisodeRecord, EvalRecord};
use serde::Serialize;

/// Header of `metrics.csv`.
pub const METRICS_HEADER: &str = "episode,total_steps,return,length,outcome,wall_seconds";
/// Header of `eval.csv`.
pub const EVAL_HEADER: &str = "total_steps,mean_return,std_return,mean_length,episodes";

/// Writes `bytes` to `path` atomically: a temporary file in the same folder, synced, renamed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    let mut file = File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
    file.write_all(bytes)
        .and_then(|()| file.sync_all())
        .with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path)
        .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
}

/// Formats one `metrics.csv` row.
pub fn metrics_row(r: &EpisodeRecord) -> String {
    format!(
        "{},{},{},{},{},{:.3}",
        r.episode,
        r.total_steps,
        r.episode_return,
        r.length,
        r.outcome().as_str(),
        r.wall_seconds
    )
}

/// Formats one `eval.csv` row.
pub fn eval_row(r: &EvalRecord) -> String {
    format!("{},{},{},{},{}", r.total_steps, r.mean_return, r.std_return, r.mean_length, r.episodes)
}

/// An open run directory.
pub struct RunDir {
    root: PathBuf,
    metrics: File,
    eval: File,
}

impl RunDir {
    /// Creates `root` (if needed) and starts `metrics.csv` and `eval.csv` with the rows already
    /// known (none for a new run; the checkpoint's for a resumed one).
    pub fn create(root: &Path, episodes: &[EpisodeRecord], evals: &[EvalRecord]) -> Result<Self> {
        std::fs::create_dir_all(root)
            .with_context(|| format!("cannot create run directory {}", root.display()))?;
        let metrics =
            Self::start_csv(&root.join("metrics.csv"), METRICS_HEADER, episodes.iter().map(metrics_row))?;
        let eval = Self::start_csv(&root.join("eval.csv"), EVAL_HEADER, evals.iter().map(eval_row))?;
        Ok(Self { root: root.to_path_buf(), metrics, eval })
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
            .with_context(|| format!("cannot append to {}", self.root.join("metrics.csv").display()))
    }

    /// Appends an evaluation to `eval.csv`.
    pub fn append_eval(&mut self, record: &EvalRecord) -> Result<()> {
        writeln!(self.eval, "{}", eval_row(record))
            .and_then(|()| self.eval.flush())
            .with_context(|| format!("cannot append to {}", self.root.join("eval.csv").display()))
    }

    /// Writes `config.toml`.
    pub fn write_config<T: Serialize>(&self, config: &T) -> Result<()> {
        let text = toml::to_string_pretty(config).context("cannot serialise the configuration")?;
        write_atomic(&self.root.join("config.toml"), text.as_bytes())
    }

    /// Writes `summary.json`.
    pub fn write_summary(&self, summary: &Summary) -> Result<()> {
        let text = serde_json::to_vec_pretty(summary).context("cannot serialise the summary")?;
        write_atomic(&self.root.join("summary.json"), &text)
    }
}

/// `summary.json` (docs/run-directory.md).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Summary {
    /// Gymnasium id.
    pub env: String,
    /// `sac` or `td3`.
    pub algo: String,
    /// The run's seed.
    pub seed: u64,
    /// `SAFE/UNSAFE`, or null for a bare run.
    pub strategy: Option<String>,
    /// `state` or `state-action`, or null for a bare run.
    pub mode: Option<String>,
    /// Mean return of the final evaluation (null until it ran).
    pub acc_reward: Option<f64>,
    /// Crashed training episodes / all training episodes x 100.
    pub crash_pct: f64,
    /// Filtered training episodes / all training episodes x 100.
    pub filtered_pct: f64,
    /// Training episodes finished.
    pub episodes: u64,
    /// Environment steps taken.
    pub steps: u64,
    /// Steps DEFENDER filtered.
    pub filtered_steps: u64,
    /// Wall-clock seconds of training (summed over resumed sessions).
    pub wall_seconds: f64,
    /// `steps / wall_seconds`.
    pub steps_per_second: f64,
    /// Whether the run finished its budget and final evaluation.
    pub complete: bool,
}

impl Summary {
    /// Fills the counts from the episode records.
    pub fn count(&mut self, episodes: &[EpisodeRecord]) {
        let n = episodes.len().max(1) as f64;
        let crashed = episodes.iter().filter(|r| r.outcome() == defender_rl::Outcome::Crashed).count();
        let filtered = episodes.iter().filter(|r| r.outcome() == defender_rl::Outcome::Filtered).count();
        self.episodes = episodes.len() as u64;
        self.crash_pct = 100.0 * crashed as f64 / n;
        self.filtered_pct = 100.0 * filtered as f64 / n;
        self.steps_per_second =
            if self.wall_seconds > 0.0 { self.steps as f64 / self.wall_seconds } else { 0.0 };
    }
}
