//! Runs on a task whose safety is a per-step cost (Safety-Gymnasium's velocity tasks) through the
//! binary: Lagrangian SAC takes the field's limit, DEFENDER takes the episode cost limit from the
//! task and demonstrations labelled by it (docs/SPEC.md, section 13), and the settings that do
//! not fit a task's safety signal are refused naming the setting.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

mod common;

use common::{ok, refused, s};

const VELOCITY: &str = "SafetyHopperVelocity-v1";

/// Hopper-v5's shipped demonstrations as if collected on the velocity task (the same body and
/// dimensions), with `meta` naming `limit` or, with `None`, no limit (a set labelled by crashes).
/// The labels mean nothing there: these tests check what the pipeline accepts and refuses.
fn velocity_demos(dir: &Path, limit: Option<f64>) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos/Hopper-v5.npz");
    let mut set = defender::EpisodeSet::load(root).unwrap();
    set.meta_mut().env_id = Some(VELOCITY.into());
    if let Some(l) = limit {
        set.meta_mut().extra.insert(defender::EPISODE_COST_LIMIT_KEY.into(), l.into());
    }
    let path = dir.join(format!("demos-{}.npz", limit.map_or("crash".into(), |l| l.to_string())));
    set.save(&path).unwrap();
    path
}

/// The `cost` column of `dir/metrics.csv`, one value per training episode.
fn episode_costs(dir: &Path) -> Vec<f64> {
    let metrics = std::fs::read_to_string(dir.join("metrics.csv")).unwrap();
    let cost = metrics.lines().next().unwrap().split(',').position(|c| c == "cost").unwrap();
    metrics.lines().skip(1).map(|l| l.split(',').nth(cost).unwrap().parse().unwrap()).collect()
}

fn train(dir: &Path, extra: &[&str]) -> Vec<String> {
    let mut args: Vec<String> =
        ["train", "--env", VELOCITY, "--steps", "300"].iter().map(ToString::to_string).collect();
    args.extend(["--out".into(), s(dir).into()]);
    args.extend(extra.iter().map(ToString::to_string));
    args
}

#[test]
fn lagrangian_sac_takes_the_fields_limit_on_a_velocity_task_and_a_crash_probability_on_a_crash_task() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("lag");
    let args = train(&run, &["--lagrangian", "25"]);
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(config.contains("cost_limit = 25.0"), "{config}");
    for c in episode_costs(&run) {
        assert!(c >= 0.0 && c.fract() == 0.0, "{c}");
    }
    let args = train(&tmp.path().join("zero"), &["--lagrangian", "0"]);
    refused(&args.iter().map(String::as_str).collect::<Vec<_>>(), &["cost_limit = 0", VELOCITY, "> 0"]);
    let hopper = ["train", "--env", "Hopper-v5", "--steps", "300", "--lagrangian", "25", "--out"];
    let out = tmp.path().join("hopper");
    refused(&[&hopper[..], &[s(&out)]].concat(), &["cost_limit", "[0, 1]", "Hopper-v5"]);
    assert!(!out.exists(), "a refused run leaves no directory");
}

#[test]
fn defender_on_a_velocity_task_uses_the_tasks_limit_and_refuses_demonstrations_without_costs() {
    let tmp = tempfile::tempdir().unwrap();
    let labelled = velocity_demos(tmp.path(), Some(25.0));
    let run = tmp.path().join("def");
    let args = train(&run, &["--strategy", "MeanDemoW5/MeanDemoW10", "--demos", s(&labelled)]);
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(config.contains("episode_cost_limit = 25.0"), "config.toml records the limit:\n{config}");

    let crash_labelled = velocity_demos(tmp.path(), None);
    let args = train(
        &tmp.path().join("crash-demos"),
        &["--strategy", "MeanDemoW5/MeanDemoW10", "--demos", s(&crash_labelled)],
    );
    refused(&args.iter().map(String::as_str).collect::<Vec<_>>(), &["carry no costs", "episode_cost_limit"]);
    let other_limit = velocity_demos(tmp.path(), Some(10.0));
    let args =
        train(&tmp.path().join("ten"), &["--strategy", "MeanDemoW5/MeanDemoW10", "--demos", s(&other_limit)]);
    refused(&args.iter().map(String::as_str).collect::<Vec<_>>(), &["passed 10", "episode_cost_limit is 25"]);
}

#[test]
fn an_episode_cost_limit_on_a_crash_task_is_refused_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tmp.path().join("run.toml");
    std::fs::write(
        &config,
        "env = \"Hopper-v5\"\n[defender]\nstrategy = \"MeanDemoW5/MeanDemoW10\"\nepisode_cost_limit = 5.0\n",
    )
    .unwrap();
    let out = tmp.path().join("run");
    refused(
        &["train", "--config", s(&config), "--steps", "300", "--out", s(&out)],
        &["episode_cost_limit = 5", "crash"],
    );
}

#[test]
fn recorded_episodes_of_a_velocity_task_are_labelled_by_the_limit() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("bare");
    let episodes = tmp.path().join("episodes.npz");
    let args = train(&run, &["--record-episodes", s(&episodes)]);
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let set = defender::EpisodeSet::load(&episodes).unwrap();
    assert_eq!(set.meta().extra[defender::EPISODE_COST_LIMIT_KEY], serde_json::json!(25.0));
    // Early Hopper episodes fall within tens of steps, long before 25 fast steps: none unsafe.
    let over = episode_costs(&run).into_iter().filter(|&c| c > 25.0).count();
    assert_eq!(set.group_sizes().1, over, "an episode is unsafe exactly when its cost passed 25");
}
