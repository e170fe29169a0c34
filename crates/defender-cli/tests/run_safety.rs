//! A run's inputs and finished results are never damaged by the run or by a user's mistake, and
//! every failure says what went wrong and where, at once (docs/run-directory.md, "What a run
//! reads and writes"): no output lands on an input, a resume without its checkpoint rewrites
//! nothing, output that cannot be printed is no panic, inputs that are not files never hang,
//! and a `train` that fails leaves no directory behind.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::{s, text};

const ENV_ID: &str = "InvertedDoublePendulum-v5";

/// `common::command()` with the progress lines off, so that a run's output is only its messages.
fn bin() -> Command {
    let mut c = common::command();
    c.env("DEFENDER_PROGRESS_INTERVAL", "off");
    c
}

/// Runs `defender args`, killed after `limit` (a hang fails the test instead of blocking it).
fn run_within(args: &[&str], limit: Duration) -> Output {
    let mut child =
        bin().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn defender");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("defender {args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Like `common::refused`, but under a time limit, with clap's usage errors (exit code 2) allowed
/// too, and giving the message back.
fn refused(args: &[&str], expect: &[&str]) -> String {
    let out = run_within(args, Duration::from_secs(60));
    let msg = text(&out);
    assert!(matches!(out.status.code(), Some(1 | 2)), "defender {args:?} should fail:\n{msg}");
    for e in expect {
        assert!(msg.contains(e), "defender {args:?}: message lacks '{e}':\n{msg}");
    }
    assert!(!msg.contains("panicked"), "{msg}");
    msg
}

/// Like `common::ok`, but under a time limit.
fn ok(args: &[&str]) {
    let out = run_within(args, Duration::from_secs(120));
    assert!(out.status.success(), "defender {args:?} failed:\n{}", text(&out));
}

fn shipped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos").join(format!("{ENV_ID}.npz"))
}

fn train<'a>(out: &'a Path, more: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["train", "--env", ENV_ID, "--steps", "300", "--eval-freq", "0", "--out", s(out)];
    args.extend_from_slice(more);
    args
}

#[test]
fn a_run_never_writes_over_what_it_reads_nor_over_a_file_of_another_kind() {
    let root = tempfile::tempdir().unwrap();
    let demos = root.path().join("demos.npz");
    std::fs::copy(shipped(), &demos).unwrap();
    let original = std::fs::read(&demos).unwrap();
    let hard = root.path().join("hard.npz");
    std::fs::hard_link(&demos, &hard).unwrap();
    let soft = root.path().join("soft.npz");
    std::os::unix::fs::symlink(&demos, &soft).unwrap();
    let out = root.path().join("r1");
    let defender = ["--strategy", "MinDemoW5/MinDemoW10", "--demos", s(&demos)];
    for target in [&demos, &hard, &soft] {
        let mut more = defender.to_vec();
        more.extend(["--record-episodes", s(target)]);
        refused(&train(&out, &more), &["--record-episodes", "--demos", "which this run reads"]);
    }
    // The demonstrations shipped for the task, read by default.
    let shipped = shipped();
    let shipped_bytes = std::fs::read(&shipped).unwrap();
    refused(
        &train(&out, &["--strategy", "MinDemoW5/MinDemoW10", "--record-episodes", s(&shipped)]),
        &["which this run reads"],
    );
    assert_eq!(std::fs::read(&shipped).unwrap(), shipped_bytes);
    // Recovery RL reads the shipped set too (its safety critic's offline data), without a filter.
    refused(
        &train(&out, &["--recovery", "0.3", "--record-episodes", s(&shipped)]),
        &["which this run reads"],
    );
    assert_eq!(std::fs::read(&shipped).unwrap(), shipped_bytes);
    // The run's own files.
    refused(
        &train(&out, &["--record-episodes", s(&out.join("metrics.csv"))]),
        &["--record-episodes", "metrics.csv (--out)"],
    );
    // An existing file that is not a recording of `defender train`: a script, demonstrations.
    let script = root.path().join("analysis.py");
    std::fs::write(&script, "print('mine')\n").unwrap();
    refused(&train(&out, &["--record-episodes", s(&script)]), &["analysis.py", "not an episode set"]);
    assert_eq!(std::fs::read_to_string(&script).unwrap(), "print('mine')\n");
    let other = root.path().join("other.npz");
    std::fs::copy(&demos, &other).unwrap();
    refused(&train(&out, &["--record-episodes", s(&other)]), &["another kind", "defender demos collect"]);
    assert_eq!(std::fs::read(&demos).unwrap(), original);
    assert!(!out.exists(), "a refused run left {}", out.display());
    // A recording of an earlier run is what --record-episodes replaces.
    let rec = root.path().join("episodes.npz");
    ok(&train(&root.path().join("a"), &["--record-episodes", s(&rec)]));
    ok(&train(&root.path().join("b"), &["--record-episodes", s(&rec), "--seed", "1"]));
}

#[test]
fn a_resume_without_a_readable_checkpoint_rewrites_nothing() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("run");
    ok(&train(&out, &["--checkpoint-every", "5"]));
    let metrics = std::fs::read(out.join("metrics.csv")).unwrap();
    let rows = String::from_utf8_lossy(&metrics).lines().count() - 1;
    assert!(rows > 10, "{rows} episodes");
    let checkpoint = out.join("checkpoint");
    std::fs::remove_dir_all(&checkpoint).unwrap();
    std::os::unix::fs::symlink("/nonexistent", &checkpoint).unwrap();
    let msg = refused(
        &["train", "--out", s(&out), "--resume", "--steps", "600"],
        &["no readable checkpoint", "symbolic link to /nonexistent", "nothing was changed"],
    );
    assert!(msg.contains(&format!("holds {rows} training episodes")), "{msg}");
    std::fs::remove_file(&checkpoint).unwrap();
    refused(&["train", "--out", s(&out), "--resume", "--steps", "600"], &["no readable checkpoint"]);
    assert_eq!(std::fs::read(out.join("metrics.csv")).unwrap(), metrics, "metrics.csv was rewritten");
    assert!(!root.path().join("run/checkpoint.tmp").exists());
}

#[test]
fn output_that_cannot_be_written_is_no_panic_and_costs_no_file() {
    let root = tempfile::tempdir().unwrap();
    for (stream, name) in [("stdout", "full-out"), ("stderr", "full-err")] {
        let out = root.path().join(name);
        let mut cmd = bin();
        // learning_starts beyond the budget: a warning on stderr before training.
        cmd.args(train(&out, &[]));
        let full = || Stdio::from(File::options().write(true).open("/dev/full").unwrap());
        let result = if stream == "stdout" {
            cmd.stdout(full()).stderr(Stdio::piped()).output().unwrap()
        } else {
            cmd.stdout(Stdio::piped()).stderr(full()).output().unwrap()
        };
        let msg = text(&result);
        assert!(!msg.contains("panicked"), "{stream}: {msg}");
        assert_ne!(result.status.code(), Some(101), "{stream}: a panic");
        if stream == "stdout" {
            assert_eq!(result.status.code(), Some(1), "{msg}");
            assert!(msg.contains("cannot write to standard output"), "{msg}");
        } else {
            assert!(result.status.success(), "{msg}");
        }
        let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
        assert!(summary.contains("\"complete\": true"), "{stream}: {summary}");
        assert!(out.join("actor.safetensors").is_file(), "{stream}");
    }
}

#[test]
fn inputs_that_are_not_regular_files_are_refused_at_once() {
    let root = tempfile::tempdir().unwrap();
    let fifo = root.path().join("fifo.npz");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let folder = root.path().join("folder.npz");
    std::fs::create_dir(&folder).unwrap();
    let out = root.path().join("r");
    let limit = Duration::from_secs(20);
    let unused = root.path().join("unused");
    let csv = root.path().join("unused.csv");
    for (input, what) in [
        (Path::new("/dev/zero"), "a character device"),
        (fifo.as_path(), "a FIFO"),
        (folder.as_path(), "a directory"),
    ] {
        let start = Instant::now();
        let args = train(&out, &["--strategy", "MinDemoW5/MinDemoW10", "--demos", s(input)]);
        let out = run_within(&args, limit);
        let msg = text(&out);
        assert_eq!(out.status.code(), Some(1), "{msg}");
        assert!(msg.contains(s(input)) && msg.contains(what), "{msg}");
        let config = ["train", "--config", s(input), "--out", s(&unused)];
        assert!(text(&run_within(&config, limit)).contains(what));
        let ablate = ["ablate", "--demos", s(input), "--episodes", s(input), "--out", s(&csv)];
        assert!(text(&run_within(&ablate, limit)).contains(what));
        let select = ["select", "--demos", s(input), "--out", s(&csv)];
        assert!(text(&run_within(&select, limit)).contains(what));
        assert!(start.elapsed() < limit, "{input:?} took {:?}", start.elapsed());
    }
    assert!(!out.exists() && !unused.exists() && !csv.exists());
}

#[test]
fn a_failed_train_leaves_no_directory_behind() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("never");
    let o = s(&out);
    let junk = root.path().join("junk.npz");
    std::fs::write(&junk, "not an archive").unwrap();
    let cases: Vec<(Vec<&str>, &[&str])> = vec![
        (
            vec!["train", "--env", "Hopper-v9", "--steps", "100", "--out", o],
            &["--env Hopper-v9", "unknown task"],
        ),
        (vec!["train", "--steps", "100", "--out", o], &["--env is required"]),
        (vec!["train", "--env", ENV_ID, "--out", o], &["no budget"]),
        (
            vec![
                "train",
                "--env",
                ENV_ID,
                "--steps",
                "100",
                "--strategy",
                "MinDemoW5/MinDemoW10",
                "--demos",
                "no.npz",
                "--out",
                o,
            ],
            &["--demos no.npz", "No such file"],
        ),
        (
            vec!["train", "--env", ENV_ID, "--steps", "100", "--seed", "9223372036854775808", "--out", o],
            &["--seed", "too large"],
        ),
        (
            vec!["train", "--env", ENV_ID, "--steps", "18446744073709551615", "--out", o],
            &["--steps", "too large"],
        ),
        (
            vec!["train", "--env", ENV_ID, "--episodes", "9223372036854775808", "--out", o],
            &["--episodes", "too large"],
        ),
        // Past the checks before the directory exists: it is removed again.
        (
            vec![
                "train",
                "--env",
                ENV_ID,
                "--steps",
                "100",
                "--strategy",
                "MinDemoW5/MinDemoW10",
                "--demos",
                s(&junk),
                "--out",
                o,
            ],
            &["junk.npz", "not a .npz"],
        ),
    ];
    for (args, expect) in cases {
        refused(&args, expect);
        assert!(!out.exists(), "defender {args:?} left {o} behind");
    }
    // A folder the user made stays, empty.
    std::fs::create_dir(&out).unwrap();
    refused(&["train", "--env", ENV_ID, "--out", o], &["no budget"]);
    refused(
        &[
            "train",
            "--env",
            ENV_ID,
            "--steps",
            "100",
            "--strategy",
            "MinDemoW5/MinDemoW10",
            "--demos",
            s(&junk),
            "--out",
            o,
        ],
        &["not a .npz"],
    );
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0, "left files in {o}");
}

#[test]
fn a_config_toml_that_cannot_be_read_is_named_as_such() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("loop");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("metrics.csv"), "episode,total_steps,return,length,outcome,wall_seconds\n")
        .unwrap();
    std::os::unix::fs::symlink("config.toml", out.join("config.toml")).unwrap();
    for args in [
        vec!["train", "--out", s(&out), "--resume"],
        vec!["train", "--env", ENV_ID, "--steps", "100", "--out", s(&out)],
    ] {
        refused(&args, &["config.toml", "cannot be read", "symbolic links"]);
    }
    let report = run_within(&["report", s(&out)], Duration::from_secs(30));
    let msg = text(&report);
    assert!(msg.contains("config.toml is there but cannot be read"), "{msg}");
    assert!(!msg.contains("no config.toml"), "{msg}");
}
