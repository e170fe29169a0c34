//! `defender select` and `defender train --strategy auto` through the binary: the ranking file and
//! table, clear errors, and a run that records the strategy it chose and keeps it when resumed.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::{refused, s, text};

const ENV_ID: &str = "InvertedDoublePendulum-v5";

/// Runs `defender args`, which must succeed; the run's `Output`, for the tests that read its
/// stdout alone (`common::ok` gives stdout and stderr together).
fn ok(args: &[&str]) -> Output {
    let out = common::defender(args);
    assert!(out.status.success(), "defender {args:?} failed:\n{}", text(&out));
    out
}

fn shipped_demos() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos").join(format!("{ENV_ID}.npz"))
}

/// The rank-1 row of a selection CSV, as (strategy, false_alarm_rate, crash_prevention_rate).
fn first_row(csv: &Path) -> (String, f64, f64) {
    let text = std::fs::read_to_string(csv).unwrap();
    let row: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[0], "1");
    (row[1].to_string(), row[6].parse().unwrap(), row[7].parse().unwrap())
}

#[test]
fn select_ranks_every_strategy_and_prints_the_top() {
    let dir = tempfile::tempdir().unwrap();
    let demos = shipped_demos();
    let csv = dir.path().join("sel.csv");
    let out = ok(&["select", "--demos", s(&demos), "--num-demos", "3", "--no-equal", "--out", s(&csv)]);
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.contains("rank  strategy") && stdout.contains("false_alarm"), "{stdout}");
    assert!(stdout.contains("441 strategies ranked from 3 + 3 demonstrations"), "{stdout}");
    let (best, fa, _) = first_row(&csv);
    assert!(stdout.contains(&format!("chosen: {best} (state, scaling none)")), "{stdout}");
    assert!(fa < 1.0);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "rank,strategy,safe_method,unsafe_method,mode,scaling,false_alarm_rate,crash_prevention_rate,\
         safe_allowed,unsafe_allowed,mean_lead,demo_score,ablation_score,score,eligible"
    );
    assert_eq!(lines.count(), 441);
    assert!(!text.contains("Equal"));
    // Deterministic through the binary too.
    let again = dir.path().join("again.csv");
    ok(&["select", "--demos", s(&demos), "--num-demos", "3", "--no-equal", "--out", s(&again)]);
    assert_eq!(text, std::fs::read_to_string(&again).unwrap());
    // z-scored features are another cost: another ranking, of the same strategies.
    let zscore = dir.path().join("zscore.csv");
    #[rustfmt::skip]
    ok(&["select", "--demos", s(&demos), "--num-demos", "3", "--no-equal", "--scaling", "zscore", "--out", s(&zscore)]);
    let z = std::fs::read_to_string(&zscore).unwrap();
    assert_eq!(z.lines().count(), 442);
    assert_ne!(z, text, "z-scoring changed no cost");
    // --scaling auto ranks both together: each one's rows, in each one's order.
    let both = dir.path().join("both.csv");
    #[rustfmt::skip]
    ok(&["select", "--demos", s(&demos), "--num-demos", "3", "--no-equal", "--scaling", "auto", "--out", s(&both)]);
    let both = std::fs::read_to_string(&both).unwrap();
    assert_eq!(both.lines().count(), 1 + 2 * 441);
    let strategies_under = |csv: &str, scaling: &str| -> Vec<String> {
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|r| r[5] == scaling)
            .map(|r| r[1..].join(","))
            .collect()
    };
    assert_eq!(strategies_under(&both, "none"), strategies_under(&text, "none"));
    assert_eq!(strategies_under(&both, "zscore"), strategies_under(&z, "zscore"));
    // --help explains the criterion.
    let help = String::from_utf8(ok(&["select", "--help"]).stdout).unwrap();
    for word in ["Leave-one-out", "false_alarm_rate", "crash_prevention_rate", "demo_score", "--episodes"] {
        assert!(help.contains(word), "--help lacks {word}");
    }
}

#[test]
fn select_refuses_bad_input_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let demos = shipped_demos();
    let csv = dir.path().join("sel.csv");
    refused(
        &["select", "--demos", s(&demos), "--num-demos", "1", "--out", s(&csv)],
        &["the safe group has 1 demonstration", "at least 2 per group"],
    );
    // One group only.
    let set = defender::EpisodeSet::load(&demos).unwrap();
    let mut safe_only = defender::EpisodeSet::new(set.obs_dim(), set.act_dim(), set.meta().clone()).unwrap();
    for e in set.safe().take(3) {
        safe_only.push_episode(e.obs, e.act, e.rew, false).unwrap();
    }
    let path = dir.path().join("safe_only.npz");
    safe_only.save(&path).unwrap();
    refused(&["select", "--demos", s(&path), "--out", s(&csv)], &["unsafe group is empty"]);
    refused(
        &["select", "--demos", s(&demos), "--strategies", "MinBoth/Nope", "--out", s(&csv)],
        &["unknown strategy 'MinBoth/Nope'"],
    );
    refused(
        &["select", "--demos", s(&demos), "--max-false-alarm", "nan", "--out", s(&csv)],
        &["max_false_alarm must be a rate in [0, 1], got NaN"],
    );
    // A usage error (clap's exit code 2) that lists the values.
    let usage = common::command()
        .args(["select", "--demos", s(&demos), "--scaling", "minmax", "--out", s(&csv)])
        .output()
        .unwrap();
    assert_eq!(usage.status.code(), Some(2));
    assert!(text(&usage).contains("invalid value 'minmax'") && text(&usage).contains("none, zscore, auto"));
    assert!(!csv.exists());
}

/// Waits until `path` exists (at most a minute).
fn wait_for(path: &Path) {
    let start = Instant::now();
    while !path.exists() && start.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn train_auto_records_the_choice_and_keeps_it_when_resumed() {
    let dir = tempfile::tempdir().unwrap();
    let demos = shipped_demos();
    let csv = dir.path().join("sel.csv");
    // What `--strategy auto` compares when no scaling is set: plain and z-scored DTW.
    #[rustfmt::skip]
    ok(&["select", "--demos", s(&demos), "--num-demos", "3", "--no-equal", "--scaling", "auto", "--out", s(&csv)]);
    let (best, fa, cp) = first_row(&csv);
    let scaling =
        std::fs::read_to_string(&csv).unwrap().lines().nth(1).unwrap().split(',').nth(5).unwrap().to_string();

    let run = dir.path().join("run");
    // SPEC's profile: the report row below is plain SAC's (the default profile's agent also
    // learns from the demonstrations, a row of its own).
    let args = [
        "train",
        "--profile",
        "spec",
        "--env",
        ENV_ID,
        "--strategy",
        "auto",
        "--num-demos",
        "3",
        "--steps",
        "2500",
        "--checkpoint-every",
        "40",
        "--seed",
        "1",
        "--out",
        s(&run),
    ];
    let mut child = common::command().args(args).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    wait_for(&run.join("summary.json"));
    std::thread::sleep(Duration::from_millis(400));
    let status = Command::new("kill").args(["-s", "TERM", &child.id().to_string()]).status().unwrap();
    assert!(status.success());
    let code = child.wait().unwrap().code();
    assert!(code == Some(143) || code == Some(0), "{code:?}");

    // config.toml: the chosen strategy (the one `defender select` ranks first) and its record.
    let config: toml::Value =
        toml::from_str(&std::fs::read_to_string(run.join("config.toml")).unwrap()).unwrap();
    let section = &config["defender"];
    assert_eq!(section["strategy"].as_str(), Some(best.as_str()));
    let record = &section["selection"];
    assert_eq!(record["chosen_by"].as_str(), Some("auto"));
    assert_eq!(record["candidates"].as_integer(), Some(441));
    assert_eq!(record["equal"].as_bool(), Some(false));
    assert_eq!(record["max_false_alarm"].as_float(), Some(0.1));
    assert_eq!(record["safe_demos"].as_integer(), Some(3));
    assert_eq!(record["false_alarm_rate"].as_float(), Some(fa));
    assert_eq!(record["crash_prevention_rate"].as_float(), Some(cp));
    assert_eq!(section["cost"]["scaling"].as_str(), Some(scaling.as_str()));
    assert_eq!(
        record["scalings"].as_array().unwrap(),
        &[toml::Value::from("none"), toml::Value::from("zscore")]
    );

    // Resumed with the same command line: the choice is kept, nothing is selected again.
    let mut resume: Vec<&str> = args.to_vec();
    resume.push("--resume");
    let out = ok(&resume);
    let msg = text(&out);
    assert!(!msg.contains("strategy auto: chose"), "the resumed run selected again:\n{msg}");
    let config2: toml::Value =
        toml::from_str(&std::fs::read_to_string(run.join("config.toml")).unwrap()).unwrap();
    assert_eq!(config2["defender"], config["defender"]);

    // summary.json: the strategy and the same record; the report reads the run.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["complete"], serde_json::Value::Bool(true));
    assert_eq!(summary["strategy"].as_str(), Some(best.as_str()));
    assert_eq!(summary["selection"]["chosen_by"].as_str(), Some("auto"));
    assert_eq!(summary["selection"]["crash_prevention_rate"].as_f64(), Some(cp));
    let report = String::from_utf8(ok(&["report", s(&run)]).stdout).unwrap();
    assert!(
        report.contains("seed 1: strategy chosen by --strategy auto, scaling chosen among none, zscore (held-out demonstrations:"),
        "{report}"
    );
    // The table names the choice as automatic, in a row of its own.
    let (safe, unsafe_) = best.split_once('/').unwrap();
    let label = if scaling == "zscore" { "auto, z-score" } else { "auto" };
    let row = format!("| SAC       | {label}: {safe}");
    assert!(report.contains(&row) && report.contains(unsafe_), "{report}");
    let run_loaded = defender_report::Run::load(&run).unwrap();
    assert!(run_loaded.config.filter.as_ref().unwrap().auto);
    let selection = run_loaded.summary.selection.unwrap();
    assert_eq!((selection.false_alarm_rate, selection.crash_prevention_rate), (fa, cp));

    // A configuration file with strategy = "auto" works the same way.
    let file = dir.path().join("auto.toml");
    std::fs::write(
        &file,
        format!(
            "env = \"{ENV_ID}\"\nalgo = \"sac\"\ntotal_steps = 200\n\n[defender]\nstrategy = \"auto\"\nnum_demos = 3\n"
        ),
    )
    .unwrap();
    let run2 = dir.path().join("run2");
    let recorded = dir.path().join("rec.npz");
    ok(&["train", "--config", s(&file), "--out", s(&run2), "--record-episodes", s(&recorded)]);
    let config3: toml::Value =
        toml::from_str(&std::fs::read_to_string(run2.join("config.toml")).unwrap()).unwrap();
    assert_eq!(config3["defender"]["strategy"].as_str(), Some(best.as_str()));
    assert_eq!(config3["defender"]["selection"]["chosen_by"].as_str(), Some("auto"));

    // The recorded episodes of that run give the ablation score its column.
    let with_episodes = dir.path().join("sel_ep.csv");
    let out = ok(&[
        "select",
        "--demos",
        s(&demos),
        "--num-demos",
        "3",
        "--no-equal",
        "--episodes",
        s(&recorded),
        "--out",
        s(&with_episodes),
    ]);
    assert!(String::from_utf8(out.stdout).unwrap().contains("recorded episodes"));
    let text = std::fs::read_to_string(&with_episodes).unwrap();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (demo, ablation, score): (f64, f64, f64) =
            (f[11].parse().unwrap(), f[12].parse().unwrap(), f[13].parse().unwrap());
        assert!((0.0..=1.0).contains(&ablation), "{line}");
        assert_eq!(score, demo * ablation, "{line}");
    }
}

/// `--profile authors` ranks under the authors' cost (FastDTW L1 over the last 20 steps, one
/// element per transition, ties executed): it runs on the shipped set, and its figures are not
/// SPEC's.
#[test]
fn select_under_the_authors_profile_ranks_with_their_cost() {
    let tmp = tempfile::tempdir().unwrap();
    let demos = shipped_demos();
    let args = |profile: &str, out: &Path| {
        ok(&[
            "select",
            "--demos",
            s(&demos),
            "--num-demos",
            "8",
            "--strategies",
            "MeanBothW5/MeanBothW5,MinDemoW5/MinDemoW10",
            "--profile",
            profile,
            "--out",
            s(out),
        ])
    };
    let (spec, authors) = (tmp.path().join("spec.csv"), tmp.path().join("authors.csv"));
    args("spec", &spec);
    args("authors", &authors);
    let (a, b) = (std::fs::read_to_string(&spec).unwrap(), std::fs::read_to_string(&authors).unwrap());
    assert_eq!(a.lines().count(), 3);
    assert_eq!(b.lines().count(), 3);
    assert_ne!(a, b, "the authors' cost ranks with other figures");
}
