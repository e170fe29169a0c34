//! Atomic file writes: write `NAME.tmp` beside the target, flush it to disk, then rename, so that
//! an interrupted program never leaves a half-written file behind (docs/run-directory.md).

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::error::{DefenderError, Result};

/// The temporary path used while writing `path`: `NAME.tmp` in the same directory.
pub(crate) fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `path` atomically: `write` fills a buffered writer on `NAME.tmp`, which is then synced
/// and renamed over `path`. On error the temporary file is removed and `path` is untouched.
///
/// # Errors
/// Whatever `write` returns, or an I/O error creating, syncing or renaming the file.
pub fn write_atomic<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let tmp = tmp_path(path);
    let result = (|| {
        let file = File::create(&tmp).map_err(|e| DefenderError::io(&tmp, e))?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        let file = w.into_inner().map_err(|e| DefenderError::io(&tmp, e.into_error()))?;
        file.sync_all().map_err(|e| DefenderError::io(&tmp, e))?;
        std::fs::rename(&tmp, path).map_err(|e| DefenderError::io(path, e))
    })();
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
