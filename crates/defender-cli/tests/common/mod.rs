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

/// Starts `defender args` (writing into `out`), waits until `ready()` holds, then stops it with
/// SIGTERM without racing its end: the process is frozen (SIGSTOP) first, and only a process
/// still alive then is sent SIGTERM and let go (SIGCONT). A run that ended first is started
/// again from an empty `out` (at most three times). Returns the stopped run's exit code.
#[allow(dead_code)]
pub fn stop_with_sigterm_when(args: &[String], out: &Path, ready: impl Fn() -> bool) -> Option<i32> {
    use std::time::{Duration, Instant};
    let signal = |pid: u32, sig: &str| {
        let status = Command::new("kill").args(["-s", sig, &pid.to_string()]).status().expect("kill");
        assert!(status.success(), "kill -s {sig} {pid}");
    };
    for _ in 0..3 {
        let _ = std::fs::remove_dir_all(out);
        let mut child = command()
            .args(args)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn defender");
        let start = Instant::now();
        while !ready() && start.elapsed() < Duration::from_secs(120) {
            if child.try_wait().expect("try_wait").is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let pid = child.id();
        if child.try_wait().expect("try_wait").is_some() {
            continue; // it ended before it could be stopped: again
        }
        signal(pid, "STOP");
        if child.try_wait().expect("try_wait").is_some() {
            continue;
        }
        signal(pid, "TERM");
        signal(pid, "CONT");
        return child.wait().expect("wait").code();
    }
    panic!("defender {args:?} ended three times before it could be stopped");
}
