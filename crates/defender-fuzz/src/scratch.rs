//! A folder of the process's own for the targets whose parsers read files: one per process,
//! removed when the process exits (the replay's test binary when its tests are done, a libFuzzer
//! run when it ends by `exit`). A process that aborts on a crash leaves it for inspection.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();

/// The process's scratch folder.
pub(crate) fn dir() -> &'static Path {
    DIR.get_or_init(|| {
        let dir = tempfile::Builder::new().prefix("defender-fuzz-").tempdir().unwrap_or_else(|e| {
            // The harness cannot run without a folder to write its inputs into.
            panic!("cannot create a scratch folder in {}: {e}", std::env::temp_dir().display())
        });
        // A static is never dropped, so TempDir's own removal never runs: exit does it.
        // SAFETY: atexit only records a function pointer; remove_at_exit is a plain extern "C"
        // function that cannot unwind (it ignores every error).
        unsafe {
            libc::atexit(remove_at_exit);
        }
        dir
    })
    .path()
}

extern "C" fn remove_at_exit() {
    if let Some(dir) = DIR.get() {
        let _ = std::fs::remove_dir_all(dir.path());
    }
}

/// A path in the scratch folder unique to the calling thread (the replay runs targets in
/// parallel threads).
pub(crate) fn thread_path(name: &str) -> PathBuf {
    let id = format!("{:?}", std::thread::current().id());
    let id: String = id.chars().filter(char::is_ascii_digit).collect();
    dir().join(format!("{id}-{name}"))
}
