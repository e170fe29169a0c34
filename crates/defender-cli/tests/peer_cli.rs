//! A peer library's run beside ours (docs/peers.md): `tools/peers/omnisafe_run_dir.py` turns the output
//! of `tools/peers/omnisafe_saclag.py` into a run directory, and `defender report` reads it as a row of
//! its own with the cost task's columns. The input is a real OmniSafe 0.5.0 SACLag run, short
//! (6,000 steps of SafetyHopperVelocity-v1, seed 0; how it was made is in its `run.json`),
//! committed as `tests/data/omnisafe-hopper`: the converter is tested on what OmniSafe writes, not
//! on a file made to fit it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{ok, python, s};

const FILES: [&str; 3] = ["episodes.csv", "evals.csv", "run.json"];
const RUN_DIR_FILES: [&str; 4] = ["config.toml", "metrics.csv", "eval.csv", "summary.json"];

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A copy of the fixture (the converter writes into the folder it reads).
fn fixture() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/omnisafe-hopper");
    for f in FILES {
        std::fs::copy(src.join(f), tmp.path().join(f)).unwrap();
    }
    tmp
}

fn convert(dir: &Path, extra: &[&str]) -> Output {
    Command::new(python())
        .arg(repo().join("tools/peers/omnisafe_run_dir.py"))
        .arg(dir)
        .args(extra)
        .output()
        .expect("run tools/peers/omnisafe_run_dir.py")
}

fn read(dir: &Path, f: &str) -> String {
    std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"))
}

/// A CSV file's column as numbers.
fn column(text: &str, name: &str) -> Vec<f64> {
    let mut lines = text.lines();
    let i = lines.next().unwrap().split(',').position(|c| c == name).unwrap();
    lines.map(|l| l.split(',').nth(i).unwrap().parse().unwrap()).collect()
}

#[test]
fn an_omnisafe_run_becomes_a_report_row_of_its_own() {
    let tmp = fixture();
    let dir = tmp.path();
    let out = convert(dir, &["--eval-every", "2000"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    // Every training episode, its outcome from its length (Hopper's health termination), its cost.
    let episodes = read(dir, "episodes.csv");
    let metrics = read(dir, "metrics.csv");
    let lengths = column(&episodes, "length");
    assert_eq!(metrics.lines().count(), lengths.len() + 1);
    for (row, len) in metrics.lines().skip(1).zip(&lengths) {
        let outcome = if *len < 1000.0 { ",crashed," } else { ",truncated," };
        assert!(row.contains(outcome), "{row} (length {len})");
    }
    assert_eq!(column(&metrics, "cost"), column(&episodes, "cost"));
    assert_eq!(column(&metrics, "return"), column(&episodes, "return"));

    // OmniSafe's one evaluation episode an epoch (1,000 steps here), grouped by 2,000 steps.
    let evals = read(dir, "evals.csv");
    let eval = read(dir, "eval.csv");
    let (returns, costs) = (column(&evals, "return"), column(&evals, "cost"));
    assert_eq!(column(&eval, "total_steps"), [2000.0, 4000.0, 6000.0]);
    assert_eq!(column(&eval, "episodes"), [2.0, 2.0, 2.0]);
    for (k, (mean, cost)) in column(&eval, "mean_return").iter().zip(column(&eval, "mean_cost")).enumerate() {
        assert!((mean - (returns[2 * k] + returns[2 * k + 1]) / 2.0).abs() < 1e-9);
        assert!((cost - (costs[2 * k] + costs[2 * k + 1]) / 2.0).abs() < 1e-9);
    }
    let summary: serde_json::Value = serde_json::from_str(&read(dir, "summary.json")).unwrap();
    let total: f64 = column(&episodes, "cost").iter().sum();
    assert!((summary["cost"].as_f64().unwrap() - total).abs() < 1e-9);
    assert_eq!(summary["episode_cost_limit"], 25.0);

    // The report reads it as any run: its own row, with the cost task's columns.
    let report = ok(&["report", s(dir)]);
    assert!(report.contains("SAC (omnisafe-saclag)"), "{report}");
    assert!(report.contains("Cost rate"), "{report}");

    // Converting again gives the same files.
    let first: Vec<String> = RUN_DIR_FILES.iter().map(|f| read(dir, f)).collect();
    assert!(convert(dir, &["--eval-every", "2000"]).status.success());
    let second: Vec<String> = RUN_DIR_FILES.iter().map(|f| read(dir, f)).collect();
    assert_eq!(first, second);
}

/// Refused with exit code 2 and a message naming the file, the line and what is wrong; never a
/// Python traceback, never a half-written run directory.
fn refused(dir: &Path, expect: &[&str]) {
    let out = convert(dir, &[]);
    let msg = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{msg}");
    for e in expect {
        assert!(msg.contains(e), "message lacks {e:?}: {msg}");
    }
    assert!(!msg.contains("Traceback"), "{msg}");
    assert!(!dir.join("summary.json").exists(), "a refused conversion wrote summary.json");
}

#[test]
fn an_unfinished_or_malformed_peer_run_is_refused_naming_the_file() {
    let tmp = fixture();
    let run = read(tmp.path(), "run.json");
    std::fs::write(tmp.path().join("run.json"), run.replace("\"complete\": true", "\"complete\": false"))
        .unwrap();
    refused(tmp.path(), &["run.json", "complete"]);

    let tmp = fixture();
    let episodes = read(tmp.path(), "episodes.csv");
    let mut lines: Vec<String> = episodes.lines().map(str::to_string).collect();
    let mut fields: Vec<&str> = lines[3].split(',').collect();
    fields[2] = "nan";
    lines[3] = fields.join(",");
    std::fs::write(tmp.path().join("episodes.csv"), lines.join("\n")).unwrap();
    refused(tmp.path(), &["episodes.csv:4", "column return", "not finite"]);

    let tmp = fixture();
    std::fs::remove_file(tmp.path().join("evals.csv")).unwrap();
    refused(tmp.path(), &["evals.csv", "missing"]);
}
