//! Progress off a terminal: a run whose stderr is a file or a pipe (nohup, a sweep's per-run log,
//! a Ray worker) prints a plain `progress:` line every `DEFENDER_PROGRESS_INTERVAL` seconds, never
//! a carriage-return bar; `off` silences it; and a sweep's "complete" line quotes the run's
//! summary, not its closing `run directory:` line.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::{Command, Output};

fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

/// `defender train` on IDP for 1,500 steps, SAC learning from step 1,000 (about two seconds, so
/// a line a second shows more than once), with the interval variable set to `interval`.
fn train(dir: &Path, interval: Option<&str>) -> Output {
    let config = dir.join("run.toml");
    std::fs::write(
        &config,
        "profile = \"spec\"\nenv = \"InvertedDoublePendulum-v5\"\ntotal_steps = 1500\n[sac]\nlearning_starts = 1000\n",
    )
    .unwrap();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_defender"));
    cmd.args(["train", "--config"]).arg(&config).arg("--out").arg(dir.join("run"));
    cmd.env_remove("DEFENDER_PROGRESS_INTERVAL");
    if let Some(value) = interval {
        cmd.env("DEFENDER_PROGRESS_INTERVAL", value);
    }
    let out = cmd.output().expect("run defender");
    assert!(out.status.success(), "{}", text(&out));
    out
}

fn progress_lines(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| l.starts_with("progress:"))
        .map(String::from)
        .collect()
}

#[test]
fn a_run_off_a_terminal_prints_plain_progress_lines_at_the_interval() {
    let dir = tempfile::tempdir().unwrap();
    let out = train(dir.path(), Some("0"));
    let lines = progress_lines(&out);
    assert!(!lines.is_empty(), "no progress line with an interval of 0:\n{}", text(&out));
    for line in &lines {
        // e.g. "progress: 00:00:01 733/1500 steps (812/s, eta 0s) ep 120 return 31 crash ..."
        assert!(line.contains("/1500 steps (") && line.contains("/s, eta "), "{line}");
    }
    assert!(
        lines.iter().any(|l| l.contains(" ep ") && l.contains(" crash ")),
        "no line names an episode: {lines:?}"
    );
    assert!(!String::from_utf8_lossy(&out.stderr).contains('\r'), "a bar's carriage returns reached a file");
}

#[test]
fn the_default_interval_is_quiet_on_a_short_run_and_off_is_silent() {
    for interval in [None, Some("off")] {
        let dir = tempfile::tempdir().unwrap();
        let out = train(dir.path(), interval);
        assert!(progress_lines(&out).is_empty(), "{interval:?}:\n{}", text(&out));
    }
}

#[test]
fn an_unreadable_interval_is_named_and_the_default_used() {
    let dir = tempfile::tempdir().unwrap();
    let out = train(dir.path(), Some("1m"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("DEFENDER_PROGRESS_INTERVAL=\"1m\"") && stderr.contains("using 60s"), "{stderr}");
    assert!(progress_lines(&out).is_empty(), "{stderr}");
}

#[test]
fn a_sweep_reports_each_finished_run_by_its_summary() {
    let smoke = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/smoke.toml");
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_defender"))
        .arg("sweep")
        .arg(&smoke)
        .arg("--out")
        .arg(dir.path())
        .args(["--jobs", "1"])
        .env("DEFENDER_PROGRESS_INTERVAL", "off")
        .output()
        .expect("run defender");
    assert!(out.status.success(), "{}", text(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let complete: Vec<&str> = stderr.lines().filter(|l| l.contains("] complete ")).collect();
    assert_eq!(complete.len(), 2, "{stderr}");
    for line in complete {
        assert!(line.contains("1500 steps") && line.contains("Acc Reward"), "{line}");
        assert!(line.contains("; evaluation (mean of the last"), "the evaluations follow: {line}");
        assert!(!line.contains("run directory:"), "{line}");
    }
}
