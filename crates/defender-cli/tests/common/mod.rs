//! Helpers shared by the CLI's integration tests (each test file that needs them says `mod common;`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The project's Python (made by `make setup`, with numpy), for tests that make inputs with it
/// or run a tools/ script.
#[allow(dead_code)]
pub fn python() -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../.deps/venv/bin/python");
    assert!(p.exists(), "{} is missing: run `make setup`", p.display());
    p
}

/// The `defender` binary under test, its networks on one thread.
#[allow(dead_code)] // each test file uses a part
pub fn command() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_defender"));
    c.env("DEFENDER_NN_THREADS", "1");
    c
}

/// Runs `defender args`.
#[allow(dead_code)]
pub fn defender(args: &[&str]) -> Output {
    command().args(args).output().expect("run defender")
}

/// A run's stdout and stderr, together.
#[allow(dead_code)]
pub fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

/// Runs `defender args`, which must succeed; its output.
#[allow(dead_code)]
pub fn ok(args: &[&str]) -> String {
    let out = defender(args);
    assert!(out.status.success(), "defender {args:?} failed:\n{}", text(&out));
    text(&out)
}

/// Runs `defender args`, which must fail with exit code 1, a message holding every `expect`,
/// and no panic.
#[allow(dead_code)]
pub fn refused(args: &[&str], expect: &[&str]) {
    let out = defender(args);
    let msg = text(&out);
    assert_eq!(out.status.code(), Some(1), "defender {args:?} should fail:\n{msg}");
    for e in expect {
        assert!(msg.contains(e), "defender {args:?}: message lacks '{e}':\n{msg}");
    }
    assert!(!msg.contains("panicked"), "{msg}");
}

/// A path as a command-line argument.
#[allow(dead_code)]
pub fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// The lines of `dir/metrics.csv` without its `wall_seconds` column, the only one that depends on
/// the machine, so that two runs' files can be compared for bit-exactness. The column is found by
/// its name in the header: columns added later (like `cost`) must not shift it.
#[allow(dead_code)]
pub fn metrics_without_wall(dir: &Path) -> Vec<String> {
    let path = dir.join("metrics.csv");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let header = text.lines().next().unwrap_or_default();
    let wall = header
        .split(',')
        .position(|c| c == "wall_seconds")
        .unwrap_or_else(|| panic!("{}: no wall_seconds column in the header {header:?}", path.display()));
    text.lines()
        .map(|l| {
            l.split(',').enumerate().filter(|&(i, _)| i != wall).map(|(_, f)| f).collect::<Vec<_>>().join(",")
        })
        .collect()
}
