//! `defender train`'s last line, the run's one-line summary: it names what was trained (bare, a
//! `[safety]` baseline, the demonstrations alone, or both), and on a task whose safety is a
//! per-step cost (an episode cost limit) it gives the run's cost, not only the share of episodes
//! that fell. Tiny runs: a few hundred steps, no learning.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

mod common;

use common::{ok, s};

const IDP: &str = "InvertedDoublePendulum-v5";
const VELOCITY: &str = "SafetyHopperVelocity-v1";

/// `defender train --env ENV --steps 300 --seed SEED --out DIR EXTRA...`; the summary line (the
/// line before `run directory:`).
fn summary_line(env: &str, seed: &str, out: &Path, extra: &[&str]) -> String {
    let mut args = vec!["train", "--env", env, "--steps", "300", "--seed", seed, "--out", s(out)];
    args.extend(extra);
    let said = ok(&args);
    let lines: Vec<&str> = said.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
    let at = lines.iter().position(|l| l.starts_with("run directory:")).expect(&said);
    // The summary, then the evaluations' line (the final evaluation at least), then the directory.
    assert!(lines[at - 1].starts_with("evaluation (the last evaluation of 1): return "), "{said}");
    lines[at - 2].to_string()
}

/// A Recovery RL configuration whose pretraining is short and whose networks are small.
fn recovery_config(dir: &Path) -> String {
    let path = dir.join("recovery.toml");
    std::fs::write(
        &path,
        format!(
            "env = \"{IDP}\"\nalgo = \"sac\"\n[sac]\nnet_arch = [32, 32]\nbatch_size = 32\n\
             [safety]\nmethod = \"recovery\"\neps_risk = 0.3\ngamma_risk = 0.5\npretrain_steps = 20\n"
        ),
    )
    .unwrap();
    s(&path).to_string()
}

#[test]
fn the_summary_line_names_the_baseline_not_bare() {
    let tmp = tempfile::tempdir().unwrap();
    let line = |name: &str, extra: &[&str]| summary_line(IDP, "5", &tmp.path().join(name), extra);

    let bare = line("bare", &[]);
    assert!(bare.starts_with(&format!("{IDP} sac bare seed 5: 300 steps, ")), "{bare}");
    assert!(bare.contains(", crash ") && !bare.contains("training cost"), "a crash task: {bare}");

    let penalty = line("penalty", &["--penalty", "1"]);
    assert!(penalty.starts_with(&format!("{IDP} sac penalty seed 5: ")), "{penalty}");
    let lagrangian = line("lagrangian", &["--lagrangian", "0.2"]);
    assert!(lagrangian.starts_with(&format!("{IDP} sac lagrangian seed 5: ")), "{lagrangian}");
    let config = recovery_config(tmp.path());
    let recovery = line("recovery", &["--config", &config]);
    assert!(recovery.starts_with(&format!("{IDP} sac recovery seed 5: ")), "{recovery}");

    let demos = line("demos", &["--learn-from-demos"]);
    assert!(demos.starts_with(&format!("{IDP} sac learning from the demonstrations seed 5: ")), "{demos}");
    let both = line("penalty-demos", &["--penalty", "1", "--learn-from-demos"]);
    let want = format!("{IDP} sac penalty + learning from the demonstrations seed 5: ");
    assert!(both.starts_with(&want), "{both}");
    for l in [&penalty, &lagrangian, &recovery, &demos, &both] {
        assert!(!l.contains(" bare "), "{l}");
    }
}

#[test]
fn a_cost_tasks_summary_line_gives_its_training_cost() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("bare");
    // Seed 1's random hopper passes the velocity threshold on some steps.
    let line = summary_line(VELOCITY, "1", &run, &[]);

    // The figures are those of the run's files: the cost summed over metrics.csv's episodes, per
    // environment step and per episode.
    let metrics = std::fs::read_to_string(run.join("metrics.csv")).unwrap();
    let header: Vec<&str> = metrics.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let (cost_at, outcome_at) = (column("cost"), column("outcome"));
    let rows: Vec<Vec<&str>> = metrics.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let cost: f64 = rows.iter().map(|r| r[cost_at].parse::<f64>().unwrap()).sum();
    let falls = rows.iter().filter(|r| r[outcome_at] == "crashed").count();
    let episodes = rows.len() as f64;
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["cost"].as_f64(), Some(cost));
    assert!(cost > 0.0, "a run with a cost to show");
    assert_eq!(summary["steps"].as_u64(), Some(300));

    let want = format!("{VELOCITY} sac bare seed 1: 300 steps, {} episodes, Acc Reward ", rows.len());
    assert!(line.starts_with(&want), "{line}");
    let figures = format!(
        ", training cost {cost:.0} ({:.3} per env step, {:.1} per episode; limit 25 an episode), falls {:.1}%, \
         filtered 0.0%, ",
        cost / 300.0,
        cost / episodes,
        100.0 * falls as f64 / episodes
    );
    assert!(line.contains(&figures), "{line}\nwants {figures}");
    assert!(!line.contains("crash"), "a velocity task's falls are not its violations: {line}");
}
