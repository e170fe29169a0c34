//! Atomic checkpoint directories: everything is written into `NAME.tmp/`, then the directory
//! replaces the previous checkpoint by renames, so a crash at any moment leaves either the old
//! or the new checkpoint complete.
//!
//! Replacing a non-empty directory is two renames (`NAME -> NAME.old`, `NAME.tmp -> NAME`);
//! if the process dies between them, [`resolve`] finds the complete `NAME.old`.

use std::path::{Path, PathBuf};

use crate::error::RlError;

/// Writes a checkpoint at `dir` with `fill`, which receives the (empty) temporary directory;
/// the directory replaces the previous checkpoint atomically ([`defender_io::replace_dir`]).
///
/// # Errors
/// Whatever `fill` returns, or [`RlError::Io`] from the directory operations.
pub fn write_atomic(dir: &Path, fill: impl FnOnce(&Path) -> Result<(), RlError>) -> Result<(), RlError> {
    defender_io::replace_dir(dir, fill)
}

/// The complete checkpoint to read for `dir`: `dir` itself, or `dir.old` if a replacement was
/// interrupted between its two renames.
///
/// # Errors
/// [`RlError::Checkpoint`] if neither exists.
pub fn resolve(dir: &Path) -> Result<PathBuf, RlError> {
    defender_io::resolve_dir(dir)
        .ok_or_else(|| RlError::checkpoint(dir, "no checkpoint here (nor an interrupted one beside it)"))
}

/// Writes `value` as pretty JSON to `path`.
///
/// # Errors
/// [`RlError::Io`].
pub(crate) fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), RlError> {
    let text = serde_json::to_vec_pretty(value)
        .map_err(|e| RlError::io(path, std::io::Error::new(std::io::ErrorKind::InvalidData, e)))?;
    Ok(defender_io::write_bytes(path, &text)?)
}

/// Reads JSON from `path`.
///
/// # Errors
/// [`RlError::Io`], or [`RlError::Checkpoint`] if the content does not parse.
pub(crate) fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, RlError> {
    let text = std::fs::read(path).map_err(|e| RlError::io(path, e))?;
    serde_json::from_slice(&text).map_err(|e| RlError::checkpoint(path, e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_the_whole_directory_and_recovers_an_interrupted_swap() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("checkpoint");
        write_atomic(&dir, |d| std::fs::write(d.join("a"), "1").map_err(|e| RlError::io(d, e))).unwrap();
        write_atomic(&dir, |d| std::fs::write(d.join("b"), "2").map_err(|e| RlError::io(d, e))).unwrap();
        assert!(!dir.join("a").exists(), "a file of the previous checkpoint survived");
        assert_eq!(std::fs::read_to_string(dir.join("b")).unwrap(), "2");
        assert!(!defender_io::tmp_sibling(&dir, ".tmp").exists() && !defender_io::tmp_sibling(&dir, ".old").exists());
        // A failing fill leaves the previous checkpoint in place.
        let err = write_atomic(&dir, |d| Err(RlError::checkpoint(d, "boom")));
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(resolve(&dir).unwrap().join("b")).unwrap(), "2");
        // Interrupted between the two renames: only NAME.old exists.
        std::fs::rename(&dir, defender_io::tmp_sibling(&dir, ".old")).unwrap();
        assert_eq!(resolve(&dir).unwrap(), defender_io::tmp_sibling(&dir, ".old"));
        assert!(resolve(&root.path().join("nothing")).is_err());
    }
}
