//! Atomic file writes: write `NAME.tmp` beside the target, flush it to disk, then rename, so that
//! an interrupted program never leaves a half-written file behind (docs/run-directory.md).

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::error::{DefenderError, Result};

/// The temporary path used while writing `path`: `NAME.tmp` in the same directory.
pub(crate) fn tmp_path(path: &Path) -> PathBuf {
    defender_io::tmp_sibling(path, ".tmp")
}

/// Writes `path` atomically ([`defender_io::write_file`]: `NAME.tmp`, fsync, rename, fsync of
/// the directory): `write` fills a buffered writer on the temporary file. On error the temporary
/// file is removed and `path` is untouched.
///
/// # Errors
/// Whatever `write` returns, or an I/O error creating, syncing or renaming the file.
pub fn write_atomic<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let mut inner: Option<DefenderError> = None;
    let written = defender_io::write_file(path, |w| {
        write(w).map_err(|e| {
            inner = Some(e);
            std::io::Error::other("write failed")
        })
    });
    match (written, inner) {
        (Err(_), Some(e)) => Err(e),
        (Err((at, e)), None) => Err(DefenderError::io(at, e)),
        (Ok(()), _) => Ok(()),
    }
}

/// Writes `path` atomically with a writer that wants a path of its own (e.g. safetensors): `write`
/// fills `NAME.tmp`, which is then synced, renamed over `path`, and the directory synced. On
/// error the temporary file is removed and `path` is untouched.
///
/// # Errors
/// Whatever `write` returns, or an I/O error syncing or renaming the file.
pub(crate) fn commit_file(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = tmp_path(path);
    let result = write(&tmp).and_then(|()| {
        let sync = |p: &Path| File::open(p).and_then(|f| f.sync_all()).map_err(|e| DefenderError::io(p, e));
        sync(&tmp)?;
        std::fs::rename(&tmp, path).map_err(|e| DefenderError::io(path, e))?;
        let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        defender_io::sync_dir(parent).map_err(|e| DefenderError::io(parent, e))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes a `Write` error as a [`DefenderError::Io`] on `path`.
pub(crate) fn io_at(path: &Path) -> impl Fn(std::io::Error) -> DefenderError + '_ {
    move |e| DefenderError::io(path, e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn writes_atomically_and_cleans_up_on_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.csv");
        write_atomic(&path, |w| w.write_all(b"x,y\n").map_err(io_at(&path))).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "x,y\n");
        let err = write_atomic(&path, |w| {
            w.write_all(b"partial").map_err(io_at(&path))?;
            Err(DefenderError::Config("boom".into()))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "x,y\n", "the old file is untouched");
        assert!(!tmp_path(&path).exists(), "the temporary file is removed");
    }
}
