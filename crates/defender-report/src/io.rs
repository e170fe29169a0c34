//! Atomic output: write `NAME.tmp`, sync it, then rename it to `NAME`, so that a reader (or an
//! interrupted run or report) never sees a half-written file.

use std::path::Path;

use crate::error::{Result, io_err};

/// Writes `bytes` to `path` atomically (through `path` + `.tmp` in the same directory, synced to
/// disk before the rename, so that a crash leaves either the old file or the new one).
///
/// # Errors
///
/// [`crate::ReportError::Io`] naming the file when writing or renaming fails.
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<()> {
    defender_io::write_bytes(path.as_ref(), bytes).map_err(|(at, e)| io_err(at)(e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_and_replaces_without_leaving_the_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.md");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "two");
        assert!(!dir.path().join("out.md.tmp").exists());
        let err = write_atomic(dir.path().join("no/such/dir/x"), b"x").unwrap_err();
        assert!(err.to_string().contains("no/such/dir/x.tmp"), "{err}");
    }
}
