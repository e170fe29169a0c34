//! The committed `results/*/arms.txt` files (the baselines', the velocity tasks' and their finals
//! at power): each line `TASK ARM DIR...` names an arm the docs read, with run directories relative
//! to the repository root. Every directory must be a complete run of that task that the report
//! loads, every arm one of the file's allowed names, and no directory may serve two arms: a table
//! built from these files is then built from what is committed.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::HashSet;
use std::path::Path;

use defender_report::Run;

fn check(file: &str, arms: &[&str]) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let path = root.join(file);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
    let mut seen = HashSet::new();
    let mut pairs = HashSet::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut words = line.split_whitespace();
        let (task, arm) =
            (words.next().unwrap(), words.next().unwrap_or_else(|| panic!("{file}:{}: no ARM", i + 1)));
        assert!(arms.contains(&arm), "{file}:{}: arm {arm:?} is not one of {arms:?}", i + 1);
        assert!(pairs.insert((task, arm)), "{file}:{}: {task} {arm} listed twice", i + 1);
        for dir in words {
            assert!(seen.insert(dir), "{file}:{}: {dir} serves two arms", i + 1);
            let run = Run::load(root.join(dir)).unwrap_or_else(|e| panic!("{file}:{}: {dir}: {e}", i + 1));
            assert_eq!(run.config.env, task, "{file}:{}: {dir} is a run of another task", i + 1);
        }
    }
}

#[test]
fn baselines_arms_name_complete_runs_of_their_task() {
    let arms = [
        "bare",
        "penalty",
        "penalty-v1",
        "lagrangian-v1",
        "recovery-v1",
        "demos",
        "defender",
        "lagrangian",
        "pid",
    ];
    let more = ["recovery", "penalty-demos", "recovery-demos", "lagrangian-demos", "pid-demos"];
    let history = ["lagrangian-demos-v1", "pid-demos-v1", "pid-v2", "recovery-v2", "recovery-demos-v2"];
    check("results/baselines/arms.txt", &[&arms[..], &more[..], &history[..]].concat());
}

#[test]
fn velocity_arms_name_complete_runs_of_their_task() {
    let arms = [
        "bare",
        "lagrangian-v1",
        "defender",
        "omnisafe-saclag",
        "omnisafe-saclag-300k",
        "lagrangian",
        "pid",
        "defender-limit",
    ];
    check("results/velocity/arms.txt", &arms);
}

#[test]
fn crash_limit_arms_name_complete_runs_of_their_task() {
    check("results/crash-limit/arms.txt", &["bare", "defender", "defender-limit"]);
}

#[test]
fn velocity_power_arms_name_complete_runs_of_their_task() {
    check(
        "results/velocity-power/arms.txt",
        &["dl-cont-d20", "lag", "et-sac", "default", "bare", "omnisafe-saclag"],
    );
}
