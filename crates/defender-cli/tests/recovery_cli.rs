//! Recovery RL through the binary: `defender train --recovery EPS_RISK` runs, pins its
//! demonstrations in `config.toml`, reports the recovery policy's steps in `updates.csv`, and a
//! run stopped and resumed ends as the run left alone; without demonstrations, or with TD3, it is
//! refused naming the key.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

mod common;

use common::{ok, s, text};

const ENV_ID: &str = "InvertedDoublePendulum-v5";

/// Small networks, learning from step 300, and a short pretraining (the flag keeps it).
fn config_file(dir: &Path) -> String {
    let path = dir.join("recovery.toml");
    std::fs::write(
        &path,
        format!(
            "env = \"{ENV_ID}\"\nalgo = \"sac\"\n[sac]\nlearning_starts = 300\nnet_arch = [64, 64]\n\
             batch_size = 64\n[safety]\nmethod = \"recovery\"\ngamma_risk = 0.7\neps_risk = 0.2\n\
             pretrain_steps = 200\n"
        ),
    )
    .unwrap();
    s(&path).to_string()
}

fn args(config: &str, out: &Path) -> Vec<String> {
    ["train", "--config", config, "--recovery", "0.3", "--steps", "2000", "--eval-freq", "500", "--seed", "4"]
        .iter()
        .map(|a| a.to_string())
        .chain(["--out".to_string(), s(out).to_string()])
        .collect()
}

fn read(dir: &Path, file: &str) -> String {
    std::fs::read_to_string(dir.join(file)).unwrap()
}

#[test]
fn a_recovery_run_trains_and_resumes_to_the_run_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let config = config_file(dir.path());
    let alone = dir.path().join("alone");
    ok(&args(&config, &alone).iter().map(String::as_str).collect::<Vec<_>>());

    let written: toml::Table = toml::from_str(&read(&alone, "config.toml")).unwrap();
    let safety = &written["safety"];
    assert_eq!(safety["method"].as_str(), Some("recovery"));
    assert_eq!(safety["eps_risk"].as_float(), Some(0.3), "the flag sets eps_risk");
    assert_eq!(safety["gamma_risk"].as_float(), Some(0.7), "the configuration's gamma_risk stays");
    assert_eq!(safety["pretrain_steps"].as_integer(), Some(200));
    assert_eq!(safety["pos_fraction"].as_float(), Some(0.3), "violations over-sampled by default");
    assert!(written["demos"].as_str().unwrap().ends_with(&format!("{ENV_ID}.npz")));
    assert_eq!(written["demos_sha256"].as_str().map(str::len), Some(64), "the demonstrations are pinned");
    let updates = read(&alone, "updates.csv");
    let header = updates.lines().next().unwrap();
    let column = header.split(',').position(|c| c == "recovery_steps").expect(header);
    let counts: Vec<u64> =
        updates.lines().skip(1).map(|l| l.split(',').nth(column).unwrap().parse().unwrap()).collect();
    assert!(!counts.is_empty() && counts.windows(2).all(|w| w[0] <= w[1]), "{updates}");

    // The same run stopped by SIGTERM after its first evaluation, then resumed.
    let out = dir.path().join("stopped");
    let evaluated = || std::fs::read_to_string(out.join("eval.csv")).is_ok_and(|t| t.lines().count() >= 2);
    let code = common::stop_with_sigterm_when(&args(&config, &out), &out, evaluated);
    assert_eq!(code, Some(143), "not stopped by SIGTERM");
    assert!(out.join("checkpoint/agent/recovery/state.json").exists());
    ok(&["train", "--out", s(&out), "--resume"]);
    let (ma, mo) = (common::metrics_without_wall(&alone), common::metrics_without_wall(&out));
    let first = ma.iter().zip(&mo).position(|(a, b)| a != b);
    assert!(ma == mo, "metrics.csv differs from row {first:?}: {:?}", first.map(|i| (&ma[i], &mo[i])));
    for file in ["eval.csv", "updates.csv"] {
        assert_eq!(read(&alone, file), read(&out, file), "{file} differs");
    }
    let actor = |d: &Path| {
        let bytes = std::fs::read(d.join("actor.safetensors")).unwrap();
        let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
        bytes[8 + n..].to_vec()
    };
    assert!(actor(&alone) == actor(&out), "the final actors differ");
}

#[test]
fn recovery_without_demonstrations_or_with_td3_is_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("no-data");
    std::fs::create_dir(&empty).unwrap();
    let out = dir.path().join("x");
    let base = ["train", "--env", ENV_ID, "--steps", "100", "--recovery", "0.3", "--out", s(&out)];
    let o = common::command().args(base).env("DEFENDER_DATA", &empty).output().unwrap();
    let msg = text(&o);
    assert!(!o.status.success() && msg.contains("`demos`") && msg.contains("recovery"), "{msg}");
    assert!(!msg.contains("panicked"), "{msg}");

    let o = common::command().args(base).args(["--algo", "td3"]).output().unwrap();
    let msg = text(&o);
    assert!(!o.status.success() && msg.contains("algo = \"td3\""), "{msg}");

    let o = common::command()
        .args(["train", "--env", ENV_ID, "--steps", "100", "--recovery", "1.5", "--out"])
        .arg(&out)
        .output();
    let msg = text(&o.unwrap());
    assert!(msg.contains("eps_risk"), "{msg}");
}
