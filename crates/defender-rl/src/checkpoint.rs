//! Atomic checkpoint directories: everything is written into `NAME.tmp/`, then the directory
//! replaces the previous checkpoint by renames, so a crash at any moment leaves either the old
//! or the new checkpoint complete.
//!
//! Replacing a non-empty directory is two renames (`NAME -> NAME.old`, `NAME.tmp -> NAME`);
//! if the process dies between them, [`resolve`] finds the complete `NAME.old`.
//!
//! Integrity: the last file written into a checkpoint is [`MANIFEST_FILE`], the size and CRC-32
//! (zip's checksum, as SB3's zip checkpoints) of every other file in it. [`resolve`] verifies
//! every listed file before anything is parsed, so a flipped bit or a truncated file is an error
//! naming the file, never a silently different run. A checkpoint without a manifest (written
//! before manifests existed) is accepted with a warning on stderr, so that a run begun with an
//! older version is not lost; its next checkpoint has a manifest.

use std::collections::BTreeMap;
use std::io::{Read, Write as _};
use std::path::{Component, Path, PathBuf};

use crate::error::RlError;

/// Writes a checkpoint at `dir` with `fill`, which receives the (empty) temporary directory;
/// the directory replaces the previous checkpoint atomically ([`defender_io::replace_dir`]).
///
/// # Errors
/// Whatever `fill` returns, or [`RlError::Io`] from the directory operations.
pub fn write_atomic(dir: &Path, fill: impl FnOnce(&Path) -> Result<(), RlError>) -> Result<(), RlError> {
    defender_io::replace_dir(dir, |tmp: &Path| {
        fill(tmp)?;
        write_manifest(tmp)
    })
}

/// The complete checkpoint to read for `dir`: `dir` itself, or `dir.old` if a replacement was
/// interrupted between its two renames; every file its manifest lists is verified first
/// ([`verify`]).
///
/// # Errors
/// [`RlError::Checkpoint`] if neither exists, or naming the file that fails verification.
pub fn resolve(dir: &Path) -> Result<PathBuf, RlError> {
    let found = defender_io::resolve_dir(dir)
        .ok_or_else(|| RlError::checkpoint(dir, "no checkpoint here (nor an interrupted one beside it)"))?;
    verify(&found)?;
    Ok(found)
}

/// The manifest's name inside a checkpoint directory.
pub const MANIFEST_FILE: &str = "manifest.json";

/// A manifest larger than this is not one we wrote (it lists a few dozen files).
const MAX_MANIFEST_BYTES: u64 = 1 << 20;

/// One file of a checkpoint as the manifest records it.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSum {
    bytes: u64,
    /// CRC-32 (IEEE, as zip), 8 lowercase hex digits.
    crc32: String,
}

/// `manifest.json`: format version and every other file of the checkpoint, by relative path
/// (`/`-separated).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    format: u32,
    files: BTreeMap<String, FileSum>,
}

const MANIFEST_FORMAT: u32 = 1;

/// Size and CRC-32 of a file, read in chunks (no allocation of the file's size).
fn file_sum(path: &Path) -> Result<FileSum, RlError> {
    let mut file = std::fs::File::open(path).map_err(|e| RlError::io(path, e))?;
    let mut hasher = crc32fast::Hasher::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut bytes = 0u64;
    loop {
        let n = file.read(&mut buf).map_err(|e| RlError::io(path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        bytes += n as u64;
    }
    Ok(FileSum { bytes, crc32: format!("{:08x}", hasher.finalize()) })
}

fn list_files(root: &Path, dir: &Path, out: &mut Vec<(String, PathBuf)>) -> Result<(), RlError> {
    let entries = std::fs::read_dir(dir).map_err(|e| RlError::io(dir, e))?;
    for entry in entries {
        let entry = entry.map_err(|e| RlError::io(dir, e))?;
        let path = entry.path();
        let kind = entry.file_type().map_err(|e| RlError::io(&path, e))?;
        if kind.is_dir() {
            list_files(root, &path, out)?;
        } else {
            let rel = path.strip_prefix(root).unwrap_or(&path);
            let name: Vec<String> =
                rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
            out.push((name.join("/"), path));
        }
    }
    Ok(())
}

/// Writes `dir/manifest.json`: the size and CRC-32 of every other file under `dir`.
fn write_manifest(dir: &Path) -> Result<(), RlError> {
    let mut files = Vec::new();
    list_files(dir, dir, &mut files)?;
    let mut manifest = Manifest { format: MANIFEST_FORMAT, files: BTreeMap::new() };
    for (name, path) in files {
        if name != MANIFEST_FILE {
            manifest.files.insert(name, file_sum(&path)?);
        }
    }
    write_json(&dir.join(MANIFEST_FILE), &manifest)
}

/// Verifies the checkpoint directory `dir` against its manifest: every listed file exists, has
/// its recorded size and CRC-32. Files the manifest does not list are ignored.
///
/// # Errors
/// [`RlError::Checkpoint`] naming the manifest (missing, unreadable) or the file that fails.
pub fn verify(dir: &Path) -> Result<(), RlError> {
    let path = dir.join(MANIFEST_FILE);
    let meta = match std::fs::metadata(&path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // A checkpoint of a version before manifests: refusing it would lose the run, so it
            // is accepted with a warning (its next checkpoint has a manifest).
            // A full or closed stderr must not stop the resume: the warning is dropped then.
            let _ = writeln!(
                std::io::stderr(),
                "warning: {}: no manifest.json (a checkpoint written by an older defender), so its files \
                 cannot be verified; the next checkpoint will have one",
                dir.display()
            );
            return Ok(());
        }
        Err(e) => return Err(RlError::io(&path, e)),
    };
    if meta.len() > MAX_MANIFEST_BYTES {
        return Err(RlError::checkpoint(
            &path,
            format!("{} bytes, not a manifest (the file is corrupt)", meta.len()),
        ));
    }
    let manifest: Manifest = read_json(&path)
        .map_err(|e| RlError::checkpoint(&path, format!("unreadable ({e}); the file is corrupt")))?;
    if manifest.format != MANIFEST_FORMAT {
        return Err(RlError::checkpoint(
            &path,
            format!("format {} (this defender reads format {MANIFEST_FORMAT})", manifest.format),
        ));
    }
    for (name, want) in &manifest.files {
        let rel = Path::new(name);
        if name.is_empty() || !rel.components().all(|c| matches!(c, Component::Normal(_))) {
            return Err(RlError::checkpoint(
                &path,
                format!("lists {name:?}, not a path inside the checkpoint (the file is corrupt)"),
            ));
        }
        let file = dir.join(rel);
        let got_bytes = match std::fs::metadata(&file) {
            Ok(m) if m.is_file() => m.len(),
            _ => return Err(RlError::checkpoint(&file, "missing (the checkpoint is incomplete)")),
        };
        if got_bytes != want.bytes {
            return Err(RlError::checkpoint(
                &file,
                format!(
                    "{got_bytes} bytes where the manifest records {} (the file is truncated or corrupt)",
                    want.bytes
                ),
            ));
        }
        if file_sum(&file)?.crc32 != want.crc32 {
            return Err(RlError::checkpoint(&file, "checksum mismatch (the file is corrupt)"));
        }
    }
    Ok(())
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
    fn every_file_is_verified_against_the_manifest() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("checkpoint");
        write_atomic(&dir, |d| {
            std::fs::create_dir(d.join("agent")).map_err(|e| RlError::io(d, e))?;
            std::fs::write(d.join("agent/actor.bin"), [1u8, 2, 3]).map_err(|e| RlError::io(d, e))?;
            std::fs::write(d.join("trainer.json"), "{}").map_err(|e| RlError::io(d, e))
        })
        .unwrap();
        resolve(&dir).unwrap();
        std::fs::write(dir.join("agent/actor.bin"), [1u8, 2, 7]).unwrap();
        let err = resolve(&dir).unwrap_err().to_string();
        assert!(err.contains("actor.bin") && err.contains("checksum mismatch"), "{err}");
        std::fs::write(dir.join("agent/actor.bin"), [1u8, 2]).unwrap();
        let err = resolve(&dir).unwrap_err().to_string();
        assert!(err.contains("actor.bin") && err.contains("truncated"), "{err}");
        std::fs::remove_file(dir.join("agent/actor.bin")).unwrap();
        assert!(resolve(&dir).unwrap_err().to_string().contains("missing"));
        std::fs::remove_file(dir.join(MANIFEST_FILE)).unwrap();
        resolve(&dir).expect("an older checkpoint (no manifest) is accepted with a warning");
        std::fs::write(
            dir.join(MANIFEST_FILE),
            r#"{"format": 1, "files": {"../x": {"bytes": 0, "crc32": "0"}}}"#,
        )
        .unwrap();
        assert!(resolve(&dir).unwrap_err().to_string().contains("not a path inside"));
    }

    #[test]
    fn replaces_the_whole_directory_and_recovers_an_interrupted_swap() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("checkpoint");
        write_atomic(&dir, |d| std::fs::write(d.join("a"), "1").map_err(|e| RlError::io(d, e))).unwrap();
        write_atomic(&dir, |d| std::fs::write(d.join("b"), "2").map_err(|e| RlError::io(d, e))).unwrap();
        assert!(!dir.join("a").exists(), "a file of the previous checkpoint survived");
        assert_eq!(std::fs::read_to_string(dir.join("b")).unwrap(), "2");
        assert!(
            !defender_io::tmp_sibling(&dir, ".tmp").exists()
                && !defender_io::tmp_sibling(&dir, ".old").exists()
        );
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
