//! Tests of experiment files (`super`): expansion, arms, and the refusals with the line to fix.

use super::*;

/// The simulator's task ids (`defender_mujoco::TASKS`, which this crate does not link).
const TASKS: &[&str] = &[
    "Hopper-v5",
    "Walker2d-v5",
    "InvertedDoublePendulum-v5",
    "SafetyHopperVelocity-v1",
    "SafetyWalker2dVelocity-v1",
    "SafetyHalfCheetahVelocity-v1",
];

const GRID: &str = r#"
description = "test"
[grid]
envs = ["InvertedDoublePendulum-v5", "Hopper-v5"]
strategies = ["none", "MeanDemoW5/MeanDemoW10"]
modes = ["state", "state-action"]
seeds = [0, 1]
[budget]
steps = 1000
per_env = { "Hopper-v5" = { episodes = 20 } }
[run]
eval_freq = 500
[run.sac]
learning_starts = 50
"#;

#[test]
fn expands_to_named_runs_with_their_overrides() {
    let e = parse(GRID, TASKS).unwrap();
    let names: Vec<&str> = e.runs.iter().map(|r| r.name.as_str()).collect();
    // Per task: 2 bare + 2 modes x 2 seeds DEFENDER.
    assert_eq!(names.len(), 12, "{names:?}");
    assert_eq!(names[0], "InvertedDoublePendulum-v5/sac-bare-s0");
    assert!(names.contains(&"Hopper-v5/sac-MeanDemoW5-MeanDemoW10-sa-s1"), "{names:?}");
    let hopper = e.runs.iter().find(|r| r.name == "Hopper-v5/sac-MeanDemoW5-MeanDemoW10-s1").unwrap();
    assert_eq!((hopper.config.seed, hopper.config.total_steps, hopper.config.total_episodes), (1, 0, 20));
    assert_eq!(hopper.config.eval_freq, 500);
    assert_eq!(hopper.config.sac.as_ref().unwrap().learning_starts, 50);
    let d = hopper.config.defender.as_ref().unwrap();
    assert_eq!(d.strategy.to_string(), "MeanDemoW5/MeanDemoW10");
    assert_eq!(d.mode, defender::Mode::State);
    let idp = &e.runs[0].config;
    assert_eq!((idp.total_steps, idp.defender.is_none()), (1000, true));
}

#[test]
fn new_runs_take_the_default_profile_unless_the_file_names_one() {
    use crate::profile::Profile;
    let e = parse(GRID, TASKS).unwrap();
    let hopper = e.runs.iter().find(|r| r.name == "Hopper-v5/sac-MeanDemoW5-MeanDemoW10-s1").unwrap();
    assert_eq!(hopper.config.profile, Profile::KeepsLearning);
    let d = hopper.config.defender.as_ref().unwrap();
    assert_eq!((d.filter.margin, d.filter.own_episodes.map(|o| o.keep)), (0.02, Some(50)));
    assert!(hopper.config.sac.as_ref().unwrap().demos_in_replay);
    // Bare SAC stays bare SAC.
    let bare = &e.runs[0].config;
    assert!(bare.defender.is_none() && !bare.sac.as_ref().unwrap().demos_in_replay);
    let spec = parse(&GRID.replace("[run]\n", "[run]\nprofile = \"spec\"\n"), TASKS).unwrap();
    let hopper = spec.runs.iter().find(|r| r.name == "Hopper-v5/sac-MeanDemoW5-MeanDemoW10-s1").unwrap();
    assert_eq!(hopper.config.profile, Profile::Spec);
    assert!(hopper.config.defender.as_ref().unwrap().filter.is_spec());
    assert!(!hopper.config.sac.as_ref().unwrap().demos_in_replay);
}

#[test]
fn arms_add_named_variants_and_one_may_stay_unnamed() {
    let arms = format!(
        "{GRID}\n[[arms]]\nstrategies = [\"none\"]\n[[arms]]\nname = \"tight\"\n\
         strategies = [\"MeanBothW5/MeanBothW5\"]\nrun = {{ defender = {{ filter = {{ margin = 0.05 }} }} }}\n"
    );
    let e = parse(&arms, TASKS).unwrap();
    let names: Vec<&str> = e.runs.iter().map(|r| r.name.as_str()).collect();
    assert!(names.contains(&"Hopper-v5/sac-bare-s0"), "{names:?}");
    assert!(names.contains(&"Hopper-v5/sac-MeanBothW5-MeanBothW5-sa-tight-s1"), "{names:?}");
    assert!(!names.iter().any(|n| n.contains("MeanDemoW5")), "arms replace the grid's strategies: {names:?}");
    let tight = e.runs.iter().find(|r| r.name == "Hopper-v5/sac-MeanBothW5-MeanBothW5-tight-s0").unwrap();
    assert_eq!(tight.config.defender.as_ref().unwrap().filter.margin, 0.05);
    let two_unnamed = format!("{GRID}\n[[arms]]\nstrategies = [\"none\"]\n[[arms]]\n");
    assert!(parse(&two_unnamed, TASKS).unwrap_err().to_string().contains("more than one arm without a name"));
    let bad = format!("{GRID}\n[[arms]]\nname = \"Tight\"\n");
    assert!(format!("{:#}", parse(&bad, TASKS).unwrap_err()).contains("lowercase"));
}

#[test]
fn an_arm_may_keep_to_some_tasks_and_seeds() {
    // A setting chosen per task (the IDP arm), and one run only for the seed another
    // experiment does not already hold (Hopper's, seed 1).
    let arms = format!(
        "{GRID}\n[[arms]]\nname = \"idp\"\nstrategies = [\"none\"]\nenvs = [\"InvertedDoublePendulum-v5\"]\n\
         run = {{ eval_freq = 250 }}\n[[arms]]\nname = \"late\"\nstrategies = [\"none\"]\nenvs = [\"Hopper-v5\"]\nseeds = [1]\n"
    );
    let e = parse(&arms, TASKS).unwrap();
    let names: Vec<&str> = e.runs.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "InvertedDoublePendulum-v5/sac-bare-idp-s0",
            "InvertedDoublePendulum-v5/sac-bare-idp-s1",
            "Hopper-v5/sac-bare-late-s1"
        ]
    );
    let late = &e.runs[2].config;
    assert_eq!((late.seed, late.total_episodes), (1, 20), "the grid's budget for its task");
    assert_eq!(e.runs[0].config.eval_freq, 250);
    refused(
        &format!("{GRID}\n[[arms]]\nname = \"x\"\nenvs = [\"Walker2d-v5\"]\n"),
        &["line 18", "'x'", "Walker2d-v5", "not in grid.envs"],
    );
    refused(&format!("{GRID}\n[[arms]]\nname = \"x\"\nenvs = []\n"), &["'x'", "envs is empty"]);
    refused(&format!("{GRID}\n[[arms]]\nname = \"x\"\nseeds = []\n"), &["line 18", "'x'", "seeds is empty"]);
}

/// Every experiment file the project ships expands: a file edited into nonsense is caught
/// here, not hours into a sweep.
#[test]
fn every_shipped_experiment_expands() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 6, "{files:?}");
    for file in files {
        let e = load(&file, TASKS).unwrap_or_else(|err| panic!("{err:#}"));
        assert!(!e.runs.is_empty() && !e.description.is_empty(), "{}", file.display());
    }
}

fn refused(text: &str, expect: &[&str]) {
    let err = format!("{:#}", parse(text, TASKS).unwrap_err());
    for e in expect {
        assert!(err.contains(e), "'{e}' not in: {err}");
    }
}

#[test]
fn bad_files_are_refused_with_the_line_to_fix() {
    refused(&GRID.replace("[run]\n", "[run]\nlearning_rate = 1\n"), &["learning_rate"]);
    refused(&GRID.replace("description", "descripton"), &["descripton", "line 2"]);
    refused(&GRID.replace("MeanDemoW5/MeanDemoW10", "MeanDemoW5/Bogus"), &["line 5", "Bogus"]);
    refused(&GRID.replace("seeds = [0, 1]", "seeds = []"), &["grid.seeds is empty"]);
    refused(&GRID.replace("\"none\", ", "\"none\", \"none\", "), &["appears twice", "line 5"]);
    refused(&GRID.replace("Hopper-v5\"]", "Hoper-v5\"]"), &["unknown task 'Hoper-v5'", "line 4"]);
    refused(&GRID.replace("steps = 1000\n", ""), &["budget"]);
}

/// Values that parse but cannot run are refused when the file is read, naming the run, the
/// section, the key and the value, not run by run after others have started.
#[test]
fn bad_values_are_refused_before_any_run() {
    let first = "run 'InvertedDoublePendulum-v5/sac-bare-s0'";
    refused(
        &GRID.replace("learning_starts = 50", "learning_rate = nan"),
        &[first, "[sac]", "learning_rate = NaN"],
    );
    refused(
        &GRID.replace("learning_starts = 50", "learning_rate = -0.001"),
        &["[sac]", "learning_rate = -0.001"],
    );
    refused(&GRID.replace("learning_starts = 50", "batch_size = 0"), &["[sac]", "batch_size = 0"]);
    refused(&GRID.replace("eval_freq = 500", "eval_freq = 500\neval_episodes = 0"), &["eval_episodes = 0"]);
    let defender_run = "run 'InvertedDoublePendulum-v5/sac-MeanDemoW5-MeanDemoW10-n0-s0'";
    refused(
        &GRID.replace("seeds = [0, 1]", "seeds = [0, 1]\nnum_demos = [0]"),
        &[defender_run, "num_demos = 0"],
    );
    let dynamics = GRID.replace("[run.sac]", "[run.defender.dynamics]\nlearning_rate = nan\n[run.sac]");
    refused(&dynamics, &["[defender]", "dynamics: learning_rate = NaN"]);
    let r_task = GRID.replace("[run.sac]", "[run.defender]\nr_task = inf\n[run.sac]");
    refused(&r_task, &["[defender]", "r_task = inf"]);
}

#[test]
fn num_demos_beyond_the_file_is_refused_at_load() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("x.toml");
    let text = GRID.replace("seeds = [0, 1]", "seeds = [0, 1]\nnum_demos = [50, 51]");
    std::fs::write(&file, text).unwrap();
    let err = format!("{:#}", load(&file, TASKS).unwrap_err());
    for e in [
        "x.toml",
        "run 'InvertedDoublePendulum-v5/sac-MeanDemoW5-MeanDemoW10-n51-s0'",
        "num_demos = 51",
        "give at most 50",
    ] {
        assert!(err.contains(e), "'{e}' not in: {err}");
    }
}
