//! A run is never lost: SIGTERM/SIGINT stop it at a checkpoint with the conventional exit code,
//! kill -9 loses at most the work since the last checkpoint, `--resume` continues it to exactly
//! the results of the same run left alone, and refuses what it cannot honour. Through the
//! binary, where a user (or a scheduler such as Slurm or Ray) meets it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::{ok, refused, s};

const ENV_ID: &str = "InvertedDoublePendulum-v5";

fn spawn(args: &[&str]) -> Child {
    common::command().args(args).stdout(Stdio::null()).stderr(Stdio::null()).spawn().expect("spawn defender")
}

fn signal(child: &Child, sig: &str) {
    let status = Command::new("kill").args(["-s", sig, &child.id().to_string()]).status().unwrap();
    assert!(status.success());
}

fn same_results(a: &Path, b: &Path) {
    let (ma, mb) = (common::metrics_without_wall(a), common::metrics_without_wall(b));
    assert_eq!(ma.len(), mb.len(), "episode counts differ");
    assert_eq!(ma, mb, "metrics.csv differs");
    let eval = |d: &Path| std::fs::read_to_string(d.join("eval.csv")).unwrap();
    assert_eq!(eval(a), eval(b), "eval.csv differs");
    let updates = |d: &Path| std::fs::read_to_string(d.join("updates.csv")).unwrap();
    assert!(updates(a).lines().count() > 2, "updates.csv has no rows:\n{}", updates(a));
    assert_eq!(updates(a), updates(b), "updates.csv differs");
    assert!(actor(a) == actor(b), "the final actors differ");
}

/// The final actor as (header, tensor bytes): safetensors' JSON header compared as a value,
/// since its metadata map has no fixed key order.
fn actor(dir: &Path) -> (serde_json::Value, Vec<u8>) {
    let bytes = std::fs::read(dir.join("actor.safetensors")).unwrap();
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    (serde_json::from_slice(&bytes[8..8 + n]).unwrap(), bytes[8 + n..].to_vec())
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// A DEFENDER run long enough to be interrupted several times, learning from step 300 on (so
/// that the networks, the optimisers and `updates.csv` change as it goes).
fn run_args(out: &Path) -> Vec<String> {
    let config = out.with_extension("sac.toml");
    std::fs::write(&config, format!("env = \"{ENV_ID}\"\nalgo = \"sac\"\n[sac]\nlearning_starts = 300\n"))
        .unwrap();
    [
        "train",
        "--config",
        s(&config),
        "--strategy",
        "MinDemoW5/MinDemoW10",
        "--steps",
        "2500",
        "--eval-freq",
        "1000",
        "--checkpoint-every",
        "40",
        "--seed",
        "3",
        "--out",
        s(out),
    ]
    .map(String::from)
    .to_vec()
}

fn args_ref(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

#[test]
fn sigterm_and_sigint_stop_at_a_checkpoint_with_the_conventional_exit_code() {
    let root = tempfile::tempdir().unwrap();
    for (sig, code) in [("TERM", 143), ("INT", 130), ("HUP", 129)] {
        let out = root.path().join(sig);
        let mut child = spawn(&args_ref(&run_args(&out)));
        // Wait until the run is under way (its summary is written at the start).
        let start = Instant::now();
        while !out.join("summary.json").exists() && start.elapsed() < Duration::from_secs(60) {
            std::thread::sleep(Duration::from_millis(50));
        }
        std::thread::sleep(Duration::from_millis(400));
        signal(&child, sig);
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(code), "SIG{sig}");
        assert!(out.join("checkpoint/trainer.json").exists(), "SIG{sig}: no checkpoint written");
        assert_eq!(summary(&out)["complete"], serde_json::Value::Bool(false));
        ok(&["train", "--out", s(&out), "--resume"]);
        assert_eq!(summary(&out)["complete"], serde_json::Value::Bool(true));
    }
}

/// The soak test: killed with SIGKILL and SIGTERM at moments drawn from a fixed seed, resumed
/// each time, the run ends exactly as the same run left alone.
#[test]
fn a_run_killed_and_resumed_many_times_ends_as_the_run_left_alone() {
    let root = tempfile::tempdir().unwrap();
    let alone = root.path().join("alone");
    ok(&args_ref(&run_args(&alone)));

    let out = root.path().join("interrupted");
    let mut state = 0x9E37_79B9_7F4A_7C15_u64;
    let mut next = || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        state >> 33
    };
    let mut kills = 0;
    let mut first = true;
    for round in 0..8 {
        let args = if first {
            run_args(&out)
        } else {
            ["train", "--out", s(&out), "--resume"].map(String::from).to_vec()
        };
        first = false;
        let mut child = spawn(&args_ref(&args));
        std::thread::sleep(Duration::from_millis(300 + next() % 1500));
        if child.try_wait().unwrap().is_some() {
            break; // finished before the kill
        }
        let sig = if round % 2 == 0 { "KILL" } else { "TERM" };
        signal(&child, sig);
        let status = child.wait().unwrap();
        kills += 1;
        if sig == "TERM" {
            assert!(matches!(status.code(), Some(143) | Some(0)), "SIGTERM exit: {status:?}");
        }
    }
    // However far it got, one last --resume finishes it.
    ok(&["train", "--out", s(&out), "--resume"]);
    assert!(kills >= 2, "the run was interrupted only {kills} times");
    same_results(&alone, &out);
    for leftover in ["checkpoint.tmp", "checkpoint.old", "metrics.csv.tmp", "summary.json.tmp"] {
        assert!(!out.join(leftover).exists(), "{leftover} left behind");
    }
}

#[test]
fn a_run_killed_before_its_first_checkpoint_starts_again_under_resume() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("early");
    let mut args = run_args(&out);
    let at = args.iter().position(|a| a == "--checkpoint-every").unwrap();
    args[at + 1] = "0".into();
    args.extend(["--checkpoint-seconds", "0"].map(String::from));
    let mut child = spawn(&args_ref(&args));
    let start = Instant::now();
    while !out.join("summary.json").exists() && start.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    signal(&child, "KILL");
    let _ = child.wait();
    assert!(!out.join("checkpoint").exists());
    ok(&["train", "--out", s(&out), "--resume"]);
    assert_eq!(summary(&out)["complete"], serde_json::Value::Bool(true));
}

fn stopped_run(root: &Path, name: &str, demos: Option<&Path>) -> PathBuf {
    let out = root.join(name);
    let mut args = run_args(&out);
    let at = args.iter().position(|a| a == "--steps").unwrap();
    args[at + 1] = "300".into();
    if let Some(d) = demos {
        args.extend(["--demos".to_string(), s(d).to_string()]);
    }
    ok(&args_ref(&args));
    out
}

#[test]
fn resume_refuses_what_it_cannot_honour() {
    let root = tempfile::tempdir().unwrap();
    let demos = root.path().join("demos.npz");
    let shipped =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos").join(format!("{ENV_ID}.npz"));
    std::fs::copy(&shipped, &demos).unwrap();
    let out = stopped_run(root.path(), "run", Some(&demos));
    let o = s(&out);
    // Flags that would change the run.
    refused(
        &["train", "--out", o, "--resume", "--strategy", "MeanDemoW5/MeanDemoW10"],
        &["defender.strategy", "MinDemoW5/MinDemoW10"],
    );
    refused(&["train", "--out", o, "--resume", "--seed", "4"], &["seed: 3 -> 4"]);
    refused(&["train", "--out", o, "--resume", "--env", "Hopper-v5"], &["env:"]);
    // Flags that repeat the run's own settings are fine; a smaller budget is not.
    refused(&["train", "--out", o, "--resume", "--steps", "100"], &["budget"]);
    // The run is complete: a different budget needs a new run.
    refused(&["train", "--out", o, "--resume", "--steps", "600"], &["complete"]);
    // An edited config.toml.
    let config = out.join("config.toml");
    let saved = std::fs::read_to_string(&config).unwrap();
    std::fs::write(&config, saved.replace("MinDemoW5/MinDemoW10", "MeanBothW5/MeanBothW5")).unwrap();
    refused(&["train", "--out", o, "--resume"], &["config.toml differs", "defender.strategy"]);
    std::fs::write(&config, &saved).unwrap();
    // Demonstrations whose content changed since the run started.
    let mut bytes = std::fs::read(&demos).unwrap();
    let n = bytes.len();
    bytes[n / 2] ^= 1;
    std::fs::write(&demos, bytes).unwrap();
    refused(&["train", "--out", o, "--resume"], &["demonstrations changed", "SHA-256"]);
}

#[test]
fn a_larger_budget_extends_a_stopped_run_everywhere() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("extend");
    let mut child = spawn(&args_ref(&run_args(&out)));
    let start = Instant::now();
    let has_first_rows = || {
        ["updates.csv", "dynamics.csv"]
            .iter()
            .all(|f| std::fs::read_to_string(out.join(f)).is_ok_and(|t| t.contains("\n1000,")))
    };
    while !has_first_rows() && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(50));
    }
    signal(&child, "TERM");
    assert_eq!(child.wait().unwrap().code(), Some(143));
    ok(&["train", "--out", s(&out), "--resume", "--steps", "3000"]);
    let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(config.contains("total_steps = 3000"), "{config}");
    assert_eq!(summary(&out)["steps"].as_u64(), Some(3000));
    let eval = std::fs::read_to_string(out.join("eval.csv")).unwrap();
    assert!(eval.lines().last().unwrap().starts_with("3000,"), "{eval}");
    // Stopped after its first rows, the run keeps every row it had written.
    for file in ["updates.csv", "dynamics.csv"] {
        let text = std::fs::read_to_string(out.join(file)).unwrap();
        let steps: Vec<&str> = text.lines().skip(1).map(|l| l.split(',').next().unwrap()).collect();
        assert_eq!(steps, ["1000", "2000", "3000"], "{file}:\n{text}");
    }
}

#[test]
fn one_run_directory_has_one_writer() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("shared");
    let mut first = spawn(&args_ref(&run_args(&out)));
    let start = Instant::now();
    while !out.join("summary.json").exists() && start.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    refused(&args_ref(&run_args(&out)), &["in use by another process"]);
    refused(&["train", "--out", s(&out), "--resume"], &["in use by another process"]);
    assert!(first.wait().unwrap().success());
}

#[test]
fn foreign_directories_and_unwritable_outputs_are_refused_before_any_work() {
    let root = tempfile::tempdir().unwrap();
    let foreign = root.path().join("mine");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("metrics.csv"), "my own data\n").unwrap();
    refused(
        &["train", "--env", ENV_ID, "--steps", "200", "--out", s(&foreign)],
        &["not a run directory", "metrics.csv"],
    );
    assert_eq!(std::fs::read_to_string(foreign.join("metrics.csv")).unwrap(), "my own data\n");

    let out = root.path().join("rec");
    let start = Instant::now();
    refused(
        &[
            "train",
            "--env",
            ENV_ID,
            "--steps",
            "200000",
            "--record-episodes",
            "/no/such/dir/e.npz",
            "--out",
            s(&out),
        ],
        &["--record-episodes", "/no/such/dir/e.npz"],
    );
    assert!(start.elapsed() < Duration::from_secs(30), "refused only after training");

    refused(
        &[
            "train",
            "--env",
            ENV_ID,
            "--steps",
            "200",
            "--strategy",
            "MinDemoW5/MinDemoW10",
            "--r-task",
            "1e300",
            "--out",
            s(&root.path().join("r")),
        ],
        &["r_task", "out of range"],
    );
}

#[test]
fn impossible_sizes_are_errors_not_aborts() {
    let root = tempfile::tempdir().unwrap();
    for (i, (section, expect)) in
        [("buffer_size = 1000000000000", "buffer_size"), ("net_arch = [100000000, 100000000]", "net_arch")]
            .iter()
            .enumerate()
    {
        let config = root.path().join(format!("c{i}.toml"));
        std::fs::write(
            &config,
            format!("env = \"{ENV_ID}\"\nalgo = \"sac\"\ntotal_steps = 100\n[sac]\n{section}\n"),
        )
        .unwrap();
        refused(
            &["train", "--config", s(&config), "--out", s(&root.path().join(format!("o{i}")))],
            &[expect, "invalid configuration"],
        );
    }
}

#[test]
fn long_commands_check_their_output_path_before_working() {
    let demos = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos").join(format!("{ENV_ID}.npz"));
    let start = Instant::now();
    refused(
        &["demos", "collect", "--env", ENV_ID, "--safe", "2", "--unsafe", "2", "--out", "/no/such/dir/d.npz"],
        &["--out", "/no/such/dir/d.npz"],
    );
    refused(
        &["ablate", "--demos", s(&demos), "--episodes", s(&demos), "--out", "/no/such/dir/s.csv"],
        &["--out", "/no/such/dir/s.csv"],
    );
    assert!(start.elapsed() < Duration::from_secs(20), "refused only after the work");
}
