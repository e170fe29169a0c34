//! A folder of the process's own for the targets whose parsers read files: one per process,
//! removed when the process ends normally (libFuzzer's runs end by exit, which leaves it in the
//! system's temporary folder: a few small files).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The process's scratch folder.
pub(crate) fn dir() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        tempfile::Builder::new().prefix("defender-fuzz-").tempdir().unwrap_or_else(|e| {
            // The harness cannot run without a folder to write its inputs into.
            panic!("cannot create a scratch folder in {}: {e}", std::env::temp_dir().display())
        })
    })
    .path()
}

/// A path in the scratch folder unique to the calling thread (the replay runs targets in
/// parallel threads).
pub(crate) fn thread_path(name: &str) -> PathBuf {
    let id = format!("{:?}", std::thread::current().id());
    let id: String = id.chars().filter(char::is_ascii_digit).collect();
    dir().join(format!("{id}-{name}"))
}
