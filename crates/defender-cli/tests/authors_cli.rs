//! The authors' protocol on the command line (docs/SPEC.md, section 10): `defender ablate
//! --profile authors` against the independent reference of `tools/golden/authors_protocol_golden.py`,
//! its first 500 episodes and its refusals; `defender demos collect --profile authors`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use defender::EpisodeSet;

mod common;

use common::{ok, s, text};

/// Runs `defender args`, which must fail (with any exit code, clap's usage errors too), a message
/// holding every `expect`, and no panic. Unlike `common::refused`, the exit code may be other than 1.
fn refused(args: &[&str], expect: &[&str]) {
    let out = common::defender(args);
    let msg = text(&out);
    assert!(!out.status.success(), "defender {args:?} should fail:\n{msg}");
    for e in expect {
        assert!(msg.contains(e), "defender {args:?}: message lacks '{e}':\n{msg}");
    }
    assert!(!msg.contains("panicked"), "{msg}");
}

fn golden(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../defender/tests/data/authors_protocol").join(name)
}

/// `strategy -> (mean_ratio, safe_rate, score)` of a CSV whose columns name them.
fn scores(path: &Path) -> HashMap<String, [f64; 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let (st, r, sr, sc) = (col("strategy"), col("mean_ratio"), col("safe_rate"), col("score"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let num = |k: usize| f[k].parse::<f64>().unwrap();
            (f[st].to_string(), [num(r), num(sr), num(sc)])
        })
        .collect()
}

fn same_scores(got: &Path, want: &Path) {
    let (got, want) = (scores(got), scores(want));
    assert_eq!(got.len(), 576);
    for (strategy, w) in &want {
        let g = got[strategy];
        for (a, b) in g.iter().zip(w) {
            assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0), "{strategy}: {g:?} against {w:?}");
        }
    }
}

#[test]
fn ablate_profile_authors_matches_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let (demos, episodes) = (golden("demos.npz"), golden("episodes.npz"));
    let out = dir.path().join("authors.csv");
    let base = ["ablate", "--profile", "authors", "--horizon", "25", "--demos", s(&demos), "--episodes"];
    let printed = ok(&[&base[..], &[s(&episodes), "--out", s(&out)]].concat());
    assert!(printed.contains("576 strategies ranked by the authors' score (horizon 25)"), "{printed}");
    same_scores(&out, &golden("scores-state.csv"));
    let csv = std::fs::read_to_string(&out).unwrap();
    assert!(
        csv.starts_with("rank,strategy,safe_method,unsafe_method,mode,mean_ratio,safe_rate,score,scoring\n")
    );
    assert!(csv.lines().skip(1).all(|l| l.ends_with(",authors")));

    // --num-demos: per group, the first 3 in the authors' diversity order.
    let diverse = dir.path().join("diverse.csv");
    ok(&[&base[..], &[s(&episodes), "--num-demos", "3", "--out", s(&diverse)]].concat());
    same_scores(&diverse, &golden("scores-state-diverse3.csv"));

    // The SPEC ablation of the same files is another score (and has no scoring column).
    let spec = dir.path().join("spec.csv");
    ok(&["ablate", "--demos", s(&demos), "--episodes", s(&episodes), "--out", s(&spec)]);
    assert!(!std::fs::read_to_string(&spec).unwrap().contains("scoring"));
    assert_ne!(scores(&spec)["MinDemoW5/MinBothW5"], scores(&out)["MinDemoW5/MinBothW5"]);

    // Refusals, each naming what to change.
    let two =
        [&base[..], &[s(&episodes), "--demos", s(&demos), "--episodes", s(&episodes), "--out", "x.csv"]]
            .concat();
    refused(&two, &["one task at a time"]);
    refused(&["ablate", "--combine", s(&out), s(&spec), "--out", "x.csv"], &["authors score", "scoring"]);
    refused(
        &[
            "ablate",
            "--profile",
            "authors",
            "--combine",
            s(&spec),
            s(&spec2(&dir, &demos, &episodes)),
            "--out",
            "x.csv",
        ],
        &["SPEC section 7's scores", "--profile authors first"],
    );
    // Files of the authors' score combine into a file of that score: the mean over the files.
    let both = dir.path().join("both.csv");
    ok(&["ablate", "--combine", s(&out), s(&diverse), "--out", s(&both)]);
    let both_csv = std::fs::read_to_string(&both).unwrap();
    assert!(both_csv.lines().skip(1).all(|l| l.ends_with(",authors")), "{both_csv}");
    let (a, b, c) = (scores(&out), scores(&diverse), scores(&both));
    assert_eq!(c.len(), 576);
    for (strategy, got) in &c {
        for k in 0..3 {
            let want = (a[strategy][k] + b[strategy][k]) / 2.0;
            assert!(
                (got[k] - want).abs() <= 1e-12,
                "{strategy}: {got:?}, want the mean of {:?} and {:?}",
                a[strategy],
                b[strategy]
            );
        }
    }
    refused(
        &["ablate", "--horizon", "25", "--demos", s(&demos), "--episodes", s(&episodes), "--out", "x.csv"],
        &["--horizon is for --profile authors"],
    );
    // The golden files name no registered task: the horizon must be given.
    refused(
        &[
            "ablate",
            "--profile",
            "authors",
            "--demos",
            s(&demos),
            "--episodes",
            s(&episodes),
            "--out",
            "x.csv",
        ],
        &["--horizon", "Golden-v0"],
    );
}

#[test]
fn ablate_profile_authors_scores_the_first_500_episodes() {
    let dir = tempfile::tempdir().unwrap();
    let source = EpisodeSet::load(golden("episodes.npz")).unwrap();
    // 520 episodes: the golden ones cycled; past the 500th, one-step episodes, which would move
    // every score (each counts as crashed and p = 1 or 0).
    let mut long = EpisodeSet::new(source.obs_dim(), source.act_dim(), source.meta().clone()).unwrap();
    for i in 0..520 {
        let e = source.episode(i % source.len());
        if i < 500 {
            long.push_episode(e.obs, e.act, e.rew, e.crashed).unwrap();
        } else {
            let (o, a) = (source.obs_dim(), source.act_dim());
            long.push_episode(&e.obs[..2 * o], &e.act[..a], &e.rew[..1], true).unwrap();
        }
    }
    let first = long.reordered(&(0..500).collect::<Vec<_>>()).unwrap();
    let (long_path, first_path) = (dir.path().join("long.npz"), dir.path().join("first.npz"));
    long.save(&long_path).unwrap();
    first.save(&first_path).unwrap();
    let demos = golden("demos.npz");
    let run = |episodes: &Path, out: &Path| {
        ok(&[
            "ablate",
            "--profile",
            "authors",
            "--horizon",
            "25",
            "--demos",
            s(&demos),
            "--episodes",
            s(episodes),
            "--strategies",
            "MinDemoW5/MinBothW5,MeanBothW5/MeanBothW5,MaxTrajW10/MinEqual",
            "--out",
            s(out),
        ])
    };
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    let printed = run(&long_path, &a);
    assert!(printed.contains("scoring its first 500 of 520 recorded episodes"), "{printed}");
    run(&first_path, &b);
    assert_eq!(std::fs::read_to_string(&a).unwrap(), std::fs::read_to_string(&b).unwrap());
    // Scored by SPEC section 7, all 520 count (a control: the extra episodes do move the scores).
    let (c, d) = (dir.path().join("c.csv"), dir.path().join("d.csv"));
    for (episodes, out) in [(&long_path, &c), (&first_path, &d)] {
        ok(&[
            "ablate",
            "--demos",
            s(&demos),
            "--episodes",
            s(episodes),
            "--strategies",
            "MinDemoW5/MinBothW5",
            "--out",
            s(out),
        ]);
    }
    assert_ne!(std::fs::read_to_string(&c).unwrap(), std::fs::read_to_string(&d).unwrap());
}

#[test]
fn demos_collect_profile_authors_keeps_every_demonstration_in_diversity_order() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("idp.npz");
    // A 6-step horizon, so that the untrained policy sometimes lasts it: 100 episodes, a
    // demonstration after every 5th.
    let args = [
        "demos",
        "collect",
        "--profile",
        "authors",
        "--env",
        "InvertedDoublePendulum-v5",
        "--max-episode-steps",
        "6",
        "--episodes",
        "100",
        "--demonstrate-every",
        "5",
        "--seed",
        "1",
        "--out",
        s(&out),
    ];
    let printed = ok(&args);
    assert!(printed.contains("over 100 training episodes"), "{printed}");
    let set = EpisodeSet::load(&out).unwrap();
    assert_eq!(set.len(), 20);
    let (safe, unsafe_) = set.group_sizes();
    assert!(safe >= 1 && unsafe_ >= 1, "({safe}, {unsafe_})");
    // Safe = lasted the horizon; the safe group first.
    for e in set.episodes() {
        assert_eq!(e.crashed, e.len() < 6, "episode {} of {} steps", e.index, e.len());
        assert_eq!(e.crashed, e.index >= safe);
    }
    let meta = &set.meta().extra;
    assert_eq!(meta["collection"], "authors");
    let mut sources: Vec<u64> =
        meta["source_training_episodes"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
    sources.sort_unstable();
    assert_eq!(sources, (1..=20).map(|k| 5 * k).collect::<Vec<u64>>());
    assert_eq!(meta["r_task"].as_f64().unwrap(), f64::from(set.min_reward().unwrap()));
    // Each group is already in the diversity order: choosing again keeps it.
    let (s_order, u_order) = defender::diversity::diverse_order(&set, 20, defender::Mode::State).unwrap();
    assert_eq!((s_order, u_order), ((0..safe).collect(), (0..unsafe_).collect()));
    // One seed, one file.
    let again = dir.path().join("again.npz");
    let mut repeat = args.to_vec();
    let at = repeat.len() - 1;
    repeat[at] = s(&again);
    ok(&repeat);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&again).unwrap());

    // The file trains a profile run, the first N of each group filtering.
    let run = dir.path().join("run");
    ok(&[
        "train",
        "--env",
        "InvertedDoublePendulum-v5",
        "--profile",
        "authors",
        "--strategy",
        "MeanBothW5/MeanBothW5",
        "--demos",
        s(&out),
        "--num-demos",
        "1",
        "--steps",
        "300",
        "--out",
        s(&run),
    ]);

    // Flags of the other rule are refused, by name.
    let mut with_safe = args.to_vec();
    with_safe.extend(["--safe", "3"]);
    refused(&with_safe, &["--safe is not for --profile authors"]);
    refused(
        &["demos", "collect", "--env", "InvertedDoublePendulum-v5", "--episodes", "10", "--out", s(&again)],
        &["--episodes is for --profile authors"],
    );
}

/// The final actor's tensor bytes (after safetensors' JSON header, whose key order is not fixed).
fn tensors(dir: &Path) -> Vec<u8> {
    let bytes = std::fs::read(dir.join("actor.safetensors")).unwrap();
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    bytes[8 + n..].to_vec()
}

#[test]
fn a_run_with_demonstrations_in_its_buffer_resumes_exactly() {
    // The authors' bare SAC with the demonstrations in its buffer and their BC term (the
    // `authors-demos` arm): `defender train` stores them before every session, and a resumed
    // run must take the checkpoint's buffer instead, flags included.
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("run.toml");
    std::fs::write(
        &config,
        "env = \"InvertedDoublePendulum-v5\"\nalgo = \"sac\"\nprofile = \"authors\"\n\
         [sac]\ndemos_in_replay = true\nbc_weight = 1.0\nbc_form = \"authors\"\nbatch_size = 64\n",
    )
    .unwrap();
    let demos = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos/InvertedDoublePendulum-v5.npz");
    std::fs::write(
        &config,
        format!("demos = \"{}\"\n{}", demos.display(), std::fs::read_to_string(&config).unwrap()),
    )
    .unwrap();
    let args = |out: &Path| -> Vec<String> {
        [
            "train",
            "--config",
            s(&config),
            "--steps",
            "1500",
            "--eval-freq",
            "500",
            "--seed",
            "2",
            "--out",
            s(out),
        ]
        .map(String::from)
        .to_vec()
    };
    let alone = dir.path().join("alone");
    ok(&args(&alone).iter().map(String::as_str).collect::<Vec<_>>());

    let out = dir.path().join("stopped");
    let mut child = common::command()
        .args(args(&out))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Stop it once its first evaluation (step 500) is written.
    let start = std::time::Instant::now();
    while !std::fs::read_to_string(out.join("eval.csv")).is_ok_and(|t| t.lines().count() >= 2)
        && start.elapsed() < std::time::Duration::from_secs(120)
    {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let kill = Command::new("kill").args(["-s", "TERM", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    assert_eq!(child.wait().unwrap().code(), Some(143), "the run ended before it was stopped");
    ok(&["train", "--out", s(&out), "--resume"]);
    assert_eq!(
        common::metrics_without_wall(&alone),
        common::metrics_without_wall(&out),
        "metrics.csv differs"
    );
    for file in ["eval.csv", "updates.csv"] {
        let read = |d: &Path| std::fs::read_to_string(d.join(file)).unwrap();
        assert_eq!(read(&alone), read(&out), "{file} differs");
    }
    assert!(tensors(&alone) == tensors(&out), "the final actors differ");
    let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(config.contains("demos_in_replay = true") && config.contains("demos_sha256"), "{config}");
}

#[test]
fn the_shipped_authors_set_is_what_its_readme_says() {
    // data/demos/authors/README.md describes each file; a set remade with other settings must
    // change the README too.
    // (file, (safe, unsafe), transitions, demonstrate_every, training_episodes)
    let shipped = [
        ("InvertedDoublePendulum-v5.npz", (20, 80), 22_141, 4, 400),
        ("Hopper-v5.npz", (33, 67), 53_572, 15, 1500),
    ];
    for (file, groups, transitions, every, episodes) in shipped {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos/authors").join(file);
        let set = EpisodeSet::load(&path).unwrap();
        assert_eq!(set.group_sizes(), groups, "{file}");
        assert_eq!(set.transitions(), transitions, "{file}");
        let meta = &set.meta().extra;
        assert_eq!(meta["collection"], "authors", "{file}");
        assert_eq!(meta["demonstrate_every"], every, "{file}");
        assert_eq!(meta["training_episodes"], episodes, "{file}");
        let r_task = meta["r_task"].as_f64().unwrap() as f32;
        assert_eq!(Some(r_task), set.min_reward(), "{file}");
    }
}

/// A second SPEC ablation of the same files with other bytes (3 demonstrations per group), for a
/// --combine of two SPEC files.
fn spec2(dir: &tempfile::TempDir, demos: &Path, episodes: &Path) -> PathBuf {
    let path = dir.path().join("spec2.csv");
    ok(&["ablate", "--demos", s(demos), "--episodes", s(episodes), "--num-demos", "3", "--out", s(&path)]);
    path
}
