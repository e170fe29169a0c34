//! A complete run counts for an experiment only if it is the run the experiment asks for. A
//! stopped run is checked by `defender train --resume` itself (it refuses a changed
//! configuration); a complete one is not started again, so the sweep compares its `config.toml`
//! with the planned configuration here, before anything runs. Without this, an edited
//! experiment file (a longer budget, another learning rate) would be reported from runs made
//! under the old one.
//!
//! This is also what lets two experiment files share runs: `experiments/auto.toml` run into the
//! directory of `experiments/table1.toml` reuses its bare and `MeanDemoW5/MeanDemoW10` runs,
//! because their configurations are the same.

use std::path::Path;

use anyhow::{Result, bail};

use super::runner::{RunState, state_of};
use defender_config::experiment::PlannedRun;
use defender_config::run_config::{RunConfig, read_config};

/// Settings that may differ because they do not change what the agent learns or what the report
/// reads: where and how often a run saves its work (`record_episodes` is an absolute path inside
/// the sweep directory, which moves with a clone of the results), and the dynamics model's
/// settings. A filtered transition is terminal, so no update reads the model's prediction; the
/// agent learns bit for bit the same whatever the model's schedule (tested in
/// `crates/defender/tests/defender_env.rs`), and runs made before the default schedule changed
/// still count.
fn operational(key: &str) -> bool {
    key == "record_episodes" || key.starts_with("checkpoint_every") || key.starts_with("defender.dynamics.")
}

/// How the complete run in `dir` differs from `planned`, as `key: run -> experiment` lines.
pub fn differences(dir: &Path, planned: &RunConfig) -> Result<Vec<String>> {
    let saved = read_config(&dir.join("config.toml"))?;
    let planned = &planned.clone().keeping_automatic_choice_of(&saved);
    let mut diffs: Vec<String> = defender_config::resume::differences(&saved, planned, true)?
        .into_iter()
        .filter(|line| !operational(line.split(':').next().unwrap_or_default()))
        .collect();
    // `resume::differences` leaves the budget out (a stopped run may extend it); a complete
    // run's budget is part of what it measured.
    for (key, run, experiment) in [
        ("total_steps", saved.total_steps, planned.total_steps),
        ("total_episodes", saved.total_episodes, planned.total_episodes),
    ] {
        if run != experiment {
            diffs.push(format!("{key}: {run} -> {experiment}"));
        }
    }
    if planned.record_episodes.is_some() && saved.record_episodes.is_none() {
        diffs.push("record_episodes: (unset) -> a file (the run recorded no episodes)".to_string());
    }
    Ok(diffs)
}

/// Refuses the sweep if a complete run in `root` was made with another configuration than the
/// experiment's, naming each run and setting.
pub fn check(root: &Path, runs: &[PlannedRun]) -> Result<()> {
    let mut conflicts = Vec::new();
    for run in runs {
        let dir = root.join(&run.name);
        if state_of(&dir) != RunState::Complete {
            continue;
        }
        let diffs = differences(&dir, &run.config_in(root))?;
        if !diffs.is_empty() {
            conflicts.push(format!("{}:\n    {}", dir.display(), diffs.join("\n    ")));
        }
    }
    if !conflicts.is_empty() {
        bail!(
            "{} complete run(s) in {} were made with another configuration than the experiment's \
             (run -> experiment):\n  {}\n\
             a complete run is not run again: restore the experiment file, move those runs away, \
             or sweep into another --out",
            conflicts.len(),
            root.display(),
            conflicts.join("\n  ")
        );
    }
    Ok(())
}
