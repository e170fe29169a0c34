//! An exclusive lock on a directory (a run or a sweep), so that two processes never write the
//! same run. It is an OS file lock on `DIR/.lock`: the kernel drops it when the process exits,
//! however it exits, so a killed run never leaves a lock that blocks its own resume.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Why a directory could not be locked.
#[derive(Debug)]
pub enum LockError {
    /// Another process holds the lock; its pid as it wrote it, if readable.
    Busy {
        /// The directory.
        dir: PathBuf,
        /// What the holder wrote into the lock file (its pid), if anything.
        holder: Option<String>,
    },
    /// The lock file could not be created or locked.
    Io(PathBuf, std::io::Error),
}

impl std::fmt::Display for LockError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LockError::Busy { dir, holder } => {
                write!(f, "{} is in use by another process", dir.display())?;
                if let Some(pid) = holder {
                    write!(f, " (pid {pid})")?;
                }
                write!(f, "; wait for it to finish or stop it first")
            }
            LockError::Io(path, e) => write!(f, "cannot lock {}: {e}", path.display()),
        }
    }
}

impl std::error::Error for LockError {}

/// An exclusive lock on a directory, held until dropped (or the process ends).
#[derive(Debug)]
pub struct DirLock {
    _file: File,
    path: PathBuf,
}

impl DirLock {
    /// The lock file's name inside the locked directory.
    pub const FILE_NAME: &'static str = ".lock";

    /// Locks `dir` (which must exist) without waiting.
    ///
    /// # Errors
    /// [`LockError::Busy`] if another process holds it, [`LockError::Io`] otherwise.
    pub fn try_acquire(dir: &Path) -> Result<DirLock, LockError> {
        let path = dir.join(Self::FILE_NAME);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| LockError::Io(path.clone(), e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let holder = std::fs::read_to_string(&path)
                    .ok()
                    .map(|s| s.trim().to_owned())
                    .filter(|s| !s.is_empty());
                return Err(LockError::Busy { dir: dir.to_path_buf(), holder });
            }
            Err(TryLockError::Error(e)) => return Err(LockError::Io(path, e)),
        }
        // Best effort: the pid only improves the message another process prints.
        let _ = file.set_len(0).and_then(|()| write!(file, "{}", std::process::id()));
        Ok(DirLock { _file: file, path })
    }

    /// Whether another process holds the lock of `dir` right now (a run going on). Creates
    /// nothing: a directory without a lock file is not held.
    #[must_use]
    pub fn is_held(dir: &Path) -> bool {
        match File::open(dir.join(Self::FILE_NAME)) {
            // A shared lock is refused while an exclusive one is held; released on drop.
            Ok(file) => matches!(file.try_lock_shared(), Err(TryLockError::WouldBlock)),
            Err(_) => false,
        }
    }

    /// The lock file.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_is_refused_until_the_first_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let first = DirLock::try_acquire(dir.path()).unwrap();
        let err = DirLock::try_acquire(dir.path()).unwrap_err();
        assert!(matches!(err, LockError::Busy { .. }), "{err}");
        assert!(err.to_string().contains("in use by another process"), "{err}");
        assert!(DirLock::is_held(dir.path()));
        drop(first);
        assert!(!DirLock::is_held(dir.path()));
        DirLock::try_acquire(dir.path()).unwrap();
    }
}
