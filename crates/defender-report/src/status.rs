//! Why a run directory is left out of a report: still running (a process holds its lock), stopped
//! (a checkpoint to resume from), or broken (neither). The report lists each one it leaves out,
//! so that a table short of a seed says so.

use std::fs::{File, TryLockError};
use std::path::{Path, PathBuf};

use defender_io::DirLock;

use crate::run::{CONFIG_FILE, SUMMARY_FILE};

/// The checkpoint directory of a run (docs/run-directory.md).
pub(crate) const CHECKPOINT_DIR: &str = "checkpoint";

/// What state a skipped run directory is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SkipKind {
    /// A process holds the directory's lock (`defender train` writing it).
    Running,
    /// Not complete, nobody writing it, and a checkpoint to resume from.
    Stopped,
    /// Not complete, nobody writing it, and no checkpoint.
    Broken,
}

impl SkipKind {
    /// `running`, `stopped` or `broken`.
    pub fn as_str(self) -> &'static str {
        match self {
            SkipKind::Running => "running",
            SkipKind::Stopped => "stopped",
            SkipKind::Broken => "broken",
        }
    }
}

/// A run directory that was found but left out of the report.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedRun {
    /// The run directory.
    pub dir: PathBuf,
    /// Its state.
    pub kind: SkipKind,
    /// Why, in a sentence for a warning: the state and what makes it so.
    pub reason: String,
}

/// Whether a process holds `dir`'s lock (`Some(holder's pid, if written)`) or not (`None`).
///
/// A probe that changes nothing on disk: it opens an existing `.lock` read-only (none: nobody
/// ever locked the directory, or it is not locked now) and tries to take a shared lock, released
/// at once. `DirLock` takes an exclusive lock, so a held lock refuses the probe. A `defender
/// train` that tries to lock the directory during the microseconds of the probe is refused as
/// if another run held it; a report is not run in a loop against a starting run, so this is
/// accepted. A lock that cannot be probed (permissions) counts as not held.
pub fn lock_holder(dir: &Path) -> Option<Option<String>> {
    let path = dir.join(DirLock::FILE_NAME);
    let file = File::open(&path).ok()?;
    match file.try_lock_shared() {
        Ok(()) => None, // released when `file` is dropped
        Err(TryLockError::WouldBlock) => {
            let pid =
                std::fs::read_to_string(&path).ok().map(|s| s.trim().to_owned()).filter(|s| !s.is_empty());
            Some(pid)
        }
        Err(TryLockError::Error(_)) => None,
    }
}

/// Whether `dir` holds a checkpoint (also the one an interrupted replacement leaves as
/// `checkpoint.old`, which `defender train --resume` resumes from).
pub(crate) fn has_checkpoint(dir: &Path) -> bool {
    defender_io::resolve_dir(&dir.join(CHECKPOINT_DIR)).is_some()
}

/// The skip record of a run directory held by a running process.
pub(crate) fn running(dir: &Path, holder: Option<String>) -> SkippedRun {
    let pid = holder.map_or_else(String::new, |pid| format!(" by pid {pid}"));
    SkippedRun {
        dir: dir.to_path_buf(),
        kind: SkipKind::Running,
        reason: format!("still running (its lock {} is held{pid})", DirLock::FILE_NAME),
    }
}

/// Why `path` cannot be read as a file when something is there under its name (a symbolic
/// link to nowhere or to itself, a directory); `None` when it is absent or a readable file.
pub(crate) fn unreadable(path: &Path) -> Option<String> {
    std::fs::symlink_metadata(path).ok()?;
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => None,
        Ok(_) => Some("not a regular file".into()),
        Err(e) => Some(e.to_string()),
    }
}

/// The skip record of a run directory that nobody is writing and that is not complete:
/// `summary.json` is missing, or says `"complete": false`.
pub(crate) fn not_complete(dir: &Path) -> SkippedRun {
    let summary = if dir.join(SUMMARY_FILE).is_file() {
        format!("{SUMMARY_FILE} says \"complete\": false")
    } else {
        format!("no {SUMMARY_FILE}")
    };
    let resume = format!("`defender train --out {} --resume`", dir.display());
    let (kind, reason) = if has_checkpoint(dir) {
        (SkipKind::Stopped, format!("stopped ({summary}; a checkpoint is present: {resume} continues it)"))
    } else if dir.join(CONFIG_FILE).is_file() {
        (
            SkipKind::Broken,
            format!(
                "broken ({summary}, no process holds its lock and there is no checkpoint: it ended \
                 before its first one; {resume} starts it again from its {CONFIG_FILE})"
            ),
        )
    } else if let Some(e) = unreadable(&dir.join(CONFIG_FILE)) {
        (SkipKind::Broken, format!("broken ({summary}; its {CONFIG_FILE} is there but cannot be read: {e})"))
    } else {
        (
            SkipKind::Broken,
            format!(
                "broken ({summary}, no {CONFIG_FILE}, no process holds its lock and there is no \
                 checkpoint: nothing to resume)"
            ),
        )
    };
    SkippedRun { dir: dir.to_path_buf(), kind, reason }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_lock_is_seen_and_the_probe_leaves_it_alone() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(lock_holder(dir.path()), None, "no lock file");
        assert!(!dir.path().join(DirLock::FILE_NAME).exists(), "the probe creates nothing");
        let lock = DirLock::try_acquire(dir.path()).unwrap();
        let pid = std::process::id().to_string();
        assert_eq!(lock_holder(dir.path()), Some(Some(pid)));
        // Still held by its owner after the probe: a second lock is refused.
        assert!(DirLock::try_acquire(dir.path()).is_err());
        drop(lock);
        assert_eq!(lock_holder(dir.path()), None, "released: the file stays, the lock does not");
        DirLock::try_acquire(dir.path()).unwrap();
    }
}
