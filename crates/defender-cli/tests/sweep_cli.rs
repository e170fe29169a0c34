//! `defender sweep` through the binary: an experiment file expands to ordinary runs, a sweep
//! stopped by SIGTERM and started again gives the same results as one left alone, complete runs
//! are skipped, and bad experiment files are refused before anything runs.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;

fn defender(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_defender")).args(args).output().expect("run defender")
}

fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

fn smoke() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/smoke.toml")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const RUNS: [&str; 2] =
    ["InvertedDoublePendulum-v5/sac-bare-s0", "InvertedDoublePendulum-v5/sac-MinDemoW5-MinDemoW10-s0"];

fn actor_tensors(dir: &Path) -> Vec<u8> {
    let bytes = std::fs::read(dir.join("actor.safetensors")).unwrap();
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    bytes[8 + n..].to_vec()
}

#[test]
fn a_sweep_stopped_by_sigterm_and_started_again_equals_one_left_alone() {
    let root = tempfile::tempdir().unwrap();
    let alone = root.path().join("alone");
    let out = defender(&["sweep", s(&smoke()), "--out", s(&alone), "--jobs", "2"]);
    assert!(out.status.success(), "{}", text(&out));
    let listed = text(&defender(&["sweep", s(&smoke()), "--out", s(&alone), "--list"]));
    assert_eq!(listed.matches("complete").count(), 2, "{listed}");

    let stopped = root.path().join("stopped");
    let mut child = Command::new(env!("CARGO_BIN_EXE_defender"))
        .args(["sweep", s(&smoke()), "--out", s(&stopped), "--jobs", "2"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Stop it once both runs are under way and have checkpointed.
    let start = Instant::now();
    while !RUNS.iter().all(|r| stopped.join(r).join("checkpoint/trainer.json").exists())
        && start.elapsed() < Duration::from_secs(120)
    {
        std::thread::sleep(Duration::from_millis(50));
    }
    Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert_eq!(child.wait().unwrap().code(), Some(143), "a sweep stopped by SIGTERM exits 143");
    for r in RUNS {
        let dir = stopped.join(r);
        // No run is left running: its directory can be locked again.
        let lock = defender_io::DirLock::try_acquire(&dir);
        assert!(lock.is_ok(), "{r} still has a writer after the sweep stopped");
    }
    let listed = text(&defender(&["sweep", s(&smoke()), "--out", s(&stopped), "--list"]));
    assert!(listed.contains("stopped"), "{listed}");

    let again = defender(&["sweep", s(&smoke()), "--out", s(&stopped), "--jobs", "2"]);
    assert!(again.status.success(), "{}", text(&again));
    for r in RUNS {
        assert_eq!(
            common::metrics_without_wall(&alone.join(r)),
            common::metrics_without_wall(&stopped.join(r)),
            "{r}: metrics.csv differs"
        );
        let eval = |d: &Path| std::fs::read_to_string(d.join(r).join("eval.csv")).unwrap();
        assert_eq!(eval(&alone), eval(&stopped), "{r}: eval.csv differs");
        assert!(actor_tensors(&alone.join(r)) == actor_tensors(&stopped.join(r)), "{r}: the actors differ");
    }
    // Everything complete: a third start skips both runs.
    let third = defender(&["sweep", s(&smoke()), "--out", s(&stopped)]);
    assert!(text(&third).contains("2 complete, 0 to run"), "{}", text(&third));
    // The report reads the sweep as it reads any runs.
    let report = defender(&["report", s(&stopped)]);
    assert!(report.status.success(), "{}", text(&report));
    assert!(text(&report).contains("MinDemoW5"), "{}", text(&report));

    // Another experiment may share complete runs when it asks for the same configuration ...
    let smoke_text = std::fs::read_to_string(smoke()).unwrap();
    let subset = root.path().join("subset.toml");
    std::fs::write(&subset, smoke_text.replace(r#"["none", "MinDemoW5/MinDemoW10"]"#, r#"["none"]"#))
        .unwrap();
    let shared = defender(&["sweep", s(&subset), "--out", s(&stopped)]);
    assert!(text(&shared).contains("1 complete, 0 to run"), "{}", text(&shared));
    // ... but an edited experiment is not reported from runs made under the old one: refused
    // before anything runs, naming the run and the setting.
    let edited = root.path().join("edited.toml");
    std::fs::write(&edited, smoke_text.replace("steps = 1500", "steps = 1600")).unwrap();
    let refused = defender(&["sweep", s(&edited), "--out", s(&stopped)]);
    assert!(!refused.status.success(), "{}", text(&refused));
    let message = text(&refused);
    assert!(message.contains("sac-bare-s0") && message.contains("total_steps: 1500 -> 1600"), "{message}");
    let listed = text(&defender(&["sweep", s(&edited), "--out", s(&stopped), "--list"]));
    assert_eq!(listed.matches("changed").count(), 2, "{listed}");
}

#[test]
fn bad_experiment_files_are_refused_before_anything_runs() {
    let root = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(smoke()).unwrap();
    let strategies_line = 1 + base.lines().position(|l| l.starts_with("strategies")).unwrap();
    let strategies_line = format!("line {strategies_line}");
    let cases = [
        (base.replace("[budget]", "[budget]\nsteeps = 3"), vec!["steeps", "line"]),
        (base.replace("MinDemoW5/MinDemoW10", "MinDemoW5/Nope"), vec!["Nope", strategies_line.as_str()]),
        (base.replace("seeds = [0]", "seeds = []"), vec!["grid.seeds is empty"]),
        (base.replace("\"none\", ", "\"none\", \"none\", "), vec!["appears twice"]),
    ];
    for (i, (textual, expect)) in cases.iter().enumerate() {
        let file = root.path().join(format!("bad{i}.toml"));
        std::fs::write(&file, textual).unwrap();
        let out_dir = root.path().join(format!("out{i}"));
        let out = defender(&["sweep", s(&file), "--out", s(&out_dir)]);
        let msg = text(&out);
        assert_eq!(out.status.code(), Some(1), "{msg}");
        for e in expect {
            assert!(msg.contains(e), "'{e}' missing from: {msg}");
        }
        assert!(!out_dir.exists(), "a refused experiment created its output");
    }
}

#[test]
fn output_into_a_closed_pipe_ends_quietly() {
    // `defender sweep --list | head -1`: the reader is gone before the listing is written.
    let root = tempfile::tempdir().unwrap();
    let table1 = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/table1.toml");
    let mut child = Command::new(env!("CARGO_BIN_EXE_defender"))
        .args(["sweep", s(&table1), "--out", s(root.path()), "--list"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// A run whose strategy `auto` chose is resumed, and later skipped as complete, under that
/// choice: the experiment still says `auto`, the run's `config.toml` names the strategy chosen,
/// and neither the resume nor the completeness check may read that as a changed configuration.
/// (SAC learns from step 2000 so that the run lasts seconds, however fast the machine, and the
/// SIGTERM finds it under way.)
#[test]
fn an_automatic_run_resumes_and_then_counts_as_complete_under_its_choice() {
    let root = tempfile::tempdir().unwrap();
    let experiment = root.path().join("auto.toml");
    std::fs::write(
        &experiment,
        "[grid]\nenvs = [\"InvertedDoublePendulum-v5\"]\nstrategies = [\"auto\"]\nnum_demos = [3]\nseeds = [0]\n\n\
         [budget]\nsteps = 3000\n\n[run]\neval_freq = 1000\ncheckpoint_every_episodes = 10\n\n\
         [run.sac]\nlearning_starts = 2000\n",
    )
    .unwrap();
    let out = root.path().join("sweep");
    let mut child = Command::new(env!("CARGO_BIN_EXE_defender"))
        .args(["sweep", s(&experiment), "--out", s(&out)])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let run = out.join("InvertedDoublePendulum-v5/sac-auto-n3-s0");
    let start = Instant::now();
    while !run.join("checkpoint/trainer.json").exists() && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(50));
    }
    Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert_eq!(child.wait().unwrap().code(), Some(143));
    let chosen = |dir: &Path| -> toml::Value {
        toml::from_str(&std::fs::read_to_string(dir.join("config.toml")).unwrap()).unwrap()
    };
    let before = chosen(&run);
    assert_eq!(before["defender"]["selection"]["chosen_by"].as_str(), Some("auto"));
    // No scaling set: auto compared plain and z-scored DTW, and config.toml names the one kept.
    let compared = before["defender"]["selection"]["scalings"].as_array().unwrap();
    assert_eq!(compared, &[toml::Value::from("none"), toml::Value::from("zscore")]);
    let kept = before["defender"]["cost"]["scaling"].as_str().unwrap();
    assert!(kept == "none" || kept == "zscore", "{kept}");

    let again = defender(&["sweep", s(&experiment), "--out", s(&out)]);
    assert!(again.status.success(), "{}", text(&again));
    assert!(text(&again).contains("1 resumed"), "{}", text(&again));
    assert_eq!(chosen(&run)["defender"], before["defender"], "the resumed run chose again");
    let third = defender(&["sweep", s(&experiment), "--out", s(&out)]);
    assert!(text(&third).contains("1 complete, 0 to run"), "{}", text(&third));
}

/// `--list` shows a run whose lock is held (a `defender train` writing it now) as `running`, not
/// `stopped`; an `--out` that is a regular file is refused.
#[test]
fn list_shows_a_locked_run_as_running() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("sweep");
    let dir = out.join(RUNS[0]);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("config.toml"), "").unwrap();
    let listed = text(&defender(&["sweep", s(&smoke()), "--out", s(&out), "--list"]));
    assert!(listed.contains(&format!("stopped  {}", RUNS[0])), "{listed}");
    let lock = defender_io::DirLock::try_acquire(&dir).unwrap();
    let listed = text(&defender(&["sweep", s(&smoke()), "--out", s(&out), "--list"]));
    assert!(listed.contains(&format!("running  {}", RUNS[0])), "{listed}");
    assert!(listed.contains(&format!("new      {}", RUNS[1])), "{listed}");
    drop(lock);
    let file = root.path().join("file");
    std::fs::write(&file, "x").unwrap();
    let refused = defender(&["sweep", s(&smoke()), "--out", s(&file), "--list"]);
    assert!(
        !refused.status.success() && text(&refused).contains("exists and is not a directory"),
        "{}",
        text(&refused)
    );
}

/// Flags fill what a partial `--config` leaves out; its values are checked before anything
/// runs, naming the file's section, key and value.
#[test]
fn flags_fill_a_partial_config_and_bad_values_are_named() {
    let root = tempfile::tempdir().unwrap();
    let config = root.path().join("partial.toml");
    std::fs::write(&config, "total_steps = 10\n[sac]\nbatch_size = 0\n").unwrap();
    let out = root.path().join("run");
    let no_env = text(&defender(&["train", "--config", s(&config), "--out", s(&out)]));
    assert!(no_env.contains("no `env`; add env = \"Hopper-v5\" to the file or give --env"), "{no_env}");
    let filled =
        defender(&["train", "--config", s(&config), "--env", "InvertedDoublePendulum-v5", "--out", s(&out)]);
    let message = text(&filled);
    assert!(!filled.status.success(), "{message}");
    assert!(message.contains("[sac]") && message.contains("batch_size = 0"), "{message}");
    assert!(!out.join("config.toml").exists(), "nothing was started: {message}");
}
