//! Atomic writes of files and directories (write aside, fsync, rename, fsync the parent).

use std::fs::File;
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

/// The sibling of `path` with `suffix` appended to its file name (`NAME.tmp`, `NAME.old`).
#[must_use]
pub fn tmp_sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_else(|| "output".into());
    name.push(suffix);
    path.with_file_name(name)
}

fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Syncs a directory, so that the renames inside it survive a power loss.
///
/// # Errors
/// The I/O error of opening or syncing it.
pub fn sync_dir(dir: &Path) -> io::Result<()> {
    File::open(dir)?.sync_all()
}

fn with_path(path: &Path, e: io::Error) -> (PathBuf, io::Error) {
    (path.to_path_buf(), e)
}

/// Writes `path` atomically: `write` fills a buffered writer on `NAME.tmp` in the same directory,
/// which is then synced, renamed over `path`, and the directory synced. On any error the
/// temporary file is removed and `path` is untouched.
///
/// # Errors
/// The path where it failed and the I/O error (what `write` returned included).
pub fn write_file<F>(path: &Path, write: F) -> Result<(), (PathBuf, io::Error)>
where
    F: FnOnce(&mut BufWriter<File>) -> io::Result<()>,
{
    let tmp = tmp_sibling(path, ".tmp");
    let result = (|| {
        let file = File::create(&tmp).map_err(|e| with_path(&tmp, e))?;
        let mut w = BufWriter::new(file);
        write(&mut w).map_err(|e| with_path(&tmp, e))?;
        let file = w.into_inner().map_err(|e| with_path(&tmp, e.into_error()))?;
        file.sync_all().map_err(|e| with_path(&tmp, e))?;
        std::fs::rename(&tmp, path).map_err(|e| with_path(path, e))?;
        sync_dir(parent_of(path)).map_err(|e| with_path(parent_of(path), e))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// [`write_file`] for bytes already in memory.
///
/// # Errors
/// As [`write_file`].
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), (PathBuf, io::Error)> {
    write_file(path, |w| io::Write::write_all(w, bytes))
}

fn remove_dir_if_exists(path: &Path) -> Result<(), (PathBuf, io::Error)> {
    match std::fs::remove_dir_all(path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(with_path(path, e)),
        _ => Ok(()),
    }
}

fn sync_tree_files(dir: &Path) -> io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        if entry.file_type()?.is_dir() {
            sync_tree_files(&entry.path())?;
        } else {
            File::open(entry.path())?.sync_all()?;
        }
    }
    sync_dir(dir)
}

/// Writes the directory `dir` atomically: `fill` writes into an empty `NAME.tmp/`, every file in
/// it is synced, then it replaces `dir` by two renames (`NAME -> NAME.old`, `NAME.tmp -> NAME`).
/// A crash at any moment leaves a complete directory that [`resolve_dir`] finds.
///
/// # Errors
/// Whatever `fill` returns, or the failing path and I/O error; on error `NAME.tmp` is removed.
pub fn replace_dir<E, F>(dir: &Path, fill: F) -> Result<(), E>
where
    F: FnOnce(&Path) -> Result<(), E>,
    E: From<(PathBuf, io::Error)>,
{
    let tmp = tmp_sibling(dir, ".tmp");
    let old = tmp_sibling(dir, ".old");
    remove_dir_if_exists(&tmp)?;
    std::fs::create_dir_all(&tmp).map_err(|e| with_path(&tmp, e))?;
    let filled = fill(&tmp).and_then(|()| sync_tree_files(&tmp).map_err(|e| E::from(with_path(&tmp, e))));
    if let Err(e) = filled {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    if dir.exists() {
        // Only now is the previous `NAME.old` (if any) superseded by a complete `NAME`.
        remove_dir_if_exists(&old)?;
        std::fs::rename(dir, &old).map_err(|e| with_path(dir, e))?;
    }
    std::fs::rename(&tmp, dir).map_err(|e| with_path(&tmp, e))?;
    sync_dir(parent_of(dir)).map_err(|e| with_path(parent_of(dir), e))?;
    remove_dir_if_exists(&old)?;
    Ok(())
}

/// The complete directory to read for `dir`: `dir` itself, or `NAME.old` if a [`replace_dir`]
/// was interrupted between its two renames; `None` if neither exists.
#[must_use]
pub fn resolve_dir(dir: &Path) -> Option<PathBuf> {
    if dir.is_dir() {
        return Some(dir.to_path_buf());
    }
    let old = tmp_sibling(dir, ".old");
    old.is_dir().then_some(old)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.csv");
        write_file(&path, |w| w.write_all(b"x,y\n")).unwrap();
        let err = write_file(&path, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("boom"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "x,y\n");
        assert!(!tmp_sibling(&path, ".tmp").exists(), "the temporary file is removed");
        let missing = dir.path().join("no/such/dir/x");
        let (at, _) = write_bytes(&missing, b"1").unwrap_err();
        assert!(at.ends_with("no/such/dir/x.tmp"), "{}", at.display());
    }

    #[derive(Debug)]
    struct E(#[allow(dead_code)] String);
    impl From<(PathBuf, io::Error)> for E {
        fn from((p, e): (PathBuf, io::Error)) -> Self {
            E(format!("{}: {e}", p.display()))
        }
    }

    #[test]
    fn replaces_a_whole_directory_and_recovers_an_interrupted_swap() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("checkpoint");
        let put = |name: &'static str| {
            move |d: &Path| std::fs::write(d.join(name), name).map_err(|e| E::from((d.into(), e)))
        };
        replace_dir(&dir, put("a")).unwrap();
        replace_dir(&dir, put("b")).unwrap();
        assert!(!dir.join("a").exists(), "a file of the previous directory survived");
        assert!(dir.join("b").exists());
        assert!(!tmp_sibling(&dir, ".tmp").exists() && !tmp_sibling(&dir, ".old").exists());
        let failed: Result<(), E> = replace_dir(&dir, |_| Err(E("boom".into())));
        assert!(failed.is_err());
        assert!(!tmp_sibling(&dir, ".tmp").exists(), "a failed fill leaves no temporary directory");
        assert!(resolve_dir(&dir).unwrap().join("b").exists());
        std::fs::rename(&dir, tmp_sibling(&dir, ".old")).unwrap();
        assert_eq!(resolve_dir(&dir).unwrap(), tmp_sibling(&dir, ".old"));
        assert!(resolve_dir(&root.path().join("nothing")).is_none());
    }
}
