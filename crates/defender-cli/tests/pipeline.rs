//! End to end on tiny budgets, through the built binary: train bare and with DEFENDER (recording
//! the episodes), ablate the recording, report the runs; and check that the numbers in the files
//! agree with each other.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;

const ENV_ID: &str = "InvertedDoublePendulum-v5";

fn defender(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_defender")).args(args).output().expect("run defender")
}

fn ok(args: &[&str]) -> String {
    let out = defender(args);
    assert!(
        out.status.success(),
        "defender {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn shipped_demos() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos").join(format!("{ENV_ID}.npz"))
}

struct Metrics {
    rows: Vec<(u64, u64, f64, u64, String)>,
}

fn read_metrics(dir: &Path) -> Metrics {
    let text = std::fs::read_to_string(dir.join("metrics.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "episode,total_steps,return,length,outcome,wall_seconds,cost");
    let rows = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 7, "{l}");
            // The crash cost of the three tasks: 1 for a crashed episode, 0 otherwise.
            assert_eq!(f[6], if f[4] == "crashed" { "1" } else { "0" }, "{l}");
            (
                f[0].parse().unwrap(),
                f[1].parse().unwrap(),
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
                f[4].into(),
            )
        })
        .collect();
    Metrics { rows }
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// The files of one run agree: episodes are numbered in order, steps add up, the summary's
/// counts are those of metrics.csv, and Acc Reward is the last evaluation.
fn check_consistent(dir: &Path, steps: u64) -> Metrics {
    let m = read_metrics(dir);
    let s = summary(dir);
    assert!(!m.rows.is_empty());
    let mut total = 0;
    for (i, (episode, total_steps, _ret, length, outcome)) in m.rows.iter().enumerate() {
        assert_eq!(*episode, i as u64);
        total += length;
        assert_eq!(*total_steps, total, "total_steps adds the lengths");
        assert!(["crashed", "filtered", "truncated"].contains(&outcome.as_str()), "{outcome}");
    }
    assert!(total <= steps);
    assert_eq!(s["steps"].as_u64().unwrap(), steps);
    assert_eq!(s["episodes"].as_u64().unwrap(), m.rows.len() as u64);
    assert_eq!(s["complete"], serde_json::Value::Bool(true));
    let n = m.rows.len() as f64;
    let count = |o: &str| m.rows.iter().filter(|r| r.4 == o).count() as f64;
    assert!((s["crash_pct"].as_f64().unwrap() - 100.0 * count("crashed") / n).abs() < 1e-9);
    assert!((s["filtered_pct"].as_f64().unwrap() - 100.0 * count("filtered") / n).abs() < 1e-9);
    assert_eq!(s["filtered_steps"].as_u64().unwrap() as f64, count("filtered"));
    let eval = std::fs::read_to_string(dir.join("eval.csv")).unwrap();
    let last = eval.lines().last().unwrap();
    let acc: f64 = last.split(',').nth(1).unwrap().parse().unwrap();
    assert!((s["acc_reward"].as_f64().unwrap() - acc).abs() < 1e-9);
    assert!(dir.join("config.toml").is_file() && dir.join("actor.safetensors").is_file());
    assert!(dir.join("checkpoint").join("trainer.json").is_file());
    m
}

#[test]
fn train_ablate_report() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let demos = shipped_demos();
    let demos = demos.to_str().unwrap();
    let steps = 1200u64;
    let steps_s = steps.to_string();
    let bare = root.join("runs/bare");
    let def = root.join("runs/defender");
    let recorded = root.join("episodes.npz");
    let common = ["train", "--env", ENV_ID, "--steps", &steps_s, "--seed", "3"];

    let out = ok(&[
        &common[..],
        &["--out", bare.to_str().unwrap(), "--record-episodes", recorded.to_str().unwrap()],
    ]
    .concat());
    assert!(out.contains("bare seed 3"), "{out}");
    let bare_m = check_consistent(&bare, steps);
    assert!(bare_m.rows.iter().all(|r| r.4 != "filtered"), "a bare run filters nothing");

    let defended =
        [&common[..], &["--strategy", "MeanDemoW5/MeanDemoW10", "--demos", demos, "--num-demos", "5"]]
            .concat();
    let out = ok(&[&defended[..], &["--out", def.to_str().unwrap()]].concat());
    assert!(out.contains("DEFENDER MeanDemoW5/MeanDemoW10"), "{out}");
    let def_m = check_consistent(&def, steps);
    assert!(def_m.rows.iter().any(|r| r.4 == "filtered"), "an untrained agent gets filtered");
    let config = std::fs::read_to_string(def.join("config.toml")).unwrap();
    let config: toml::Value = toml::from_str(&config).unwrap();
    let section = &config["defender"];
    assert_eq!(section["strategy"].as_str(), Some("MeanDemoW5/MeanDemoW10"));
    assert_eq!(section["num_demos"].as_integer(), Some(5));
    let r_task = section["r_task"].as_float().expect("R_task is written");
    // A filtered episode ends with R_task as its last reward; its return includes it.
    assert!(r_task.is_finite());

    // The dynamics model on its own thread: the same run, episode for episode.
    let threaded = root.join("threaded");
    ok(&[&defended[..], &["--dynamics-thread", "--out", threaded.to_str().unwrap()]].concat());
    assert_eq!(check_consistent(&threaded, steps).rows, def_m.rows, "--dynamics-thread changed the run");
    let config: toml::Value =
        toml::from_str(&std::fs::read_to_string(threaded.join("config.toml")).unwrap()).unwrap();
    assert_eq!(config["defender"]["dynamics"]["background"].as_bool(), Some(true));

    // The recorded episodes of the bare run are an episode set numpy-compatible tools read.
    let scores = root.join("scores.csv");
    let out = ok(&[
        "ablate",
        "--demos",
        demos,
        "--episodes",
        recorded.to_str().unwrap(),
        "--num-demos",
        "5",
        "--strategies",
        "MeanDemoW5/MeanDemoW10,MinBoth/MinTrajW10,MaxBothW5/MinDemoW10",
        "--out",
        scores.to_str().unwrap(),
    ]);
    assert!(out.contains("3 strategies ranked"), "{out}");
    let csv = std::fs::read_to_string(&scores).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "rank,strategy,safe_method,unsafe_method,mode,mean_ratio,safe_rate,score"
    );
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(String::from).collect()).collect();
    assert_eq!(rows.len(), 3);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r[0], (i + 1).to_string());
        let (ratio, rate, score): (f64, f64, f64) =
            (r[5].parse().unwrap(), r[6].parse().unwrap(), r[7].parse().unwrap());
        assert!((0.0..=1.0).contains(&ratio) && (0.0..=1.0).contains(&rate));
        assert!((score - ratio * rate).abs() < 1e-12, "score = mean_ratio x safe_rate");
        assert_eq!(r[4], "state");
    }
    let scores_sorted: Vec<f64> = rows.iter().map(|r| r[7].parse().unwrap()).collect();
    assert!(scores_sorted.windows(2).all(|w| w[0] >= w[1]), "ranked by score");

    // The screen replays the same episodes in order: SPEC's filter ("spec") leaves exactly the
    // crashes the ablation counts as unsafe; a margin near 1 catches nothing.
    let screened = root.join("screen.csv");
    let out = ok(&[
        "screen",
        "--demos",
        demos,
        "--episodes",
        recorded.to_str().unwrap(),
        "--num-demos",
        "5",
        "--strategy",
        "MeanDemoW5/MeanDemoW10",
        "--variant",
        "",
        "--variant",
        "margin = 0.999",
        "--variant",
        "budget = { share = 0.5, episodes = 10 }\nown_episodes = { keep = 3 }",
        "--out",
        screened.to_str().unwrap(),
    ]);
    assert!(out.contains("3 lines"), "{out}");
    let csv = std::fs::read_to_string(&screened).unwrap();
    let lines: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(lines.iter().map(|l| l[2]).collect::<Vec<_>>(), ["spec", "margin0.999", "budget0.5+own3"]);
    let ablated = rows.iter().find(|r| r[1] == "MeanDemoW5/MeanDemoW10").unwrap();
    let safe_rate: f64 = ablated[6].parse().unwrap();
    let crash_pct: f64 = lines[0][8].parse().unwrap();
    assert!((crash_pct - 100.0 * (1.0 - safe_rate)).abs() < 0.01, "{crash_pct} vs safe_rate {safe_rate}");
    assert!(lines[1][5].parse::<f64>().unwrap() <= lines[0][5].parse::<f64>().unwrap());
    let bad = defender(&[
        "screen",
        "--demos",
        demos,
        "--episodes",
        recorded.to_str().unwrap(),
        "--strategy",
        "MeanDemoW5/MeanDemoW10",
        "--variant",
        "margin = 1.5",
        "--out",
        screened.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && err.contains("margin = 1.5"), "{err}");

    // The report reads both runs: one bare row and one DEFENDER row, with % Time against the bare run.
    let table = ok(&["report", root.join("runs").to_str().unwrap(), "--format", "csv"]);
    assert_eq!(table.lines().count(), 3, "{table}");
    assert!(table.contains("MeanDemoW5/MeanDemoW10") || table.contains("MeanDemoW5"), "{table}");
}

#[test]
fn errors_name_what_to_fix() {
    let tmp = tempfile::tempdir().unwrap();
    let out_dir = tmp.path().join("x");
    let out = out_dir.to_str().unwrap();
    let cases: [(&[&str], &str); 5] = [
        (&["train", "--env", "Nope-v0", "--steps", "10", "--out", out], "known ids"),
        (&["train", "--env", ENV_ID, "--out", out], "--steps"),
        (&["train", "--env", ENV_ID, "--steps", "10", "--strategy", "MeanDemo/X", "--out", out], "strategy"),
        (
            &[
                "train",
                "--env",
                ENV_ID,
                "--steps",
                "10",
                "--strategy",
                "MinBoth/MinBoth",
                "--demos",
                "/nonexistent.npz",
                "--out",
                out,
            ],
            "/nonexistent.npz",
        ),
        (&["demos", "collect", "--env", ENV_ID, "--max-steps", "200", "--out", out], "raise --max-steps"),
    ];
    for (args, expected) in cases {
        let o = defender(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(err.contains(expected), "{args:?}: '{expected}' not in: {err}");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    }
    // A config file with an unknown key is refused with its name.
    let cfg = tmp.path().join("c.toml");
    std::fs::write(&cfg, "env = \"Hopper-v5\"\nalgo = \"sac\"\ntotal_steps = 10\nlerning_rate = 1\n")
        .unwrap();
    let o = defender(&["train", "--config", cfg.to_str().unwrap(), "--out", out]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("lerning_rate"), "{err}");
}

/// The paper's whole chain on a tiny budget: collect demonstrations by training SAC (horizon 20,
/// 200 random steps), train with DEFENDER on them while recording, ablate with them, report.
#[test]
fn collect_train_ablate_report() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let demos = root.join("demos.npz");
    let demos_s = demos.to_str().unwrap();
    let out = ok(&[
        "demos",
        "collect",
        "--env",
        ENV_ID,
        "--safe",
        "3",
        "--unsafe",
        "3",
        "--learning-starts",
        "200",
        "--max-episode-steps",
        "20",
        "--max-steps",
        "5000",
        "--seed",
        "1",
        "--out",
        demos_s,
    ]);
    assert!(out.contains("3 safe and 3 unsafe demonstrations"), "{out}");
    let set = defender::EpisodeSet::load(&demos).unwrap();
    assert_eq!(set.group_sizes(), (3, 3));
    for e in set.episodes() {
        let n = e.rew.len();
        assert!(
            if e.crashed { n < 20 } else { n == 20 },
            "crashed {} with {n} steps (horizon 20)",
            e.crashed
        );
    }
    let meta = &set.meta().extra;
    assert_eq!(meta["learning_starts"], 200);
    let sources: Vec<u64> =
        meta["source_training_episodes"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
    assert_eq!(sources.len(), 6);
    assert!(sources.windows(2).all(|w| w[0] < w[1]), "in training order: {sources:?}");
    // Nothing was recorded before SAC's first update: the first candidate comes after an episode
    // that ended past step 200, i.e. at least 10 episodes of at most 20 steps.
    assert!(sources[0] >= 10, "{sources:?}");

    let run = root.join("runs/defender");
    let recorded = root.join("episodes.npz");
    let steps = 600u64;
    ok(&[
        "train",
        "--env",
        ENV_ID,
        "--steps",
        &steps.to_string(),
        "--strategy",
        "MeanBothW5/MeanBothW5",
        "--demos",
        demos_s,
        "--record-episodes",
        recorded.to_str().unwrap(),
        "--out",
        run.to_str().unwrap(),
    ]);
    let m = check_consistent(&run, steps);
    let episodes = defender::EpisodeSet::load(&recorded).unwrap();
    assert_eq!(episodes.len(), m.rows.len(), "one recorded episode per metrics.csv row");

    let scores = root.join("scores.csv");
    let out = ok(&[
        "ablate",
        "--demos",
        demos_s,
        "--episodes",
        recorded.to_str().unwrap(),
        "--strategies",
        "MeanBothW5/MeanBothW5,MinBoth/MinBoth",
        "--out",
        scores.to_str().unwrap(),
    ]);
    assert!(out.contains("2 strategies ranked"), "{out}");
    let table = ok(&["report", root.join("runs").to_str().unwrap()]);
    assert!(table.contains("MeanBothW5"), "{table}");

    // Tasks ablated apart and ranked together with --combine give the joint ablation's file.
    let strategies = "MeanBothW5/MeanBothW5,MinBoth/MinBoth";
    let (rec, scores_s) = (recorded.to_str().unwrap(), scores.to_str().unwrap());
    let second = root.join("second.csv");
    ok(&[
        "ablate",
        "--demos",
        demos_s,
        "--episodes",
        demos_s,
        "--strategies",
        strategies,
        "--out",
        second.to_str().unwrap(),
    ]);
    let joint = root.join("joint.csv");
    #[rustfmt::skip]
    ok(&["ablate", "--demos", demos_s, "--episodes", rec, "--demos", demos_s, "--episodes", demos_s,
         "--strategies", strategies, "--out", joint.to_str().unwrap()]);
    let combined = root.join("combined.csv");
    let out =
        ok(&["ablate", "--combine", scores_s, second.to_str().unwrap(), "--out", combined.to_str().unwrap()]);
    assert!(out.contains("2 strategies ranked over 2 tasks"), "{out}");
    let read = |p: &Path| std::fs::read_to_string(p).unwrap();
    assert_eq!(read(&combined), read(&joint));
    // Rankings of different strategies do not combine; the message says what must match.
    let other = root.join("other.csv");
    ok(&[
        "ablate",
        "--demos",
        demos_s,
        "--episodes",
        rec,
        "--strategies",
        "MinBoth/MinBoth",
        "--out",
        other.to_str().unwrap(),
    ]);
    let refused = defender(&[
        "ablate",
        "--combine",
        scores_s,
        other.to_str().unwrap(),
        "--out",
        combined.to_str().unwrap(),
    ]);
    assert!(!refused.status.success());
    let message = String::from_utf8_lossy(&refused.stderr);
    assert!(message.contains("the same strategies in the same mode"), "{message}");
    assert!(!defender(&["ablate", "--combine", scores_s, "--out", "x.csv"]).status.success(), "one file");
    // The same ranking twice (by name, or a copy) would count its runs twice: refused, naming it.
    let copy = root.join("copy.csv");
    std::fs::copy(&scores, &copy).unwrap();
    for repeat in [scores_s, copy.to_str().unwrap()] {
        let refused =
            defender(&["ablate", "--combine", scores_s, repeat, "--out", combined.to_str().unwrap()]);
        let message = String::from_utf8_lossy(&refused.stderr);
        assert!(!refused.status.success() && message.contains("is given twice"), "{message}");
    }
    // An --out that cannot be written is refused before any scoring.
    let nowhere = root.join("scores.csv").join("x.csv");
    let refused =
        defender(&["ablate", "--demos", demos_s, "--episodes", rec, "--out", nowhere.to_str().unwrap()]);
    let message = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && message.contains("--out"), "{message}");
    assert!(!message.contains("episodes scored"), "{message}");
}

/// `defender train` trains the dynamics model on its own thread when the networks have two
/// threads, inline with one (`setup::model_on_own_thread`): a matter of speed only. The same
/// DEFENDER run both ways writes the same files (but the wall-clock column).
#[test]
fn one_or_two_threads_and_the_model_on_its_own_thread_change_nothing_a_run_writes() {
    let root = tempfile::tempdir().unwrap();
    let config = root.path().join("run.toml");
    std::fs::write(&config, format!("env = \"{ENV_ID}\"\nalgo = \"sac\"\n[sac]\nlearning_starts = 300\n"))
        .unwrap();
    let run = |threads: &str| {
        let out = root.path().join(format!("threads-{threads}"));
        let args = [
            "train",
            "--config",
            config.to_str().unwrap(),
            "--strategy",
            "MinDemoW5/MinDemoW10",
            "--steps",
            "2000",
            "--eval-freq",
            "1000",
            "--seed",
            "5",
            "--out",
            out.to_str().unwrap(),
        ];
        let done = Command::new(env!("CARGO_BIN_EXE_defender"))
            .args(args)
            .env("DEFENDER_NN_THREADS", threads)
            .output()
            .expect("run defender");
        assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
        let whole = |name: &str| std::fs::read_to_string(out.join(name)).unwrap();
        (common::metrics_without_wall(&out), whole("eval.csv"), whole("updates.csv"), whole("dynamics.csv"))
    };
    let (inline, own_thread) = (run("1"), run("2"));
    assert!(inline.2.lines().count() >= 3 && inline.3.lines().count() >= 3, "no rows: {inline:?}");
    assert_eq!(inline.0, own_thread.0, "metrics.csv");
    assert_eq!(inline.1, own_thread.1, "eval.csv");
    assert_eq!(inline.2, own_thread.2, "updates.csv");
    assert_eq!(inline.3, own_thread.3, "dynamics.csv");
}
