//! What a `defender train` reads and what it writes, checked before anything is created
//! (docs/run-directory.md, "What a run reads and writes"). Its inputs are the `--config` file and
//! the demonstration file (given, or shipped for the task); its outputs are the files of the run
//! directory (`--out`) and the recorded episodes (`--record-episodes`). No output may be one of
//! the inputs (the same file, however it is named: symbolic links and hard links included), no
//! two outputs may be one file, and an existing file at `--record-episodes` is replaced only when
//! it is itself a recording of `defender train`.

use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use defender::EpisodeSet;
use defender_config::run_config::RunConfig;
use defender_report::{CONFIG_FILE, DYNAMICS_FILE, EVAL_FILE, METRICS_FILE, SUMMARY_FILE, UPDATES_FILE};

use crate::commands::train_args::TrainArgs;

/// How the provenance of a set recorded by `defender train --record-episodes` begins: such a set
/// is the one kind of file that `--record-episodes` replaces.
pub const RECORDING_PROVENANCE: &str = "training episodes of `defender train`";

/// The files and folders of a run directory that `defender train` writes.
const RUN_FILES: [&str; 8] = [
    CONFIG_FILE,
    METRICS_FILE,
    EVAL_FILE,
    SUMMARY_FILE,
    UPDATES_FILE,
    DYNAMICS_FILE,
    "actor.safetensors",
    "checkpoint",
];

/// A path as the file system resolves it: canonical if it exists, else its canonical folder
/// joined with its name, else as given made absolute.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    if let (Some(parent), Some(name)) = (path.parent(), path.file_name()) {
        let parent = if parent.as_os_str().is_empty() { Path::new(".") } else { parent };
        if let Ok(p) = std::fs::canonicalize(parent) {
            return p.join(name);
        }
    }
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// Whether `a` and `b` name one file: the same inode when both exist (hard links), else the same
/// resolved path (symbolic links).
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => resolved(a) == resolved(b),
    }
}

/// The run's inputs, each with the flag (or key) that names it.
fn inputs(config: &RunConfig, args: &TrainArgs) -> Result<Vec<(&'static str, PathBuf)>> {
    let mut inputs = Vec::new();
    if let Some(path) = &args.config {
        inputs.push(("--config", path.clone()));
    }
    let demos = match &config.defender {
        Some(section) => Some(crate::setup::demos_path(&config.env, section.demos.as_deref())?),
        // Without a filter: the set a run stores before training (its replay buffer's, or Recovery
        // RL's, which pretrains its safety critic on it).
        None => crate::recovery_agent::bare_demos(config, config.algo_config().demos_in_replay())?,
    };
    if let Some(path) = demos {
        defender_io::check_regular(&path).with_context(|| format!("--demos {}", path.display()))?;
        inputs.push(("--demos", path));
    }
    Ok(inputs)
}

/// Checks a run's configuration against the machine before anything is created: the task
/// exists, the inputs are regular files, and no output lands on an input or on another output.
/// Returns the configuration unchanged.
///
/// # Errors
/// The first rule broken, naming the flag and the path.
pub fn check(config: RunConfig, args: &TrainArgs) -> Result<RunConfig> {
    let tasks = crate::setup::task_ids();
    if !tasks.contains(&config.env.as_str()) {
        bail!("--env {}: unknown task; known ids: {} (`defender env list`)", config.env, tasks.join(", "));
    }
    let inputs = inputs(&config, args)?;
    let mut outputs: Vec<(String, PathBuf)> =
        RUN_FILES.iter().map(|name| (format!("the run's {name} (--out)"), args.out.join(name))).collect();
    if let Some(path) = &config.record_episodes {
        for (what, output) in &outputs {
            if same_file(path, output) {
                bail!(
                    "--record-episodes {} is {what}; record the episodes into another file",
                    path.display()
                );
            }
        }
        outputs.push(("--record-episodes".into(), path.clone()));
    }
    for (flag, input) in &inputs {
        // A resumed run reads and rewrites its own config.toml: that is what it continues.
        let own_config = args.resume && *flag == "--config" && same_file(input, &args.out.join(CONFIG_FILE));
        for (what, output) in outputs.iter().filter(|_| !own_config) {
            if same_file(input, output) {
                bail!(
                    "{what} {} is {flag} {}, which this run reads: a run never writes over its \
                     inputs; choose another path",
                    output.display(),
                    input.display()
                );
            }
        }
    }
    if let Some(path) = &config.record_episodes {
        check_replaceable(path)?;
    }
    Ok(config)
}

/// An existing file at `--record-episodes` is replaced only if it is a recording of `defender
/// train` (a run's earlier recording); anything else (demonstrations, a user's file) is kept.
fn check_replaceable(path: &Path) -> Result<()> {
    let Ok(meta) = std::fs::metadata(path) else { return Ok(()) };
    let refuse = |what: &str| -> Result<()> {
        bail!(
            "--record-episodes {}: the file exists and {what}; a run replaces only its own kind of \
             file (an earlier `--record-episodes` recording): remove it first, or record into \
             another file",
            path.display()
        )
    };
    if !meta.is_file() {
        return refuse("is not a regular file");
    }
    match EpisodeSet::load(path) {
        Ok(set) => match set.meta().provenance.as_deref() {
            Some(p) if p.starts_with(RECORDING_PROVENANCE) => Ok(()),
            Some(p) => refuse(&format!("is an episode set of another kind ({})", shorten(p))),
            None => refuse("is an episode set that does not say where it comes from"),
        },
        Err(_) => refuse("is not an episode set"),
    }
}

/// The first words of a provenance, for a message.
fn shorten(text: &str) -> String {
    match text.char_indices().nth(60) {
        Some((i, _)) => format!("{}...", &text[..i]),
        None => text.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_name_the_same_file() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.npz");
        std::fs::write(&a, b"x").unwrap();
        let hard = dir.path().join("hard.npz");
        std::fs::hard_link(&a, &hard).unwrap();
        let soft = dir.path().join("soft.npz");
        std::os::unix::fs::symlink(&a, &soft).unwrap();
        assert!(same_file(&a, &hard) && same_file(&a, &soft));
        assert!(same_file(&dir.path().join("new.npz"), &dir.path().join("./new.npz")));
        assert!(!same_file(&a, &dir.path().join("new.npz")));
    }
}
