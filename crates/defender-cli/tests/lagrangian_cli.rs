//! Lagrangian SAC through the binary: `--lagrangian D` trains it and records `[safety]` in
//! config.toml, its multiplier and cost critic show in updates.csv, a run stopped by SIGTERM resumes to
//! exactly the run left alone, an experiment's arm selects it, and TD3 is refused naming the key.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

mod common;

use common::{ok, refused, s};

const ENV_ID: &str = "InvertedDoublePendulum-v5";

fn read(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap()
}

/// The final actor's tensor bytes (after safetensors' JSON header, whose key order is not fixed).
fn actor(dir: &Path) -> Vec<u8> {
    let bytes = std::fs::read(dir.join("actor.safetensors")).unwrap();
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    bytes[8 + n..].to_vec()
}

/// A SAC configuration that learns from step 300, so that 2000 steps train the networks and the
/// multiplier.
fn config(root: &Path) -> String {
    let path = root.join("sac.toml");
    std::fs::write(&path, format!("env = \"{ENV_ID}\"\nalgo = \"sac\"\n[sac]\nlearning_starts = 300\n"))
        .unwrap();
    s(&path).to_string()
}

fn read_or_empty(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap_or_default()
}

/// `defender train --lagrangian 0.5` for 2000 steps, an evaluation every 1000.
fn train_args(config: &str, out: &Path) -> Vec<String> {
    let args = ["train", "--config", config, "--lagrangian", "0.5", "--steps", "2000", "--eval-freq", "1000"];
    let more = ["--checkpoint-every", "20", "--seed", "3", "--out", s(out)];
    args.iter().chain(&more).map(|a| (*a).to_string()).collect()
}

#[test]
fn lagrangian_sac_trains_records_its_section_and_resumes_exactly() {
    let root = tempfile::tempdir().unwrap();
    let config = config(root.path());
    let whole = root.path().join("whole");
    let args = train_args(&config, &whole);
    let said = ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    // The summary line names the baseline (a run with [safety] is not bare).
    assert!(said.contains(&format!("{ENV_ID} sac lagrangian seed 3: ")), "{said}");

    let saved = read(&whole, "config.toml");
    assert!(saved.contains("[safety]\nmethod = \"lagrangian\"\ncost_limit = 0.5\n"), "{saved}");
    assert!(whole.join("checkpoint/agent/lagrangian.json").exists());
    let updates = read(&whole, "updates.csv");
    let mut lines = updates.lines();
    assert!(lines.next().unwrap().ends_with(",qc_loss,lagrange_multiplier,qc_mean"));
    let column = |l: &str, k: usize| -> f64 { l.split(',').nth(k).unwrap().parse().unwrap() };
    let lambdas: Vec<f64> = lines.clone().map(|l| column(l, 9)).collect();
    // The bounded cost critic's mean Q_c at the actor's actions: what a cost of 0 or 1 can be.
    assert!(lines.map(|l| column(l, 10)).all(|q| (0.0..=100.0).contains(&q)), "{updates}");
    // IDP's random policy crashes every episode: J_c = 1 > d = 0.5, the multiplier rises.
    assert_eq!(lambdas.len(), 2, "{updates}");
    assert!(lambdas[0] > 0.001 && lambdas[1] > lambdas[0], "{updates}");

    // Stopped by SIGTERM once it has learnt a while, then resumed: the same run.
    let resumed = root.path().join("resumed");
    let learnt = || read_or_empty(&resumed, "updates.csv").contains("\n1000,");
    let code = common::stop_with_sigterm_when(&train_args(&config, &resumed), &resumed, learnt);
    assert_eq!(code, Some(143), "not stopped by SIGTERM");
    ok(&["train", "--out", s(&resumed), "--resume"]);
    assert_eq!(
        common::metrics_without_wall(&resumed),
        common::metrics_without_wall(&whole),
        "metrics.csv differs"
    );
    assert_eq!(read(&resumed, "eval.csv"), read(&whole, "eval.csv"));
    assert_eq!(read(&resumed, "updates.csv"), updates);
    assert!(actor(&resumed) == actor(&whole), "the final actors differ");
}

#[test]
fn lagrangian_with_td3_is_refused_naming_the_key() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("run");
    let args = ["train", "--env", ENV_ID, "--steps", "2000", "--algo", "td3", "--lagrangian", "0.5"];
    refused(
        &[&args[..], &["--out", s(&out)]].concat(),
        &["method = \"lagrangian\"", "algo = \"sac\"", "td3"],
    );
    assert!(!out.join("config.toml").exists(), "refused before any work");
    let args = ["train", "--env", ENV_ID, "--steps", "2000", "--lagrangian", "1.5", "--out", s(&out)];
    refused(&args, &["cost_limit", "1.5"]);
}

#[test]
fn an_experiment_arm_selects_lagrangian_sac() {
    let root = tempfile::tempdir().unwrap();
    let experiment = root.path().join("exp.toml");
    let arms = "[[arms]]\nname = \"lag\"\nrun = { safety = { method = \"lagrangian\", cost_limit = 0.1 } }\n";
    let grid = "[grid]\nenvs = [\"InvertedDoublePendulum-v5\"]\nalgos = [\"sac\"]\nstrategies = [\"none\"]\nseeds = [0]\n";
    std::fs::write(&experiment, format!("description = \"t\"\n{grid}[budget]\nsteps = 1000\n{arms}"))
        .unwrap();
    let list = ok(&["sweep", s(&experiment), "--out", s(&root.path().join("out")), "--list", "--json"]);
    assert!(list.contains("lagrangian") && list.contains("cost_limit"), "{list}");
    let td3 = experiment.with_file_name("td3.toml");
    std::fs::write(
        &td3,
        format!("description = \"t\"\n{}[budget]\nsteps = 1000\n{arms}", grid.replace("sac", "td3")),
    )
    .unwrap();
    refused(&["sweep", s(&td3), "--out", s(&root.path().join("out2")), "--list"], &["lagrangian", "algo"]);
}

#[test]
fn pid_lagrangian_trains_with_omnisafes_options_and_the_options_need_a_lagrangian() {
    // (and DEFENDER's --charge-filtered is refused without a learner of costs, or its room)
    let root = tempfile::tempdir().unwrap();
    let config = config(root.path());
    let out = root.path().join("pid");
    let said = ok(&[
        "train",
        "--config",
        &config,
        "--pid",
        "0.5",
        "--cost-normalize",
        "--max-grad-norm",
        "40",
        "--steps",
        "1000",
        "--seed",
        "2",
        "--out",
        s(&out),
    ]);
    assert!(said.contains(&format!("{ENV_ID} sac pid seed 2: ")), "{said}");
    let saved: toml::Table = read(&out, "config.toml").parse().unwrap();
    let safety = saved["safety"].as_table().unwrap();
    assert_eq!(safety["method"].as_str(), Some("pid"));
    assert_eq!(safety["ki"].as_float(), Some(1e-7), "OmniSafe's SACPID gains by default");
    assert_eq!(
        (safety["cost_normalize"].as_bool(), safety["max_grad_norm"].as_float()),
        (Some(true), Some(40.0))
    );
    let updates = read(&out, "updates.csv");
    // IDP's random policy crashes every episode: J_c = 1 > d = 0.5; the PID output is positive.
    let last = updates.lines().last().unwrap();
    let lambda: f64 = last.split(',').nth(9).unwrap().parse().unwrap();
    assert!(lambda > 0.0, "{updates}");
    // The options belong to the Lagrangian agents.
    let args = ["train", "--env", ENV_ID, "--steps", "1000", "--cost-normalize", "--out"];
    refused(
        &[&args[..], &[s(&root.path().join("bare"))]].concat(),
        &["--cost-normalize", "--lagrangian", "--pid"],
    );
    // clap's own usage error (exit code 2).
    let out = common::defender(&[
        "train",
        "--env",
        ENV_ID,
        "--lambda-lr",
        "0.1",
        "--out",
        s(&root.path().join("b2")),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(common::text(&out).contains("--lagrangian <D>"), "{}", common::text(&out));
}
