//! A run asked to `--resume` without a readable checkpoint. One killed before its first
//! checkpoint starts again from its `config.toml` (nothing of it could be kept); one that had a
//! checkpoint and lost it (deleted, replaced by a dangling link or a file) cannot continue, and
//! starting it again would rewrite its `metrics.csv` and the rest: that is an error, naming what
//! is wrong, and nothing is touched.

use std::path::Path;

use anyhow::{Result, bail};
use defender_config::run_config::RunConfig;
use defender_report::{METRICS_FILE, SUMMARY_FILE};

/// What is at `path` when it is there but not a directory.
fn not_a_directory(path: &Path) -> Option<String> {
    let meta = std::fs::symlink_metadata(path).ok()?;
    if meta.file_type().is_symlink() {
        let target = std::fs::read_link(path).map_or_else(|_| "?".into(), |t| t.display().to_string());
        return match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => None,
            Ok(_) => Some(format!("a symbolic link to {target}, which is not a directory")),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                Some(format!("a symbolic link to {target}, which does not exist"))
            }
            Err(e) => Some(format!("a symbolic link to {target}, which cannot be read ({e})")),
        };
    }
    (!meta.is_dir()).then(|| "not a directory".to_string())
}

/// The `wall_seconds` of each episode row of `metrics.csv` (its last column).
fn episode_times(out: &Path) -> Vec<f64> {
    std::fs::read_to_string(out.join(METRICS_FILE))
        .unwrap_or_default()
        .lines()
        .skip(1)
        .filter_map(|l| l.rsplit(',').next()?.trim().parse().ok())
        .collect()
}

/// The episodes `summary.json` counts (it counts them only when written at a stop or at the
/// end, each right after a checkpoint).
fn summary_episodes(out: &Path) -> u64 {
    std::fs::read_to_string(out.join(SUMMARY_FILE))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v.get("episodes")?.as_u64())
        .unwrap_or(0)
}

/// Decides for a run in `out` asked to `--resume` that has no readable checkpoint: `Ok` (with a
/// note) when it never had one, an error when it had one (its schedule, its summary or a
/// `checkpoint` that is there but unreadable say so).
///
/// # Errors
/// The run had a checkpoint that is gone or unreadable.
pub fn restart_or_refuse(out: &Path, config: &RunConfig) -> Result<()> {
    let checkpoint = out.join("checkpoint");
    let times = episode_times(out);
    let why = if let Some(what) = not_a_directory(&checkpoint) {
        Some(format!("{} is {what}", checkpoint.display()))
    } else if summary_episodes(out) > 0 {
        Some(format!("its {SUMMARY_FILE} was written at a stop or at its end, each after a checkpoint"))
    } else {
        // Episodes past the time or the count at which the trainer writes a checkpoint (the
        // last one is left out: the run may have died writing it).
        let seconds = config.checkpoint_every_seconds;
        let every = config.checkpoint_every_episodes;
        let before_last = &times[..times.len().saturating_sub(1)];
        let by_time = seconds > 0 && before_last.iter().any(|&t| t >= seconds as f64);
        let by_count = every > 0 && before_last.len() as u64 >= every;
        (by_time || by_count).then(|| {
            format!(
                "its {} episodes go past its first checkpoint (every {seconds} s / {every} episodes)",
                times.len()
            )
        })
    };
    if let Some(why) = why {
        bail!(
            "{}: --resume: {METRICS_FILE} holds {} training episodes but there is no readable \
             checkpoint ({why}), so the run cannot continue; nothing was changed. Restore {}, or \
             start the run again in a new --out",
            out.display(),
            times.len(),
            checkpoint.display()
        );
    }
    note!(
        "{}: no checkpoint yet (stopped before its first one); starting the run again from its config.toml",
        out.display()
    );
    Ok(())
}
