//! `--profile keeps-learning` on the command line: what a run's `config.toml` says it ran with,
//! that the record trains the same run again, that the flags a user gives win over the profile,
//! and that a bare run stays bare.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;

/// `defender train` on IDP for 300 steps with `args`; the run's `config.toml`.
fn train(args: &[&str]) -> toml::Table {
    train_with(&[&["--env", "InvertedDoublePendulum-v5", "--steps", "300", "--seed", "1"][..], args].concat())
}

fn train_with(args: &[&str]) -> toml::Table {
    let out = Command::new(env!("CARGO_BIN_EXE_defender"))
        .env("DEFENDER_NN_THREADS", "1")
        .arg("train")
        .args(args)
        .output()
        .expect("run defender");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "defender train {args:?} failed:\n{text}");
    let dir = args.iter().position(|a| *a == "--out").map(|i| args[i + 1]).unwrap();
    toml::from_str(&std::fs::read_to_string(Path::new(dir).join("config.toml")).unwrap()).unwrap()
}

#[test]
fn keeps_learning_fills_what_the_flags_leave_out() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("filtered");
    let out = out.to_str().unwrap();
    let strategy = ["--strategy", "MinBothW5/MinBothW5"];
    let config = train(&[&["--profile", "keeps-learning", "--out", out][..], &strategy].concat());
    assert_eq!(config["profile"].as_str(), Some("keeps-learning"));
    let filter = &config["defender"]["filter"];
    assert_eq!(filter["margin"].as_float(), Some(0.02));
    assert_eq!(filter["own_episodes"]["keep"].as_integer(), Some(50));
    assert_eq!(config["sac"]["demos_in_replay"].as_bool(), Some(true));
    assert_eq!(config["sac"]["bc_weight"].as_float(), Some(1.0));
    assert_eq!(config["sac"]["bc_form"].as_str(), Some("per-row"));
    // SPEC's cost: the profile changes the decision and the learner only.
    assert_eq!(config["defender"]["cost"]["dtw"].as_str(), Some("exact"));

    // The record trains the same run again (a reader's `--config <run>/config.toml`).
    let again = dir.path().join("again");
    let record = Path::new(out).join("config.toml");
    let copy = train_with(&["--config", record.to_str().unwrap(), "--out", again.to_str().unwrap()]);
    assert_eq!(copy, config);

    // Flags win over the profile, leaf by leaf.
    let own = dir.path().join("own");
    let config = train(
        &[
            &[
                "--profile",
                "keeps-learning",
                "--margin",
                "0",
                "--own-episodes",
                "5",
                "--out",
                own.to_str().unwrap(),
            ][..],
            &strategy,
        ]
        .concat(),
    );
    assert_eq!(config["defender"]["filter"]["margin"].as_float(), Some(0.0));
    assert_eq!(config["defender"]["filter"]["own_episodes"]["keep"].as_integer(), Some(5));
    assert_eq!(config["sac"]["bc_form"].as_str(), Some("per-row"));

    // Bare SAC stays bare SAC (the yardstick): no demonstrations, no cloning.
    let bare = dir.path().join("bare");
    let config = train(&["--profile", "keeps-learning", "--out", bare.to_str().unwrap()]);
    assert!(!config.contains_key("defender"));
    assert_eq!(config["sac"]["demos_in_replay"].as_bool(), Some(false));
    assert_eq!(config["sac"]["bc_weight"].as_float(), Some(0.0));
}

#[test]
fn a_new_run_takes_keeps_learning_and_spec_is_one_word_away() {
    let dir = tempfile::tempdir().unwrap();
    let strategy = ["--strategy", "MinBothW5/MinBothW5"];
    let new = dir.path().join("new");
    let config = train(&[&["--out", new.to_str().unwrap()][..], &strategy].concat());
    assert_eq!(config["profile"].as_str(), Some("keeps-learning"));
    assert_eq!(config["defender"]["filter"]["margin"].as_float(), Some(0.02));
    assert_eq!(config["sac"]["bc_form"].as_str(), Some("per-row"));

    // SPEC's behaviour is one word away, and its record says so (a record is read with the
    // profile it names, never with the default for new runs).
    let spec = dir.path().join("spec");
    let config = train(&[&["--profile", "spec", "--out", spec.to_str().unwrap()][..], &strategy].concat());
    assert_eq!(config["profile"].as_str(), Some("spec"));
    assert!(!config["defender"].as_table().unwrap().contains_key("filter"), "SPEC's filter: {config:?}");
    assert_eq!(config["sac"]["demos_in_replay"].as_bool(), Some(false));
}

/// `--learn-from-demos` is the default profile's learner without its filter (the "demonstrations
/// alone" baseline): the same `[sac]` as a DEFENDER run under `keeps-learning`, no `[defender]`,
/// the set recorded at the top level; under the authors' profile the flag's cloning form wins.
#[test]
fn learning_from_the_demonstrations_alone_is_the_default_learner_without_its_filter() {
    let dir = tempfile::tempdir().unwrap();
    let filtered = dir.path().join("filtered");
    let with_filter = train(&["--strategy", "MinBothW5/MinBothW5", "--out", filtered.to_str().unwrap()]);
    let alone = dir.path().join("alone");
    let config = train(&["--learn-from-demos", "--out", alone.to_str().unwrap()]);
    assert!(!config.contains_key("defender"), "{config:?}");
    assert_eq!(config["sac"], with_filter["sac"]);
    assert!(config["demos"].as_str().unwrap().ends_with("InvertedDoublePendulum-v5.npz"));

    let own = dir.path().join("own");
    let demos = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/demos/InvertedDoublePendulum-v5.npz");
    let config = train(&["--learn-from-demos", "--demos", demos, "--out", own.to_str().unwrap()]);
    assert_eq!(config["demos"].as_str(), Some(demos));

    // The flag names the learner, whatever a profile would fill (the authors' cloning form).
    let authors = dir.path().join("authors");
    let config = train(&[
        "--profile",
        "authors",
        "--strategy",
        "MinBothW5/MinBothW5",
        "--learn-from-demos",
        "--out",
        authors.to_str().unwrap(),
    ]);
    assert_eq!(config["sac"]["bc_form"].as_str(), Some("per-row"));
    assert_eq!(config["sac"]["warmup"].as_bool(), Some(false), "the profile's other keys stay");
}

/// Equal information (the repaired baselines): every baseline runs with the default's learner half, the
/// demonstrations in the buffer with per-row cloning, exactly as the demonstrations-alone run's
/// `[sac]`, beside its own `[safety]`.
#[test]
fn every_baseline_takes_the_default_learner_half() {
    let dir = tempfile::tempdir().unwrap();
    let alone = train(&["--learn-from-demos", "--out", dir.path().join("alone").to_str().unwrap()]);
    for (name, flags) in [
        ("penalty", &["--penalty", "1"][..]),
        ("lagrangian", &["--lagrangian", "0.2"][..]),
        ("pid", &["--pid", "0.2"][..]),
        ("recovery", &["--recovery", "0.3"][..]),
    ] {
        let out = dir.path().join(name);
        let config = train(&[flags, &["--learn-from-demos", "--out", out.to_str().unwrap()]].concat());
        assert_eq!(config["sac"], alone["sac"], "{name}");
        assert_eq!(config["safety"]["method"].as_str(), Some(name));
        assert!(!config.contains_key("defender"), "{name}: {config:?}");
    }
}
